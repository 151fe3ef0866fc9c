//! Figures and the report (issue 6): a small experiment with a sweep, synthesis, metrics and
//! saved samples runs with its report; every figure is a non-empty image of the size its file
//! claims; every file the report references exists; `report DIR` rebuilds the same page; and
//! headless Chromium loads the page from disk with every image loaded (its screenshot is kept
//! under the cargo target's test folder). Without Chromium the browser part is skipped, except
//! under `CI=true`, where it fails.

use std::path::{Path, PathBuf};
use std::process::Command;

const SPEC: &str = "name: report_test
seed: 11
description: A small experiment exercising every kind of figure.
datasets:
  - id: d
    kind: filtered_noise
    family: exponential
    alpha_h: {pattern: left_right, left: 0.5, right: 2.0}
    alpha_v: 1.0
    size: [32, 32]
    samples: 60
    half_width: 4
analysis:
  levels: 2
synthesis:
  methods: [method1, method2, full_covariance]
  samples: 80
  save_samples: true
metrics: [multiscale_rmse, cmd, kl_pixel, {kl_area: {block: 8}}]
sweep:
  grid:
    datasets.d.alpha_v: [0.5, 1.0, 2.0]
";

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_isar-clutter"))
}

/// `src`/`href` attribute values of an HTML page.
fn references(html: &str) -> Vec<String> {
    let mut out = vec![];
    for attr in ["src=\"", "href=\""] {
        let mut rest = html;
        while let Some(i) = rest.find(attr) {
            rest = &rest[i + attr.len()..];
            let end = rest.find('"').unwrap();
            out.push(rest[..end].replace("&amp;", "&"));
            rest = &rest[end..];
        }
    }
    out
}

fn chromium() -> Option<PathBuf> {
    if let Ok(p) = std::env::var("CHROMIUM") {
        return Some(PathBuf::from(p));
    }
    ["chromium", "chromium-browser", "google-chrome"]
        .iter()
        .find_map(|b| {
            let ok = Command::new("sh")
                .args(["-c", &format!("command -v {b}")])
                .output()
                .ok()?;
            ok.status
                .success()
                .then(|| PathBuf::from(String::from_utf8_lossy(&ok.stdout).trim()))
        })
}

/// Decoded RGB pixels `(width, height, bytes)` of a PNG.
fn decode(path: &Path) -> (u32, u32, Vec<u8>) {
    let file = std::io::BufReader::new(std::fs::File::open(path).unwrap());
    let mut reader = png::Decoder::new(file).read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgb);
    buf.truncate(info.buffer_size());
    (info.width, info.height, buf)
}

/// PNG width and height from the IHDR chunk.
fn png_size(p: &Path) -> (u32, u32) {
    let b = std::fs::read(p).unwrap();
    assert_eq!(
        &b[..8],
        b"\x89PNG\r\n\x1a\n",
        "{} is not a PNG",
        p.display()
    );
    let be = |i: usize| u32::from_be_bytes(b[i..i + 4].try_into().unwrap());
    (be(16), be(20))
}

#[test]
fn the_report_references_existing_figures_and_loads_in_a_browser() {
    let tmp = tempfile::tempdir().unwrap();
    let spec = tmp.path().join("spec.yaml");
    std::fs::write(&spec, SPEC).unwrap();
    let out = tmp.path().join("out");
    let o = bin()
        .args(["run", spec.to_str().unwrap(), "--quiet", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let html_path = out.join("report.html");
    let html = std::fs::read_to_string(&html_path).unwrap();
    // Every referenced file exists, and no reference leaves the folder or the machine.
    let refs = references(&html);
    let local: Vec<&String> = refs.iter().filter(|r| !r.starts_with('#')).collect();
    assert!(local.len() > 20, "{} references", local.len());
    for r in &local {
        assert!(
            !r.contains("://") && !r.starts_with('/') && !r.contains(".."),
            "{r}"
        );
        assert!(out.join(r).is_file(), "the report references missing {r}");
    }
    // The figures a reader expects are there, as PNG and SVG.
    let job = "d.method2.alpha_v=1.0";
    for stem in [
        "correlation",
        "covariance",
        "histogram_level1",
        "mean",
        "variance",
        "kl_pixel",
        "kl_area",
        "filter_parameters",
        "sample",
    ] {
        let png = format!("figures/{job}/{stem}.png");
        assert!(local.iter().any(|r| **r == png), "no {png} in the report");
        let (w, h) = png_size(&out.join(&png));
        assert!(w >= 200 && h >= 150, "{png}: {w}x{h}");
        let svg = std::fs::read_to_string(out.join(format!("figures/{job}/{stem}.svg"))).unwrap();
        assert!(svg.contains("<svg"), "{stem}.svg");
    }
    assert!(local
        .iter()
        .any(|r| r.starts_with("figures/d.alpha_v=1.0/expected_correlation")));
    assert!(local
        .iter()
        .any(|r| r.starts_with("figures/d.alpha_v=1.0/noise_floor_kl_pixel")));
    // Colour range of a real figure: this clutter is positively correlated everywhere
    // (level-1 correlations about 0.3-0.9), so the [-1, 1] diverging scale shows reds near its
    // upper part but none of the blues of correlations below -0.5, outside the colour bar.
    let corr = decode(&out.join(format!("figures/{job}/correlation.png")));
    // Panels only: the colour bar (the right-most 140 px) holds every colour of the scale.
    let (w, panels) = (corr.0 as usize, corr.0 as usize - 140);
    let near = |c: (u8, u8, u8)| {
        corr.2
            .chunks(3)
            .enumerate()
            .filter(|(i, _)| i % w < panels)
            .map(|(_, p)| p)
            .filter(|p| {
                let d = |x: u8, y: u8| (f64::from(x) - f64::from(y)).powi(2);
                (d(p[0], c.0) + d(p[1], c.1) + d(p[2], c.2)).sqrt() < 12.0
            })
            .count()
    };
    use isar_clutter::report::figures::diverging_rgb;
    assert!(
        near(diverging_rgb(0.6, -1.0, 1.0)) > 500,
        "reds of rho = 0.6"
    );
    for rho in [-0.6, -0.8] {
        assert_eq!(
            near(diverging_rgb(rho, -1.0, 1.0)),
            0,
            "cells drawn for rho = {rho}"
        );
    }
    assert!(
        local
            .iter()
            .any(|r| r.starts_with("figures/sweep_d__original__alpha_v")),
        "a curve over the swept alpha_v"
    );
    assert!(
        local
            .iter()
            .any(|r| r.starts_with("figures/sweep_d__multiscale_RMSE__average_level_1_alpha_v")),
        "similarity against the swept alpha_v"
    );
    // Tables, spec and provenance are on the page.
    for needle in [
        "Correlation matrix distance",
        "Multiscale correlation RMSE",
        "<h2 id=\"spec\">",
        "master seed",
        "report_test",
    ] {
        assert!(html.contains(needle), "report lacks {needle:?}");
    }
    // `report` rebuilds the same page from the files alone, and drops the figures an earlier
    // report drew for a job that is no longer in the run (as an edited spec leaves them): the
    // tool's records (its journal) list them. A user's own file in figures/ is kept.
    std::fs::remove_file(&html_path).unwrap();
    let stale = out.join("figures").join("removed_job");
    std::fs::create_dir_all(&stale).unwrap();
    std::fs::write(stale.join("correlation.png"), b"old").unwrap();
    let stale_sweep = out
        .join("figures")
        .join("sweep_correlation_removed_axis.svg");
    std::fs::write(&stale_sweep, b"old").unwrap();
    let mut journal = std::fs::OpenOptions::new()
        .append(true)
        .open(out.join(".isar-clutter/journal"))
        .unwrap();
    std::io::Write::write_all(
        &mut journal,
        b"figures/removed_job/correlation.png\nfigures/sweep_correlation_removed_axis.svg\n",
    )
    .unwrap();
    let users = out.join("figures").join("my_annotated.png");
    std::fs::write(&users, b"mine").unwrap();
    let o = bin().arg("report").arg(&out).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(std::fs::read_to_string(&html_path).unwrap(), html);
    assert!(!stale.exists(), "stale job figures were kept");
    assert!(!stale_sweep.exists(), "a stale run-wide figure was kept");
    assert_eq!(
        std::fs::read(&users).unwrap(),
        b"mine",
        "a user's file was removed"
    );
    // Every figure the page shows is still there (checked above for the first build).
    for r in &local {
        assert!(out.join(r).is_file(), "the rebuilt report lost {r}");
    }

    // The browser test.
    let Some(browser) = chromium() else {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "CI must run the browser test: `make test-deps` installs chromium"
        );
        eprintln!("SKIPPED the browser part: no chromium (make test-deps installs it)");
        return;
    };
    let url = format!("file://{}", html_path.display());
    let common = [
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--allow-file-access-from-files",
        "--virtual-time-budget=15000",
    ];
    let dom = Command::new(&browser)
        .args(common)
        .arg("--dump-dom")
        .arg(&url)
        .output()
        .unwrap();
    assert!(
        dom.status.success(),
        "{}",
        String::from_utf8_lossy(&dom.stderr)
    );
    let dom = String::from_utf8_lossy(&dom.stdout);
    let attr = |name: &str| -> usize {
        let key = format!("{name}=\"");
        let i = dom
            .find(&key)
            .unwrap_or_else(|| panic!("no {name} in the DOM: the load handler did not run"));
        let rest = &dom[i + key.len()..];
        rest[..rest.find('"').unwrap()].parse().unwrap()
    };
    let (total, loaded) = (attr("data-images-total"), attr("data-images-loaded"));
    assert!(total >= 20, "{total} images");
    assert_eq!(loaded, total, "images that failed to load in Chromium");
    let shot = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("report-screenshot.png");
    let _ = std::fs::remove_file(&shot);
    let o = Command::new(&browser)
        .args(common)
        .arg(format!("--screenshot={}", shot.display()))
        .arg("--window-size=1280,4000")
        .arg(&url)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(png_size(&shot), (1280, 4000));
    eprintln!("report screenshot: {}", shot.display());
}
