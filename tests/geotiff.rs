//! The `geotiff` dataset kind against files it did not write: complex GeoTIFF scenes written
//! by GDAL through rasterio (`tests/geotiff/make_fixtures.py`, run at test time in the
//! project's virtualenv `.venv`): complex int16 strips (Sentinel-1's layout) and deflated
//! complex float32 tiles give, in a window, the analysis the same pixels give when rasterio
//! reads them and saves them as `.npy`, value for value (a window given in pixels or as a box
//! of map coordinates, or cut into patches as `isar-clutter cut` cuts them), and their
//! georeferencing reaches the manifest; a box of longitude and latitude over ground control
//! points is the window GDAL's GCP transformer gives; a truncated file, an unsigned 8-bit image, an LZW-compressed one and a window
//! outside the scenes are refused at validation, naming the file and the field.

mod common;
use common::scenes::{
    assert_same_tables, assert_valid, cut_cli, dataset_files, refused, run, CUT_FIELDS,
};

use serde_json::json;
use std::path::{Path, PathBuf};

/// The fixture folder in `dir`; `None` (skip) without rasterio in `.venv`.
fn fixtures(dir: &Path) -> Option<PathBuf> {
    common::python_fixtures(
        "tests/geotiff/make_fixtures.py",
        &["numpy", "rasterio"],
        &dir.join("fixtures"),
    )
}

/// The stack of windows of the scenes `prefix_0{k}.tif`, as `kind: geotiff` fields.
fn geotiff_fields(prefix: &str) -> String {
    let files: Vec<String> = (0..3)
        .map(|k| format!("fixtures/{prefix}_0{k}.tif"))
        .collect();
    format!(
        "kind: geotiff, path: [{}], window: {{row: 5, col: 7, size: [16, 16]}}",
        files.join(", ")
    )
}

#[test]
fn geotiff_window_stacks_are_analysed_as_rasterio_reads_their_pixels() {
    let dir = tempfile::tempdir().unwrap();
    let Some(_) = fixtures(dir.path()) else {
        return;
    };
    let d = dir.path();
    let s1 = run(d, "s1", &geotiff_fields("s1"));
    assert_same_tables(
        &s1,
        &run(d, "s1_npy", "kind: npy, path: fixtures/window.npy"),
    );
    let tiled = run(d, "tiled", &geotiff_fields("tiled"));
    let npy = run(d, "tiled_npy", "kind: npy, path: fixtures/tiled_window.npy");
    assert_same_tables(&tiled, &npy);
    // The same window as a box of UTM coordinates (2.5 m columns, 5 m rows from 500000 E,
    // 5300000 N).
    let files: Vec<String> = (0..3).map(|k| format!("fixtures/tiled_0{k}.tif")).collect();
    let map = format!(
        "kind: geotiff, path: [{}], window: {{x: [500017.5, 500057.5], y: [5299895, 5299975]}}",
        files.join(", ")
    );
    assert_same_tables(&run(d, "tiled_map", &map), &npy);
    // Georeferencing: Sentinel-1's ground control points in WGS 84 (EPSG 4326, GeoKey
    // 2048), and the tiled scenes' UTM grid as an affine transform (EPSG 32632, GeoKey 3072).
    let files = dataset_files(&s1);
    let f = &files["files"][0];
    assert_eq!(
        (&f["pixel"], &f["blocks"]),
        (&json!("CInt16"), &json!("strips")),
        "{f}"
    );
    assert_eq!(f["georef"]["tiepoints"].as_array().unwrap().len(), 4, "{f}");
    assert_eq!(f["georef"]["tiepoints"][3][3], json!(11.003), "{f}");
    assert_eq!(f["georef"]["geokeys"]["2048"][0], json!(4326), "{f}");
    assert_eq!(files["window"]["rows"], json!([5, 21]));
    let files = dataset_files(&tiled);
    let f = &files["files"][2];
    assert_eq!(
        (&f["pixel"], &f["blocks"], &f["compression"]),
        (&json!("CFloat32"), &json!("tiles"), &json!("deflate")),
        "{f}"
    );
    assert_eq!(
        f["georef"]["affine"],
        json!([500000.0, 2.5, 0.0, 5300000.0, 0.0, -5.0]),
        "{f}"
    );
    assert_eq!(f["georef"]["geokeys"]["3072"][0], json!(32632), "{f}");
}

#[test]
fn a_cut_geotiff_stack_is_the_stack_cut_cuts_from_rasterios_pixels() {
    let dir = tempfile::tempdir().unwrap();
    let Some(fx) = fixtures(dir.path()) else {
        return;
    };
    let d = dir.path();
    let files: Vec<String> = (0..3).map(|k| format!("fixtures/s1_0{k}.tif")).collect();
    let fields = format!("kind: geotiff, path: [{}], {CUT_FIELDS}", files.join(", "));
    let ours = run(d, "cut", &fields);
    // `isar-clutter cut` of the same scenes as rasterio read them, one [3, 40, 30] time stack.
    cut_cli(&[fx.join("scenes.npy")], &fx.join("cut.npy"), &[]);
    let npy = run(d, "cut_npy", "kind: npy, path: fixtures/cut.npy");
    assert_same_tables(&ours, &npy);
    // `isar-clutter cut` of the GeoTIFF scenes themselves: the same stack, byte for byte.
    let tifs: Vec<PathBuf> = (0..3).map(|k| fx.join(format!("s1_0{k}.tif"))).collect();
    let tif_cut = fx.join("tif_cut.npy");
    let said = cut_cli(&tifs, &tif_cut, &["--chunk", "4"]);
    assert!(
        said.contains("42 patch(es) of 8x8 (14 place(s) x 3 scene(s))"),
        "{said}"
    );
    assert_eq!(
        std::fs::read(&tif_cut).unwrap(),
        std::fs::read(fx.join("cut.npy")).unwrap()
    );
    // Within a triangle too: the dataset's `polygon` is `cut --polygon`.
    let triangle = "[[2, 1], [2, 29], [38, 15]]";
    let with = CUT_FIELDS.replace(
        "size: [4, 4]}]}",
        &format!("size: [4, 4]}}], polygon: {triangle}}}"),
    );
    let fields = format!("kind: geotiff, path: [{}], {with}", files.join(", "));
    let tri = run(d, "triangle", &fields);
    cut_cli(
        &[fx.join("scenes.npy")],
        &fx.join("tri.npy"),
        &["--polygon", "2,1;2,29;38,15"],
    );
    assert_same_tables(
        &tri,
        &run(d, "tri_npy", "kind: npy, path: fixtures/tri.npy"),
    );
    assert!(dataset_files(&tri)["cut"]["places"].as_u64().unwrap() < 14);
    // `isar-clutter cut` with the triangle, and then the window, by longitude and latitude
    // (x = 11 + col / 10^4, y = 48 - row / 10^4 through the ground control points): the
    // stacks of the pixel options, byte for byte.
    let tri_map = fx.join("tri_map.npy");
    cut_cli(
        &tifs,
        &tri_map,
        &[
            "--map-polygon",
            "11.0001,47.9998;11.0029,47.9998;11.0015,47.9962",
        ],
    );
    assert_eq!(
        std::fs::read(&tri_map).unwrap(),
        std::fs::read(fx.join("tri.npy")).unwrap()
    );
    let boxed = fx.join("box_cut.npy");
    let mut args: Vec<String> = vec!["cut".into()];
    for t in &tifs {
        args.extend(["--input".into(), t.display().to_string()]);
    }
    args.extend(
        [
            "--patch",
            "8",
            "--stride",
            "8x6",
            "--avoid",
            "10:14,10:14",
            "--map-box",
            "11.0001,11.0029,47.9962,47.9998",
            "--out",
        ]
        .map(String::from),
    );
    args.push(boxed.display().to_string());
    let o = common::bin(&args);
    assert!(o.status.success(), "{}", common::text(&o));
    assert_eq!(
        std::fs::read(&boxed).unwrap(),
        std::fs::read(fx.join("cut.npy")).unwrap()
    );
    // The same triangle by its longitudes and latitudes, through the scenes' ground control
    // points (x = 11 + col / 10^4, y = 48 - row / 10^4), gives the same patches.
    let on_map = CUT_FIELDS.replace(
        "size: [4, 4]}]}",
        "size: [4, 4]}], polygon_map: [[11.0001, 47.9998], [11.0029, 47.9998], [11.0015, 47.9962]]}",
    );
    let fields = format!("kind: geotiff, path: [{}], {on_map}", files.join(", "));
    let tri_map = run(d, "triangle_map", &fields);
    assert_same_tables(&tri_map, &tri);
    assert_eq!(
        dataset_files(&tri_map)["cut"]["places"],
        dataset_files(&tri)["cut"]["places"]
    );
    let both = with.replace(
        "polygon:",
        "polygon_map: [[11.0, 48.0], [11.1, 48.0], [11.0, 47.9]], polygon:",
    );
    let e = refused(
        d,
        "both_polygons",
        &format!("kind: geotiff, path: [{}], {both}", files.join(", ")),
    );
    assert!(
        e.contains("cut.polygon_map") && e.contains("not both"),
        "{e}"
    );
    let files = dataset_files(&ours);
    // Rows 2, 10, 18, 26 and columns 1, 7, 13, 19 (16 places) less the 2 that cover the box
    // (row 10, columns 7 and 13).
    assert_eq!(files["cut"]["places"], json!(14), "{files}");
    let e = refused(
        d,
        "too_big",
        "kind: geotiff, path: [fixtures/s1_00.tif, fixtures/s1_01.tif], cut: {patch: 41}",
    );
    let e2 = refused(
        d,
        "line",
        "kind: geotiff, path: [fixtures/s1_00.tif, fixtures/s1_01.tif], cut: {patch: 4, polygon: [[0, 0], [5, 5]]}",
    );
    assert!(
        e2.contains("datasets[0].cut.polygon") && e2.contains("3 vertices"),
        "{e2}"
    );
    assert!(
        e.contains("datasets[0].cut") && e.contains("no 41x41 patch fits"),
        "{e}"
    );
}

#[test]
fn bad_geotiff_files_are_refused_naming_the_file_and_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let Some(fx) = fixtures(dir.path()) else {
        return;
    };
    let d = dir.path();
    assert_valid(d, "good", &geotiff_fields("s1"));
    // A scene cut short: its last strip lies past the end.
    let tif = fx.join("s1_01.tif");
    let bytes = std::fs::read(&tif).unwrap();
    std::fs::write(&tif, &bytes[..bytes.len() - 100]).unwrap();
    let e = refused(d, "truncated", &geotiff_fields("s1"));
    assert!(
        e.contains("datasets[0].path[1]")
            && e.contains("s1_01.tif: StripByteCounts: block")
            && e.contains("truncated"),
        "{e}"
    );
    std::fs::write(&tif, &bytes).unwrap();
    // Not complex.
    let e = refused(
        d,
        "byte",
        "kind: geotiff, path: [fixtures/byte.tif, fixtures/byte.tif]",
    );
    assert!(
        e.contains("datasets[0].path[0]")
            && e.contains("byte.tif: SampleFormat:")
            && e.contains("8-bit unsigned integer"),
        "{e}"
    );
    // A compression this reader does not take.
    let e = refused(d, "lzw", "kind: geotiff, path: fixtures/lzw.tif");
    assert!(
        e.contains("datasets[0].path") && e.contains("lzw.tif: Compression: 5 (LZW)"),
        "{e}"
    );
    // A window outside the scenes.
    let e = refused(
        d,
        "outside",
        "kind: geotiff, path: [fixtures/s1_00.tif, fixtures/s1_01.tif], window: {row: 30, col: 0, size: [16, 16]}",
    );
    assert!(
        e.contains("datasets[0].window") && e.contains("rows 30..46") && e.contains("40 x 30"),
        "{e}"
    );
    // No radiometric scale factors in a GeoTIFF.
    let e = refused(
        d,
        "calibration",
        &format!("{}, calibration: sigma0", geotiff_fields("s1")),
    );
    assert!(
        e.contains("datasets[0].calibration")
            && e.contains("s1_00.tif: its format gives no radiometric scale factors"),
        "{e}"
    );
    // A map box on a scene without georeferencing.
    let e = refused(
        d,
        "nogeo",
        "kind: geotiff, path: [fixtures/nogeo.tif], window: {x: [11.0, 11.001], y: [47.999, 48.0]}",
    );
    assert!(
        e.contains("datasets[0].window") && e.contains("nogeo.tif gives no georeferencing"),
        "{e}"
    );
    let e = refused(
        d,
        "nogeo_polygon",
        "kind: geotiff, path: [fixtures/nogeo.tif], cut: {patch: 8, polygon_map: [[11.0, 48.0], [11.1, 48.0], [11.0, 47.9]]}",
    );
    assert!(
        e.contains("datasets[0].cut.polygon_map")
            && e.contains("nogeo.tif gives no georeferencing"),
        "{e}"
    );
}

/// A box of longitude and latitude on scenes georeferenced by ground control points only (as
/// Sentinel-1 SLC measurement files are) is the window GDAL's GCP transformer maps it to
/// (rasterio's `GCPTransformer` in the fixture script), and the analysis of that window is
/// that of rasterio's pixels; the manifest states the fit's order and residual.
#[test]
fn a_longitude_latitude_box_on_ground_control_points_is_gdals_window() {
    let dir = tempfile::tempdir().unwrap();
    let Some(fx) = fixtures(dir.path()) else {
        return;
    };
    let d = dir.path();
    let want: serde_json::Value = common::read_json(&fx.join("gcp_box.json"));
    let files: Vec<String> = (0..3).map(|k| format!("fixtures/gcp_0{k}.tif")).collect();
    let fields = format!(
        "kind: geotiff, path: [{}], window: {{x: {}, y: {}}}",
        files.join(", "),
        want["x"],
        want["y"]
    );
    let ours = run(d, "gcp_box", &fields);
    assert_same_tables(
        &ours,
        &run(d, "gcp_npy", "kind: npy, path: fixtures/gcp_window.npy"),
    );
    let files = dataset_files(&ours);
    assert_eq!(files["window"]["rows"], want["rows"], "{files}");
    assert_eq!(files["window"]["cols"], want["cols"], "{files}");
    let fit = &files["window"]["gcp_fit"];
    assert_eq!(fit["order"], json!(2), "{files}");
    let residual = fit["max_residual_pixels"].as_f64().unwrap();
    // The bent map's inverse is no quadratic: the fit misses its points by under a pixel
    // (0.83 here), and the window is still GDAL's.
    assert!(residual > 0.1 && residual < 1.0, "{files}");
    // The four corner points of `s1_0{k}.tif` fit a plane (order 1) exactly.
    let s1: Vec<String> = (0..3).map(|k| format!("fixtures/s1_0{k}.tif")).collect();
    let fields = format!(
        "kind: geotiff, path: [{}], window: {{x: [11.0007, 11.0023], y: [47.9979, 47.9995]}}",
        s1.join(", ")
    );
    let s1 = run(d, "s1_box", &fields);
    assert_same_tables(
        &s1,
        &run(d, "s1_npy", "kind: npy, path: fixtures/window.npy"),
    );
    assert_eq!(dataset_files(&s1)["window"]["gcp_fit"]["order"], json!(1));
}
