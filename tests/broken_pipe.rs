//! A closed stdout (`isar-clutter run SPEC --dry-run | head -c 1`) ends a command quietly, as
//! with other Unix tools, instead of a panic in `println!` on "Broken pipe".

#[test]
fn a_closed_stdout_is_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let spec = dir.path().join("big.yaml");
    // 5,000 jobs: the job table is far larger than a pipe's buffer, so the writer is still
    // writing when `head` has gone.
    let values: Vec<String> = (0..5000)
        .map(|i| format!("{:.5}", 1.0 + i as f64 * 1e-4))
        .collect();
    std::fs::write(
        &spec,
        format!(
            "name: big\nseed: 1\ndatasets:\n  - id: t\n    kind: filtered_noise\n    family: \
             exponential\n    alpha_h: 1.0\n    alpha_v: 1.0\n    size: [16, 16]\n    samples: \
             10\nanalysis:\n  levels: 1\nsweep:\n  zip:\n    datasets.t.alpha_h: [{}]\n",
            values.join(", ")
        ),
    )
    .unwrap();
    let out = std::process::Command::new("sh")
        .arg("-c")
        .arg(format!(
            "\"{}\" run \"{}\" --dry-run | head -c 1 >/dev/null",
            env!("CARGO_BIN_EXE_isar-clutter"),
            spec.display()
        ))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "{err}");
}
