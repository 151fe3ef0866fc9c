//! The `raw` dataset kind: a headerless little-endian complex64 file of `samples x size`
//! values (either layout) gives the analysis of the same stack read from a `.npy`; a file of
//! the wrong size or a missing shape is refused naming the YAML path. The kind was added in
//! four source files (the spec's kinds, their checks, materialisation, estimate).

mod common;

use ndarray::Array3;
use num_complex::Complex32;
use polars::prelude::ChunkCompareEq;

/// A seeded complex64 stack `[n, h, w]`.
fn stack(n: usize, h: usize, w: usize) -> Array3<Complex32> {
    let mut x = 0x2545_f491_4f6c_dd1du64;
    let mut next = move || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x >> 40) as f32 / (1u64 << 24) as f32 - 0.5
    };
    let mut a = Array3::from_shape_simple_fn((n, h, w), || Complex32::new(next(), next()));
    // Some correlation along rows, so that the maps are not noise alone.
    for i in 0..n {
        for r in 0..h {
            for c in 1..w {
                let prev = a[[i, r, c - 1]];
                a[[i, r, c]] += prev * 0.7;
            }
        }
    }
    a
}

fn raw_bytes(a: &Array3<Complex32>) -> Vec<u8> {
    a.iter()
        .flat_map(|z| z.re.to_le_bytes().into_iter().chain(z.im.to_le_bytes()))
        .collect()
}

#[test]
fn a_raw_file_gives_the_analysis_of_the_same_npy_in_either_layout() {
    let dir = tempfile::tempdir().unwrap();
    let a = stack(12, 8, 8);
    ndarray_npy::write_npy(dir.path().join("s.npy"), &a).unwrap();
    std::fs::write(dir.path().join("s.c64"), raw_bytes(&a)).unwrap();
    let hwn = a
        .view()
        .permuted_axes([1, 2, 0])
        .as_standard_layout()
        .into_owned();
    std::fs::write(dir.path().join("s_hwn.c64"), raw_bytes(&hwn)).unwrap();
    let spec = dir.path().join("s.yaml");
    std::fs::write(
        &spec,
        "name: raw\nseed: 1\ndatasets:\n  - {id: n, kind: npy, path: s.npy}\n  \
         - {id: r, kind: raw, path: s.c64, samples: 12, size: [8, 8]}\n  \
         - {id: t, kind: raw, path: s_hwn.c64, samples: 12, size: [8, 8], layout: hwn}\n\
         analysis:\n  levels: 2\noutputs:\n  npy_maps: false\n",
    )
    .unwrap();
    let out = dir.path().join("out");
    common::run_spec(&spec, &out, &["--no-report"]);
    for name in ["analysis_summary", "pixel_stats"] {
        let df = common::read_table(&out, &format!("{name}.parquet"));
        let of = |id: &str| {
            let mask = df.column("dataset").unwrap().str().unwrap().equal(id);
            let mut part = df.filter(&mask).unwrap().drop("job").unwrap();
            part = part.drop("dataset").unwrap();
            part
        };
        assert!(of("n").height() > 0, "{name}");
        assert!(
            of("n").equals_missing(&of("r")),
            "{name}: raw differs from npy"
        );
        assert!(
            of("n").equals_missing(&of("t")),
            "{name}: raw hwn differs from npy"
        );
    }
    let jobs = common::read_table(&out, "jobs.parquet");
    let kinds = jobs.column("kind").unwrap().str().unwrap();
    assert_eq!(kinds.get(1), Some("raw"));
}

#[test]
fn a_raw_file_of_the_wrong_size_or_without_a_shape_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("s.c64"), raw_bytes(&stack(12, 8, 8))).unwrap();
    let check = |fields: &str| {
        let spec = dir.path().join("s.yaml");
        std::fs::write(
            &spec,
            format!(
                "name: raw\nseed: 1\ndatasets:\n  - {{id: r, kind: raw, path: s.c64{fields}}}\n\
                 analysis:\n  levels: 1\n"
            ),
        )
        .unwrap();
        common::text(&common::bin(&["validate", spec.to_str().unwrap()]))
    };
    let e = check(", samples: 12, size: [8, 9]");
    assert!(
        e.contains("datasets[0].path") && e.contains("holds 6144 bytes") && e.contains("6912"),
        "{e}"
    );
    let e = check(", samples: 12");
    assert!(
        e.contains("datasets[0].size") && e.contains("kind raw needs `size`"),
        "{e}"
    );
    let e = check(", samples: 12, size: [8, 8], variable: x");
    assert!(
        e.contains("does not apply to this dataset (kind raw)"),
        "{e}"
    );
    assert!(check(", samples: 12, size: [8, 8]").contains("valid"));
}
