//! Unit tests of the parent module.

use super::charts::*;
use super::heatmap::*;
use super::*;
use ndarray::Array2;
use std::fs;

fn decode(path: &Path) -> (u32, u32, Vec<u8>) {
    let file = io::BufReader::new(fs::File::open(path).expect("open png"));
    let mut reader = png::Decoder::new(file).read_info().expect("png header");
    let mut buf = vec![0; reader.output_buffer_size().expect("buffer size")];
    let info = reader.next_frame(&mut buf).expect("png frame");
    assert_eq!(info.color_type, png::ColorType::Rgb);
    buf.truncate(info.buffer_size());
    (info.width, info.height, buf)
}

fn dist(a: (u8, u8, u8), b: (u8, u8, u8)) -> f64 {
    let d = |x: u8, y: u8| (f64::from(x) - f64::from(y)).powi(2);
    (d(a.0, b.0) + d(a.1, b.1) + d(a.2, b.2)).sqrt()
}

/// Pixels of the decoded image inside the rectangle `[x0, x1) x [y0, y1)`.
fn pixels(img: &(u32, u32, Vec<u8>), x0: u32, y0: u32, x1: u32, y1: u32) -> Vec<(u8, u8, u8)> {
    let (w, _, buf) = img;
    let mut out = Vec::new();
    for y in y0..y1 {
        for x in x0..x1 {
            let i = 3 * (y * w + x) as usize;
            out.push((buf[i], buf[i + 1], buf[i + 2]));
        }
    }
    out
}

/// Renders a single-panel heat map of `map` on the [-1, 1] scale; returns the decoded PNG.
fn one_panel(dir: &Path, map: &Array2<f64>) -> (u32, u32, Vec<u8>) {
    let panels = vec![vec![Panel {
        title: "p".into(),
        map: map.view(),
    }]];
    let [png, svg] = heatmap_grid(
        dir,
        "one",
        "One",
        &panels,
        Scale::Diverging { lo: -1.0, hi: 1.0 },
        "corr",
    )
    .expect("render");
    assert!(svg.exists());
    decode(&png)
}

fn panel_square() -> (u32, u32, u32, u32) {
    (PAD_L, HEAD + PAD_T, PAD_L + PANEL, HEAD + PAD_T + PANEL)
}

#[test]
fn heatmap_grid_writes_png_and_svg() {
    let dir = tempfile::tempdir().expect("tempdir");
    let maps: Vec<Array2<f64>> = [32usize, 16, 8]
        .iter()
        .map(|&n| {
            Array2::from_shape_fn((n, n), |(r, c)| {
                0.3 + 0.6 * ((r + c) as f64 / (2 * n) as f64)
            })
        })
        .collect();
    let panels: Vec<Vec<Panel>> = (0..3)
        .map(|l| {
            ["H", "V", "D"]
                .iter()
                .map(|d| Panel {
                    title: format!("level {} {d}", l + 1),
                    map: maps[l].view(),
                })
                .collect()
        })
        .collect();
    let [png, svg] = heatmap_grid(
        dir.path(),
        "grid",
        "Correlation grid",
        &panels,
        Scale::Diverging { lo: -1.0, hi: 1.0 },
        "correlation",
    )
    .expect("render");
    assert_eq!(png, dir.path().join("grid.png"));
    let img = decode(&png);
    assert_eq!((img.0, img.1), grid_size(3, 3));
    assert_eq!((img.0, img.1), (1046, 956));
    let text = fs::read_to_string(&svg).expect("svg");
    assert!(
        text.contains("<svg") && text.contains("Correlation grid") && text.contains("level 3 D")
    );
    assert!(text.contains("data:image/png;base64,") && text.contains("width=\"1046\""));
    // Every panel fills its square, whatever its cell count: corners are coloured.
    let bg = (255, 255, 255);
    for r in 0..3 {
        for c in 0..3 {
            let (x, y) = (c * CELL_W + PAD_L, HEAD + r * CELL_H + PAD_T);
            for (px, py) in [(x, y), (x + PANEL - 1, y + PANEL - 1)] {
                assert!(
                    dist(pixels(&img, px, py, px + 1, py + 1)[0], bg) > 40.0,
                    "panel {r},{c} not filled"
                );
            }
        }
    }
    let leftovers: Vec<_> = fs::read_dir(dir.path())
        .expect("ls")
        .map(|e| e.expect("entry").file_name())
        .collect();
    assert_eq!(leftovers.len(), 2, "temporary files left: {leftovers:?}");
}

#[test]
fn heatmap_colours_span_the_scale() {
    let dir = tempfile::tempdir().expect("tempdir");
    let full = Array2::from_shape_fn((9, 9), |(r, c)| -1.0 + 2.0 * (9 * r + c) as f64 / 80.0);
    let img = one_panel(dir.path(), &full);
    let (x0, y0, x1, y1) = panel_square();
    let px = pixels(&img, x0, y0, x1, y1);
    let blue = diverging_rgb(-1.0, -1.0, 1.0);
    let red = diverging_rgb(1.0, -1.0, 1.0);
    let mid = diverging_rgb(0.0, -1.0, 1.0);
    for target in [blue, red, mid, (255, 255, 255)] {
        assert!(
            px.iter().any(|&p| dist(p, target) < 15.0),
            "no pixel near {target:?}"
        );
    }
    let half = Array2::from_shape_fn((9, 9), |(r, c)| 0.5 * (9 * r + c) as f64 / 80.0);
    let img = one_panel(dir.path(), &half);
    let px = pixels(&img, x0, y0, x1, y1);
    assert!(
        px.iter().all(|&p| dist(p, blue) > 60.0),
        "blue end colour drawn for values in [0, 0.5]"
    );
}

#[test]
fn nan_cells_are_grey_and_listed() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut map = Array2::from_elem((4, 4), 0.8);
    map[[0, 3]] = f64::NAN;
    let img = one_panel(dir.path(), &map);
    let (x0, y0, ..) = panel_square();
    let cell = PANEL / 4;
    let at = |r: u32, c: u32| {
        pixels(
            &img,
            x0 + c * cell + cell / 2,
            y0 + r * cell + cell / 2,
            x0 + c * cell + cell / 2 + 1,
            y0 + r * cell + cell / 2 + 1,
        )[0]
    };
    assert_eq!(at(0, 3), NAN_RGB);
    assert_eq!(at(1, 3), diverging_rgb(0.8, -1.0, 1.0));
    let svg = fs::read_to_string(dir.path().join("one.svg")).expect("svg");
    assert!(
        svg.contains(">\nNaN\n<") || svg.contains(">NaN<"),
        "NaN legend missing"
    );
}

#[test]
fn large_map_is_resampled() {
    let dir = tempfile::tempdir().expect("tempdir");
    let map = Array2::from_shape_fn((1024, 1024), |(r, c)| {
        ((r * 7 + c * 13) % 101) as f64 / 50.0 - 1.0
    });
    let panels = vec![vec![Panel {
        title: "big".into(),
        map: map.view(),
    }]];
    let [png, _] = heatmap_grid(
        dir.path(),
        "big",
        "Big",
        &panels,
        Scale::Perceptual,
        "value",
    )
    .expect("render");
    let (w, h, _) = decode(&png);
    assert_eq!((w, h), grid_size(1, 1));
}

#[test]
fn histograms_and_curves_write_files() {
    let dir = tempfile::tempdir().expect("tempdir");
    let a: Vec<f64> = (0..500).map(|i| (i as f64 * 0.37).sin()).collect();
    let b: Vec<f64> = (0..300)
        .map(|i| 0.5 + (i as f64 * 0.11).cos() * 0.4)
        .chain([f64::NAN])
        .collect();
    let [png, svg] = histograms(
        dir.path(),
        "hist",
        "Value histograms",
        &[("real", &a), ("synthetic", &b)],
        30,
        "value",
    )
    .expect("hist");
    let (w, h, _) = decode(&png);
    assert_eq!((w, h), CHART_SIZE);
    let text = fs::read_to_string(&svg).expect("svg");
    assert!(
        text.contains("<svg")
            && text.contains("Value histograms")
            && text.contains("synthetic (1 non-finite)")
    );

    let s1: Vec<(f64, f64)> = (1..=8).map(|i| (i as f64, 1.0 - 0.5 / i as f64)).collect();
    let s2: Vec<(f64, f64)> = (1..=8).map(|i| (i as f64, 0.4 + 0.05 * i as f64)).collect();
    let [png, svg] = curves(
        dir.path(),
        "curves",
        "Accuracy vs levels",
        &[("svm", &s1), ("knn", &s2)],
        "levels",
        "accuracy",
    )
    .expect("curves");
    let (w, h, _) = decode(&png);
    assert_eq!((w, h), CHART_SIZE);
    let text = fs::read_to_string(&svg).expect("svg");
    assert!(text.contains("<svg") && text.contains("Accuracy vs levels") && text.contains("knn"));
}

#[test]
fn error_bars_are_drawn_in_their_series_colour() {
    let dir = tempfile::tempdir().expect("tempdir");
    let pts = [(100.0, 50.0, 0.0), (250.0, 70.0, 0.0), (500.0, 80.0, 0.0)];
    let bars = [(100.0, 50.0, 20.0), (250.0, 70.0, 10.0), (500.0, 80.0, 5.0)];
    let draw = |stem: &str, p: &[(f64, f64, f64)]| {
        let [png, svg] = error_curves(
            dir.path(),
            stem,
            "Accuracy vs N",
            &[("method1", p)],
            ("training size N", "accuracy (%)"),
            Some(0.0..100.0),
        )
        .expect("error curves");
        // The fixed y range shows its ends although the points span 45-85 %.
        let text = fs::read_to_string(&svg).expect("svg");
        for tick in ["0.0", "100.0"] {
            assert!(text.lines().any(|l| l.trim() == tick), "no y tick {tick}");
        }
        decode(&png)
    };
    let (plain, barred) = (draw("plain", &pts), draw("bars", &bars));
    assert_eq!((plain.0, plain.1), CHART_SIZE);
    // The bars add pixels of the series' colour (tab10's first): three bars of 40, 20 and 10 %
    // of a plot about 400 px high, 2 px wide, less what the line already covers.
    let blue = |img: &(u32, u32, Vec<u8>)| {
        img.2
            .chunks(3)
            .filter(|p| dist((p[0], p[1], p[2]), (31, 119, 180)) < 40.0)
            .count()
    };
    let added = blue(&barred) as i64 - blue(&plain) as i64;
    assert!(added > 300, "{added} blue pixels added");
    let bad = error_curves(
        dir.path(),
        "bad",
        "t",
        &[("m", &pts)],
        ("x", "y"),
        Some(1.0..0.0),
    );
    assert!(bad.is_err());
}

#[test]
fn boxes_outline_cells_and_labels_are_ours() {
    let dir = tempfile::tempdir().expect("tempdir");
    let map = Array2::from_elem((8, 8), 0.0);
    let panels = vec![vec![Panel {
        title: "p".into(),
        map: map.view(),
    }]];
    let options = GridOptions {
        x_label: "predicted class",
        y_label: "true class",
        annotate: false,
        boxes: vec![vec![[2, 2, 2, 2]]],
    };
    let [png, svg] = heatmap_grid_with(
        dir.path(),
        "boxed",
        "Boxed",
        &panels,
        (Scale::Diverging { lo: -1.0, hi: 1.0 }, "v"),
        &options,
    )
    .expect("render");
    let text = fs::read_to_string(&svg).expect("svg");
    assert!(text.contains("predicted class") && text.contains("true class"));
    let img = decode(&png);
    // 8 cells on 224 px: 28 px a cell, so the box spans pixels 56..112 of the panel; its black
    // core is on the edge, white beside it, the inside keeps the map's colour.
    let (x0, y0, _, _) = panel_square();
    let at = |dx: u32, dy: u32| pixels(&img, x0 + dx, y0 + dy, x0 + dx + 1, y0 + dy + 1)[0];
    assert!(dist(at(56, 84), (0, 0, 0)) < 60.0, "{:?}", at(56, 84));
    assert!(dist(at(57, 84), (255, 255, 255)) < 30.0, "{:?}", at(57, 84));
    let inside = diverging_rgb(0.0, -1.0, 1.0);
    assert!(dist(at(84, 84), inside) < 10.0, "{:?}", at(84, 84));
    assert!(dist(at(20, 84), inside) < 10.0, "outside: {:?}", at(20, 84));
}

#[test]
fn bad_input_names_the_file() {
    let dir = tempfile::tempdir().expect("tempdir");
    let err =
        heatmap_grid(dir.path(), "empty", "t", &[], Scale::Perceptual, "v").expect_err("no panels");
    assert!(
        matches!(err, FigureError::Input { .. }) && err.to_string().contains("empty.{png,svg}")
    );
    assert!(histograms(dir.path(), "a/b", "t", &[("x", &[1.0])], 5, "x").is_err());
    assert!(curves(dir.path(), "c", "t", &[], "x", "y").is_err());
}

#[test]
fn colour_scales() {
    assert!(dist(diverging_rgb(0.0, -1.0, 1.0), (255, 255, 255)) < 15.0);
    assert_eq!(diverging_rgb(-1.0, -1.0, 1.0), (5, 48, 97));
    assert_eq!(diverging_rgb(1.0, -1.0, 1.0), (103, 0, 31));
    assert_eq!(diverging_rgb(-5.0, -1.0, 1.0), (5, 48, 97));
    assert_eq!(diverging_rgb(f64::NAN, -1.0, 1.0), NAN_RGB);
    // Lightness rises towards the midpoint and falls after it; blue side is blue, red side red.
    let luma = |(r, g, b): (u8, u8, u8)| {
        0.299 * f64::from(r) + 0.587 * f64::from(g) + 0.114 * f64::from(b)
    };
    let vs: Vec<f64> = (0..=200).map(|i| -1.0 + i as f64 / 100.0).collect();
    for w in vs.windows(2) {
        let (a, b) = (
            diverging_rgb(w[0], -1.0, 1.0),
            diverging_rgb(w[1], -1.0, 1.0),
        );
        if w[1] <= 0.0 {
            assert!(
                luma(b) >= luma(a) - 1e-9 && a.2 >= a.0,
                "not monotone at {}",
                w[0]
            );
        } else if w[0] >= 0.0 {
            assert!(
                luma(b) <= luma(a) + 1e-9 && b.0 >= b.2,
                "not monotone at {}",
                w[0]
            );
        }
    }
    assert_eq!(viridis_rgb(0.0), (0x44, 0x01, 0x54));
    assert_eq!(viridis_rgb(1.0), (0xfd, 0xe7, 0x25));
    assert!(dist(viridis_rgb(0.5), (33, 145, 140)) < 4.0);
}

#[test]
fn helpers() {
    assert_eq!(base64(b"Man"), "TWFu");
    assert_eq!(base64(b"Ma"), "TWE=");
    assert_eq!(base64(b"M"), "TQ==");
    assert_eq!(nice_step(32.0, 6.0), 10.0);
    assert_eq!(nice_step(2.0, 5.0), 0.5);
    assert_eq!(fmt_tick(-1e-17, 0.5), "0.0");
    assert_eq!(
        resample(
            Array2::from_shape_vec((2, 2), vec![1.0, f64::NAN, 3.0, f64::NAN])
                .expect("shape")
                .view(),
            1,
            1
        ),
        vec![2.0]
    );
    assert_eq!(
        (fit(32, 32), fit(8, 8), fit(16, 64)),
        ((224, 224), (224, 224), (224, 56))
    );
    assert_eq!(span(6, 32, 224), 0..1);
    assert_eq!(span(7, 32, 224), 1..2);
}

#[test]
fn resample_matches_the_slow_oracle_bit_for_bit() {
    // Enlarging, shrinking, mixed and odd sizes, with NaN cells (a whole NaN block too).
    for (rows, cols, w, h) in [
        (32, 32, 224, 224),
        (8, 8, 224, 224),
        (64, 64, 224, 224),
        (300, 17, 56, 224),
        (16, 64, 224, 56),
        (5, 7, 13, 11),
        (1, 1, 3, 2),
    ] {
        let map = Array2::from_shape_fn((rows, cols), |(r, c)| {
            if (r * 7 + c * 3) % 11 == 0 || (r < 4 && c < 4) {
                f64::NAN
            } else {
                ((r * cols + c) as f64 * 0.37).sin() * 1e3
            }
        });
        let (fast, slow) = (resample(map.view(), w, h), resample_slow(map.view(), w, h));
        assert_eq!(fast.len(), slow.len());
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&fast), bits(&slow), "{rows}x{cols} -> {w}x{h} differs");
    }
}
