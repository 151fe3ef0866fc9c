//! The sections of the CNN applications (ch. 5.3, docs/definitions.md §12), one file each
//! (`classification`, `location`): what a user writes and its validation against the datasets.
//! Every value that the networks, the splits or the data sets cannot take is refused with its
//! YAML path, before anything runs. What they share is in `common`; this file lists the
//! sections ([`CnnSections`]) and validates them into [`Applications`].

use super::context::{Ctx, SpecError};
mod classification;
mod common;
mod location;

pub use classification::{ClassificationPlan, ClassificationSpec};
pub use common::{DataRef, OneOrMany, MAX_TRAININGS};
pub use location::{LocationPlan, LocationSpec};

/// The CNN sections of a spec as written, one field per application ([`RawSpec::cnn`] makes
/// it from the spec's fields).
///
/// [`RawSpec::cnn`]: super::RawSpec::cnn
#[derive(Debug, Clone, Copy)]
pub struct CnnSections<'a> {
    /// The `classification` section.
    pub classification: Option<&'a ClassificationSpec>,
    /// The `location` section.
    pub location: Option<&'a LocationSpec>,
}

/// The validated CNN sections of a spec, one field per application. A new application is a
/// field here (its section's plan); the compiler then names the two places that list the
/// applications: [`CnnSections`] (and through it the spec's field), [`Applications::validate`]
/// below and the runner's `run::jobs::cnn::jobs`.
#[derive(Debug, Clone, Default)]
pub struct Applications {
    /// The validated `classification` section.
    pub classification: Option<ClassificationPlan>,
    /// The validated `location` section.
    pub location: Option<LocationPlan>,
}

impl Applications {
    /// Validates the spec's CNN sections against the stacks of the plan's analysis jobs
    /// (`stacks` lists them; called once, and only when a section is present).
    ///
    /// # Errors
    /// A [`SpecError`] with the YAML path of the first problem.
    pub fn validate(
        sections: CnnSections,
        ctx: &Ctx,
        stacks: impl Fn() -> Vec<DataRef>,
    ) -> Result<Self, SpecError> {
        let listed = std::cell::OnceCell::new();
        let stacks = || listed.get_or_init(&stacks).as_slice();
        let CnnSections {
            classification,
            location,
        } = sections;
        Ok(Applications {
            classification: classification
                .map(|c| c.validate(ctx, stacks()))
                .transpose()?,
            location: location.map(|l| l.validate(ctx, stacks())).transpose()?,
        })
    }
}
