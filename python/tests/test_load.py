"""``isar_clutter.load`` reads UAVSAR scenes written by numpy, GeoTIFF scenes written by GDAL
(rasterio), SICD images written by sarpy and HDF5 files written by h5py, not by the tool, as
those read them (or as written), and refuses
bad files naming the field and the file; the SICD example goes from images to a model and a
DataLoader."""

import importlib.util
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import isar_clutter as ic

ROWS, COLS = 12, 10


def scenes(tmp_path, n=3):
    """``n`` scenes named as UAVSAR names them, each with its annotation; numpy's reading."""
    rng = np.random.default_rng(4)
    paths, read = [], []
    for k in range(n):
        name = f"site_0{k}_L090HH_01_BC"
        x = (rng.standard_normal((ROWS, COLS)) + 1j * rng.standard_normal((ROWS, COLS))).astype("<c8")
        x.tofile(tmp_path / f"{name}_s1_1x1.slc")
        (tmp_path / f"{name}.ann").write_text(
            f"; test annotation\nslc_1_1x1 Rows (pixels) = {ROWS} ; along track\n"
            f"slc_1_1x1 Columns (pixels) = {COLS}\n"
        )
        paths.append(tmp_path / f"{name}_s1_1x1.slc")
        read.append(np.fromfile(paths[-1], dtype="<c8").reshape(ROWS, COLS))
    return paths, np.stack(read)


def test_a_uavsar_stack_is_read_as_numpy_reads_it(tmp_path):
    paths, want = scenes(tmp_path)
    x = ic.load(paths)
    assert x.dtype == np.complex64 and x.shape == (3, ROWS, COLS)
    np.testing.assert_array_equal(x, want)
    w = ic.load([str(p) for p in paths], window=(2, 3, 6, 5))
    np.testing.assert_array_equal(w, want[:, 2:8, 3:8])
    one = ic.load(paths[1], annotation=tmp_path / "site_01_L090HH_01_BC.ann")
    np.testing.assert_array_equal(one, want[1:2])
    assert ic.analyse(w, levels=1)["samples"] == 3


def test_a_uavsar_map_box_reads_the_blocks_of_the_llh_points_in_it(tmp_path):
    """tests/uavsar/make_fixtures.py's scenes and ``.llh`` grid: ``map_box`` gives the window
    numpy cut there from the blocks whose points lie in the box."""
    module = fixture_script("uavsar", "make_fixtures")
    module.main(tmp_path)
    paths = sorted(tmp_path.glob("*_s1_1x1.slc"))
    x = ic.load(paths, map_box=module.BOX)
    np.testing.assert_array_equal(x, np.load(tmp_path / "map_window.npy"))
    with pytest.raises(ValueError, match=r"window: .*holds none of the 5 x 15 grid points"):
        ic.load(paths, map_box=((10.0, 10.1), (50.0, 50.1)))


def test_bad_uavsar_files_are_refused_naming_the_field_and_the_file(tmp_path):
    paths, _ = scenes(tmp_path)
    data = paths[2].read_bytes()
    paths[2].write_bytes(data[:-8])
    with pytest.raises(ValueError, match=r"slc\[2\]: .*site_02_L090HH_01_BC_s1_1x1.slc holds 952 bytes"):
        ic.load(paths)
    paths[2].write_bytes(data)
    with pytest.raises(ValueError, match=r"window: rows 10\.\.16"):
        ic.load(paths, window=(10, 0, 6, 5))
    (tmp_path / "bad.ann").write_text("slc_1_1x1 Rows (pixels) = 12\n")
    with pytest.raises(ValueError, match=r"annotation: .*bad.ann: field `slc_1_1x1 Columns` is missing"):
        ic.load(paths, annotation=tmp_path / "bad.ann")
    with pytest.raises(ValueError, match="load reads UAVSAR .slc files"):
        ic.load(tmp_path / "x.dat")


def geotiffs(tmp_path, dtype, n=2, **options):
    """``n`` complex GeoTIFF scenes written by GDAL (rasterio); rasterio's reading."""
    rasterio = pytest.importorskip("rasterio")
    rng = np.random.default_rng(5)
    paths, read = [], []
    for k in range(n):
        ints = rng.integers(-3000, 3000, (2, ROWS, COLS))
        path = tmp_path / f"scene_{k}.tif"
        with rasterio.open(path, "w", driver="GTiff", width=COLS, height=ROWS, count=1,
                           dtype=dtype, **options) as f:
            f.write((ints[0] + 1j * ints[1]).astype(np.complex64), 1)
        with rasterio.open(path) as f:
            read.append(f.read(1))
        paths.append(path)
    return paths, np.stack(read).astype(np.complex64)


@pytest.mark.filterwarnings("ignore::rasterio.errors.NotGeoreferencedWarning")
def test_geotiff_scenes_are_read_as_rasterio_reads_them(tmp_path):
    paths, want = geotiffs(tmp_path, "complex_int16")
    x = ic.load(paths)
    assert x.dtype == np.complex64 and x.shape == (2, ROWS, COLS)
    np.testing.assert_array_equal(x, want)
    np.testing.assert_array_equal(ic.load(paths, window=(2, 3, 6, 5)), want[:, 2:8, 3:8])
    tiled = tmp_path / "tiled"
    tiled.mkdir()
    paths, want = geotiffs(tiled, "complex64", tiled=True, blockxsize=16, blockysize=16,
                           compress="deflate")
    np.testing.assert_array_equal(ic.load(paths), want)
    # The same pixels by map coordinates: a UTM grid of 2.5 m columns and 5 m rows.
    from rasterio.transform import Affine
    utm = tmp_path / "utm"
    utm.mkdir()
    upaths, uwant = geotiffs(utm, "complex64", crs="EPSG:32632",
                             transform=Affine(2.5, 0.0, 500000.0, 0.0, -5.0, 5300000.0))
    got = ic.load(upaths, map_box=((500007.5, 500020.0), (5299960.0, 5299990.0)))
    np.testing.assert_array_equal(got, uwant[:, 2:8, 3:8])
    with pytest.raises(ValueError, match="not both"):
        ic.load(upaths, window=(0, 0, 2, 2), map_box=((500007.5, 500020.0), (5299960.0, 5299990.0)))
    with pytest.raises(ValueError, match="gives no georeferencing"):
        ic.load(paths, map_box=((0.0, 1.0), (0.0, 1.0)))
    paths[1].write_bytes(paths[1].read_bytes()[:-64])
    with pytest.raises(ValueError, match=r"path\[1\]: .*scene_1.tif: TileByteCounts: block \d+ holds"):
        ic.load(paths)


def fixture_script(folder, name):
    """The fixture script ``tests/<folder>/<name>.py`` as a module."""
    path = Path(__file__).resolve().parents[2] / "tests" / folder / f"{name}.py"
    spec = importlib.util.spec_from_file_location(f"{folder}_{name}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def sicd_script(name):
    """The fixture script ``tests/sicd/<name>.py`` (it writes SICD files with sarpy) as a module."""
    pytest.importorskip("sarpy")
    return fixture_script("sicd", name)


def nisar_fixtures(tmp_path):
    """tests/hdf5/make_nisar_fixtures.py's files (h5py, numpy, scipy) in ``tmp_path``."""
    pytest.importorskip("h5py")
    pytest.importorskip("scipy")
    fixture_script("hdf5", "make_nisar_fixtures").main(tmp_path)


def sicd_fixtures(tmp_path):
    """The SICD images of tests/sicd/make_fixtures.py (written by sarpy) in ``tmp_path``."""
    sicd_script("make_fixtures").main(tmp_path)
    return tmp_path


def test_sicd_images_are_read_as_sarpy_reads_them(tmp_path):
    fx = sicd_fixtures(tmp_path)
    for prefix, window in [("scene", "window.npy"), ("float", "float_window.npy")]:
        paths = [fx / f"{prefix}_0{k}.nitf" for k in range(3)]
        x = ic.load(paths, window=(5, 7, 16, 16))
        assert x.dtype == np.complex64 and x.shape == (3, 16, 16)
        np.testing.assert_array_equal(x, np.load(fx / window))
        assert ic.load(paths).shape == (3, 40, 30)
    cal = ic.load([fx / f"cal_0{k}.nitf" for k in range(3)], calibration="sigma0")
    # The factor is the root of a float64 polynomial rounded to float32: 1e-6 relative.
    np.testing.assert_allclose(cal, np.load(fx / "cal_sigma0.npy"), rtol=1e-6, atol=0)
    with pytest.raises(ValueError, match=r"calibration: .*scene_00.nitf: its SICD XML has no Radiometric/BetaZeroSFPoly"):
        ic.load([fx / "scene_00.nitf"], calibration="beta0")
    data = (fx / "scene_01.nitf").read_bytes()
    (fx / "scene_01.nitf").write_bytes(data[:-100])
    with pytest.raises(ValueError, match=r"path\[1\]: .*scene_01.nitf: NITF header: .*truncated"):
        ic.load([fx / f"scene_0{k}.nitf" for k in range(3)])


def test_a_sicd_map_box_reads_the_pixels_sarpy_projects_it_to(tmp_path):
    module = sicd_script("make_projection_fixtures")
    module.main(tmp_path)
    paths = [tmp_path / "proj_inca.nitf", tmp_path / "proj_inca_b.nitf"]
    got = ic.load(paths, map_box=module.MAP_BOX)
    np.testing.assert_array_equal(got, np.load(tmp_path / "map_window.npy"))
    with pytest.raises(ValueError, match="its SICD XML lacks ImageFormation/ImageFormAlgo"):
        ic.load([sicd_fixtures(tmp_path / "plain") / "scene_00.nitf"], map_box=module.MAP_BOX)


def test_the_sicd_example_fits_a_model_and_fills_a_dataloader(tmp_path):
    pytest.importorskip("torch")
    fx = sicd_fixtures(tmp_path)
    example = Path(__file__).resolve().parents[2] / "examples" / "sicd_to_dataloader.py"
    images = [str(fx / f"scene_0{k}.nitf") for k in range(3)]
    o = subprocess.run([sys.executable, str(example), "--window", "5", "7", "16", "16",
                        "--out", str(tmp_path / "model"), "--batch-size", "4", *images],
                       capture_output=True, text=True, check=True)
    assert "read 3 windows of 16 x 16" in o.stdout, o.stdout
    assert "first batch: (4, 16, 16)" in o.stdout, o.stdout
    assert ic.Model.load(tmp_path / "model").method == "method2"


def test_hdf5_stacks_and_scenes_are_read_as_written(tmp_path):
    h5py = pytest.importorskip("h5py")
    rng = np.random.default_rng(29)
    x = (rng.standard_normal((4, 16, 12)) + 1j * rng.standard_normal((4, 16, 12))).astype(np.complex64)
    f = tmp_path / "stack.h5"
    with h5py.File(f, "w") as h:
        h.create_dataset("science/HH", data=x, chunks=(1, 16, 12), compression="gzip")
        h["pairs"] = np.stack([x.real, x.imag], axis=-1)
        h["re"], h["im"] = x.real.astype(np.float64), x.imag.astype(np.float64)
        h["hwn"] = np.transpose(x, (1, 2, 0)).astype(">c16")
        parts = np.empty(x.shape, dtype=[("real", "<f4"), ("imag", "<f4")])
        parts["real"], parts["imag"] = x.real, x.imag
        h["matlab"] = parts
        ints = np.empty(x.shape, dtype=[("re", "<i2"), ("im", "<i2")])
        ints["re"], ints["im"] = np.round(x.real * 1000), np.round(x.imag * 1000)
        h["ints"] = ints
        h["frame"] = x[0]
        h["geo/VV"] = x[1]
        h["geo/x_coordinates"] = 500_000.0 + 5.0 * (np.arange(12) + 0.5)
        h["geo/y_coordinates"] = 4_200_000.0 - 10.0 * (np.arange(16) + 0.5)
        h["text"] = np.array([b"abc"] * 6).reshape(1, 2, 3)
    for name, kw in [("science/HH", {}), ("/pairs", {}), ("matlab", {})]:
        got = ic.load(f, dataset=name, **kw)
        assert got.dtype == np.complex64 and np.array_equal(got, x), name
    parts = ic.load(f, dataset="re", imag="im")
    assert parts.dtype == np.complex128 and np.array_equal(parts, x.astype(np.complex128))
    hwn = ic.load(f, dataset="hwn", layout="hwn")
    assert hwn.dtype == np.complex128 and np.array_equal(hwn, x.astype(np.complex128))
    ints = ic.load(f, dataset="ints")
    assert ints.dtype == np.complex64
    assert np.array_equal(ints, np.round(x.real * 1000) + 1j * np.round(x.imag * 1000))
    scene = ic.load(f, dataset="frame", window=(2, 3, 5, 4))
    assert scene.shape == (1, 5, 4) and np.array_equal(scene[0], x[0, 2:7, 3:7])
    # Columns 3..7 (x 500015..500035) and rows 2..7 (y 4199980..4199930), box edges inside.
    geo = ic.load(f, dataset="geo/VV", map_box=((500016.0, 500034.0), (4199931.0, 4199979.0)))
    assert np.array_equal(geo[0], x[1, 2:7, 3:7])
    with pytest.raises(ValueError, match="frame has no coordinate vectors beside it in /"):
        ic.load(f, dataset="frame", map_box=((0.0, 1.0), (0.0, 1.0)))
    with h5py.File(f, "a") as h:
        h["geo/x_coordinates"][5] += 0.5
    with pytest.raises(ValueError, match="x coordinates are not evenly spaced"):
        ic.load(f, dataset="geo/VV", map_box=((500016.0, 500034.0), (4199931.0, 4199979.0)))
    for kw, words in [
        ({"dataset": "nope"}, ["dataset:", "no dataset 'nope'", "science"]),
        ({"dataset": "text"}, ["dataset:", "not numbers"]),
        ({"dataset": "re", "imag": "matlab"}, ["imag:", "must both hold real numbers"]),
        ({"dataset": "re", "imag": "pairs"}, ["imag:", "must have one shape"]),
        ({"dataset": "frame", "window": (10, 0, 8, 4)}, ["window:", "not inside"]),
        ({"dataset": "pairs", "window": (0, 0, 2, 2)}, ["window:", "a stack"]),
        ({}, ["dataset:", "give the stack's path"]),
    ]:
        with pytest.raises(ValueError) as e:
            ic.load(f, **kw)
        assert all(w in str(e.value) for w in words), (kw, str(e.value))
    bad = tmp_path / "truncated.h5"
    bad.write_bytes(f.read_bytes()[:500])
    with pytest.raises(ValueError, match=r"path: .*truncated\.h5"):
        ic.load(bad, dataset="pairs")
    with pytest.raises(ValueError, match="HDF5 file"):
        ic.load(scenes(tmp_path)[0], dataset="x")


def test_hdf5_scenes_are_calibrated_by_nisar_tables_and_iceye_factors(tmp_path):
    """tests/hdf5/make_nisar_fixtures.py's RSLC and GSLC frames (h5py, in isce3's layouts) and
    the scenes numpy and scipy calibrated from them (``|DN|**2 / table**2``, the table read
    bilinearly, clipped to its grid): ``calibration=`` gives those values; ICEYE's factor
    gives ``beta0``; a table at another epoch than the scene's times is refused."""
    nisar_fixtures(tmp_path)
    rslc = "/science/LSAR/RSLC/swaths/frequencyA/HH"
    got = ic.load(tmp_path / "rslc.h5", dataset=rslc, calibration="sigma0")
    want = np.load(tmp_path / "rslc_sigma0.npy")
    # numpy's bilinear reading against scipy's: the factors agree to their float32 rounding.
    np.testing.assert_allclose(got[0], want, rtol=2.5e-7, atol=0)
    window = ic.load(tmp_path / "gslc.h5", dataset="/science/LSAR/GSLC/grids/frequencyA/HH",
                     window=(3, 2, 30, 25), calibration="gamma0")
    np.testing.assert_allclose(window[0], np.load(tmp_path / "gslc_gamma0.npy")[3:33, 2:27],
                               rtol=2.5e-7, atol=0)
    plain = ic.load(tmp_path / "rslc.h5", dataset=rslc)
    assert not np.allclose(plain[0], want, rtol=1e-3)
    with pytest.raises(ValueError, match=r"calibration: .*bad\.h5: /epoch/metadata/.*2025-11-02"):
        ic.load(tmp_path / "bad.h5", dataset="/epoch/swaths/frequencyA/HH", calibration="sigma0")
    with pytest.raises(ValueError, match=r"holds no rcs table \(it holds \['beta0', 'gamma0', 'sigma0'\]\)"):
        ic.load(tmp_path / "rslc.h5", dataset=rslc, calibration="rcs")
    import h5py

    ints = np.arange(-600, 600, dtype=np.int16).reshape(2, 20, 30)
    with h5py.File(tmp_path / "iceye.h5", "w") as f:
        f["s_i"], f["s_q"], f["calibration_factor"] = ints[0], ints[1], 3.7e-7
    beta0 = ic.load(tmp_path / "iceye.h5", dataset="s_i", imag="s_q", calibration="beta0")
    assert np.array_equal(beta0[0], (ints[0] + 1j * ints[1]).astype(np.complex64) * np.float32(np.sqrt(3.7e-7)))
    with pytest.raises(ValueError, match="gives beta0 only"):
        ic.load(tmp_path / "iceye.h5", dataset="s_i", imag="s_q", calibration="sigma0")


def test_an_rslc_map_box_is_placed_by_its_geolocation_grid(tmp_path):
    """The RSLC frame of tests/hdf5/make_nisar_fixtures.py: ``map_box`` reads the window scipy
    placed the box on through the frame's geolocation grid at its terrain height."""
    import json

    nisar_fixtures(tmp_path)
    box = json.loads((tmp_path / "map_box.json").read_text())
    rslc = "/science/LSAR/RSLC/swaths/frequencyA/HH"
    got = ic.load(tmp_path / "rslc.h5", dataset=rslc, map_box=(box["x"], box["y"]))
    r0, r1, c0, c1 = box["window"]
    want = ic.load(tmp_path / "rslc.h5", dataset=rslc, window=(r0, c0, r1 - r0, c1 - c0))
    assert got.shape == want.shape and np.array_equal(got, want)
    with pytest.raises(ValueError, match="outside the geolocation grid"):
        ic.load(tmp_path / "rslc.h5", dataset=rslc, map_box=((-100.0, -99.9), (10.0, 10.1)))


def test_a_sentinel1_measurement_is_calibrated_by_its_safe_annotation(tmp_path):
    """A SAFE product of tests/geotiff/make_s1_calibration.py (rasterio's CInt16 measurement,
    ESA's calibration annotation): ``calibration="sigma0"`` divides each value by the
    ``sigmaNought`` table read bilinearly (scipy) at its line and pixel, as float32."""
    pytest.importorskip("scipy")
    from scipy.interpolate import RegularGridInterpolator

    module = fixture_script("geotiff", "make_s1_calibration")
    scene = (np.arange(40 * 30).reshape(40, 30) % 97 - 48 + 1j * (np.arange(1200).reshape(40, 30) % 31)).astype(np.complex64)
    lines, pixels = [-3 + 11 * k for k in range(5)], [8 * j for j in range(5)]
    li, pj = np.meshgrid(np.arange(5.0), np.arange(5.0), indexing="ij")
    sigma = 620.0 + 9.0 * pj - 4.0 * li + 1.5 * li * pj
    tables = {"sigmaNought": sigma, "betaNought": sigma * 0 + 473.0, "gamma": sigma * 0 + 560.0, "dn": sigma * 0 + 400.0}
    tiff = module.product(tmp_path / module.SAFE, scene, lines, pixels, tables)
    got = ic.load(tiff, calibration="sigma0")
    written = np.asarray([[float(f"{v:.6e}") for v in row] for row in sigma])
    f = RegularGridInterpolator((np.array(lines, float), np.array(pixels, float)), written)
    rr, cc = np.meshgrid(np.arange(40.0), np.arange(30.0), indexing="ij")
    want = scene / f(np.stack([rr, cc], axis=-1)).astype(np.float32)
    np.testing.assert_allclose(got[0], want, rtol=2.5e-7, atol=0)
    assert not np.allclose(ic.load(tiff)[0], want)
    with pytest.raises(ValueError, match="calibration: .*asked for rcs"):
        ic.load(tiff, calibration="rcs")
