//! A scene's product in an HDF5 file (the `mat73` feature): the nearest group above the
//! scene's dataset that holds a given member (NISAR's `metadata/calibrationInformation/geometry`
//! or `metadata/geolocationGrid`, under `/science/LSAR/RSLC` for
//! `/science/LSAR/RSLC/swaths/frequencyA/HH`), and the scene's own axes stored beside it
//! (an RSLC's `swaths/zeroDopplerTime` and `swaths/frequencyA/slantRange`): what the
//! calibration tables (`calibration.rs`) and the geolocation grid (`geolocation.rs`) are placed
//! on the scene's pixels by.

use super::types::H5Stack;
use crate::io::mat::v73::string_attr;

/// What a failed HDF5 call says.
pub(super) fn h5(e: hdf5_metno::Error) -> String {
    e.to_string()
}

/// The groups above the dataset `name`, nearest first, ending with the root.
pub(super) fn ancestors(name: &str) -> Vec<String> {
    let parts: Vec<&str> = name.split('/').filter(|p| !p.is_empty()).collect();
    (0..parts.len())
        .rev()
        .map(|k| format!("/{}", parts[..k].join("/")))
        .collect()
}

/// `group/name` without a doubled slash at the root.
fn join(group: &str, name: &str) -> String {
    format!("{}/{name}", group.trim_end_matches('/'))
}

/// A 1-D dataset of numbers, as `f64`, and its `units` attribute.
pub(super) fn axis(
    g: &hdf5_metno::Group,
    name: &str,
) -> Result<(Vec<f64>, Option<String>), String> {
    let d = g.dataset(name).map_err(h5)?;
    if d.ndim() != 1 {
        return Err(format!("has dimensions {:?}, not one", d.shape()));
    }
    let values = d.read_raw::<f64>().map_err(h5)?;
    Ok((values, string_attr(&d, "units")?))
}

/// Whether the axis at `a` (its `units`) and the scene's axis at `b` count in the same units
/// (where both say): two zero-Doppler times from different epochs must not be compared.
///
/// # Errors
/// Naming both and their units.
pub(super) fn same_units(
    (a, a_units): (&str, &Option<String>),
    (b, b_units): (&str, &Option<String>),
) -> Result<(), String> {
    match (a_units, b_units) {
        (Some(x), Some(y)) if x.trim() != y.trim() => Err(format!(
            "{a} is in {x:?} but {b} in {y:?}: they must share their units (and epoch)"
        )),
        _ => Ok(()),
    }
}

/// The groups from a scene's up to its product's.
pub(super) struct Product {
    /// The groups above the scene, nearest first, up to and including the product's.
    groups: Vec<String>,
}

impl Product {
    /// The nearest group above the dataset `scene` of `file` that holds `member`; `None` if
    /// none does.
    pub(super) fn find(file: &hdf5_metno::File, scene: &str, member: &str) -> Option<Product> {
        let mut groups = ancestors(scene);
        let k = groups
            .iter()
            .position(|g| file.link_exists(&join(g, member)))?;
        groups.truncate(k + 1);
        Some(Product { groups })
    }

    /// The path of `member` in the product's group.
    pub(super) fn join(&self, member: &str) -> String {
        join(self.groups.last().expect("one group at least"), member)
    }

    /// The scene's own axis `name` (`len` values, one per row or column: `side`), found in the
    /// scene's group or one above it up to the product's; its values, its `units` and its
    /// path.
    ///
    /// # Errors
    /// None found (saying where it was looked for and `why` it is wanted), not a 1-D dataset
    /// of numbers, or of another length than `len`.
    pub(super) fn beside(
        &self,
        file: &hdf5_metno::File,
        st: &H5Stack,
        (name, len, side): (&str, usize, &str),
        why: &str,
    ) -> Result<(Vec<f64>, Option<String>, String), String> {
        let (nearest, product) = (&self.groups[0], self.groups.last().expect("one group"));
        let Some(place) = self
            .groups
            .iter()
            .find(|p| file.link_exists(&join(p, name)))
        else {
            return Err(format!(
                "no {name} beside {} (looked in {nearest} and the groups above it up to \
                 {product}), {why}",
                st.dataset
            ));
        };
        let path = join(place, name);
        let grp = file.group(place).map_err(h5)?;
        let (v, units) = axis(&grp, name).map_err(|m| format!("{path}: {m}"))?;
        if v.len() != len {
            return Err(format!(
                "{path} holds {} values for the scene's {len} {side}",
                v.len()
            ));
        }
        Ok((v, units, path))
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn ancestors_run_from_the_nearest_group_to_the_root() {
        assert_eq!(
            super::ancestors("/science/LSAR/RSLC/swaths/frequencyA/HH"),
            [
                "/science/LSAR/RSLC/swaths/frequencyA",
                "/science/LSAR/RSLC/swaths",
                "/science/LSAR/RSLC",
                "/science/LSAR",
                "/science",
                "/"
            ]
        );
        assert_eq!(super::ancestors("frame"), ["/"]);
        assert_eq!(super::join("/", "metadata"), "/metadata");
    }
}
