//! Where a run's CNN trainings run: `run --device` in place of every section's
//! `training.device`, and `auto` (or `cuda`) resolved once before the jobs are planned, into
//! the device itself and the line the manifest records (docs/cnn.md, *On a GPU*).

use crate::apps::cnn::device::resolve;
use crate::apps::cnn::train::{Device, TrainingOptions};
use crate::run::plan::Plan;
use anyhow::Result;

impl Plan {
    /// Every CNN section's `training.device` set to `device` (`run --device`).
    pub fn set_training_device(&mut self, device: Device) {
        for t in self.trainings_mut() {
            t.device = device;
        }
    }

    /// Resolves each CNN section's device (`auto` to `cuda` or `cpu`, `cuda` checked here),
    /// keeping the line that says what it is in [`Plan::training_device`]; `None` without a
    /// CNN section.
    ///
    /// # Errors
    /// `cuda` that cannot be used here (no `cuda` feature, no GPU, driver, NVRTC or cuDNN).
    pub fn resolve_training_device(&mut self) -> Result<Option<String>> {
        let mut lines: Vec<String> = vec![];
        for t in self.trainings_mut() {
            let (device, line) = resolve(t.device)
                .map_err(|e| e.context("training.device (or --device) is cuda"))?;
            t.device = device;
            if !lines.contains(&line) {
                lines.push(line);
            }
        }
        self.training_device = (!lines.is_empty()).then(|| lines.join("; "));
        Ok(self.training_device.clone())
    }

    /// The training blocks of the CNN sections.
    fn trainings_mut(&mut self) -> impl Iterator<Item = &mut TrainingOptions> {
        let cnn = &mut self.cnn;
        cnn.classification
            .iter_mut()
            .map(|c| &mut c.training)
            .chain(cnn.location.iter_mut().map(|l| &mut l.training))
    }
}
