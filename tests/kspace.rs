//! The `kspace` dataset kind: measured `E(f, phi)` through the same imaging chain as the
//! simulator. k-space data simulated for a plant, written as `.npy` with their frequency and
//! azimuth vectors, must image to exactly the simulator's own images; bad axes are refused.

use isar_clutter::physics::isar::{ImagingOptions, Measurement};
use isar_clutter::physics::vegetation::{try_simulate, SceneParams};
use isar_clutter::run::plan;
use ndarray::Array1;
use ndarray_npy::WriteNpyExt;
use std::fs::File;

#[test]
fn measured_kspace_images_like_the_simulator() {
    let dir = tempfile::tempdir().unwrap();
    let m = Measurement::uniform(2e9, 18e9, 48, 51f64.to_radians(), 40).unwrap();
    let opts = ImagingOptions {
        size: 16,
        ..Default::default()
    };
    let scene = SceneParams::preset("B", "light").unwrap();
    let (k, images) = try_simulate(&scene, &m, &opts, 5, 21).unwrap();
    assert_eq!(k.dim(), (5, 48, 40));
    k.write_npy(File::create(dir.path().join("e.npy")).unwrap())
        .unwrap();
    Array1::from(m.freqs.clone())
        .write_npy(File::create(dir.path().join("f.npy")).unwrap())
        .unwrap();
    let az: Vec<String> = m
        .azimuths
        .iter()
        .map(|a| format!("{}", a.to_degrees()))
        .collect();
    let spec = dir.path().join("k.yaml");
    std::fs::write(
        &spec,
        format!(
            "name: k\nseed: 1\ndatasets:\n  - id: meas\n    kind: kspace\n    path: e.npy\n    freqs: f.npy\n    azimuths_deg: [{}]\n    image_size: 16\nanalysis:\n  levels: 2\n",
            az.join(", ")
        ),
    )
    .unwrap();
    let p = plan::load(&spec).unwrap();
    let job = &p.jobs[0];
    assert_eq!(job.dataset.shape(), (5, 16, 16));
    let got = job
        .dataset
        .materialise(job.data_seed)
        .unwrap()
        .stack
        .to_complex128(false);
    let worst = got
        .iter()
        .zip(images.iter())
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, f64::max);
    let scale = images.iter().map(|z| z.norm()).fold(0.0, f64::max);
    // Azimuths pass through degrees in the spec text: agreement to rounding.
    assert!(worst <= 1e-9 * scale, "worst {worst} of {scale}");

    // Bad axes name their field.
    std::fs::write(
        &spec,
        "name: k\nseed: 1\ndatasets:\n  - id: meas\n    kind: kspace\n    path: e.npy\n    freqs: [1.0, 2.0]\n    azimuths_deg: [0, 1]\nanalysis:\n  levels: 1\n",
    )
    .unwrap();
    let e = plan::load(&spec).unwrap_err().to_string();
    assert!(
        e.contains("datasets[0].freqs") && e.contains("48 along this axis"),
        "{e}"
    );
}
