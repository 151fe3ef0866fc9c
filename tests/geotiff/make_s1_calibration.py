"""Sentinel-1 calibration fixtures for tests/geotiff.rs, written by GDAL through rasterio and
calibrated by xarray-sentinel (B-Open's Sentinel-1 reader), not by the tool.

`S1A_IW_SLC__1SDV_20240501T140000_20240501T140027_053600_067F00_ABCD.SAFE`: a SAFE product's
two files a calibration needs: `measurement/s1a-iw1-slc-vv-20240501t140000-20240501t140027-
053600-067f00-004.tiff` (a 40 x 30 CInt16 scene, as Sentinel-1 SLC measurements store them)
and `annotation/calibration/calibration-<the same name>.xml` (ESA's calibration annotation:
an `adsHeader`, the absolute calibration constant, and 5 `calibrationVector`s from line -3
every 11 lines, each at pixels 0, 8, ..., 32, with `sigmaNought`, `betaNought`, `gamma` and
`dn` tables varying along lines and pixels). `s1_sigma0.npy`: the scene calibrated to sigma0
by xarray-sentinel (`open_calibration_dataset`, then `calibrate_amplitude` of the digital
numbers with its `sigmaNought`: the table interpolated by xarray at each line and pixel, as
float32, dividing the values). `bad_pixels.SAFE`: the same product with the third vector's
pixels shifted (no regular line-pixel grid).

Usage: python make_s1_calibration.py OUT_DIR
"""

import shutil
import sys
import warnings
from pathlib import Path

import numpy as np
import rasterio

ROWS, COLS = 40, 30
SAFE = "S1A_IW_SLC__1SDV_20240501T140000_20240501T140027_053600_067F00_ABCD.SAFE"
NAME = "s1a-iw1-slc-vv-20240501t140000-20240501t140027-053600-067f00-004"


def numbers(values, fmt):
    return " ".join(fmt.format(v) for v in values)


def annotation(lines, pixels, tables):
    """ESA's calibration annotation of the vectors at `lines` over `pixels`."""
    vectors = []
    for k, line in enumerate(lines):
        t = f"2024-05-01T14:00:{k:02d}.000000"
        fields = "".join(
            f'      <{name} count="{len(pixels)}">{numbers(tables[name][k], "{:.6e}")}</{name}>\n'
            for name in ("sigmaNought", "betaNought", "gamma", "dn")
        )
        vectors.append(
            "    <calibrationVector>\n"
            f"      <azimuthTime>{t}</azimuthTime>\n"
            f"      <line>{line}</line>\n"
            f'      <pixel count="{len(pixels)}">{numbers(pixels, "{:d}")}</pixel>\n'
            f"{fields}    </calibrationVector>\n"
        )
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n<calibration>\n  <adsHeader>\n'
        "    <missionId>S1A</missionId>\n    <productType>SLC</productType>\n"
        "    <polarisation>VV</polarisation>\n    <mode>IW</mode>\n    <swath>IW1</swath>\n"
        "    <startTime>2024-05-01T14:00:00.000000</startTime>\n"
        "    <stopTime>2024-05-01T14:00:27.000000</stopTime>\n"
        "    <absoluteOrbitNumber>53600</absoluteOrbitNumber>\n"
        "    <missionDataTakeId>425728</missionDataTakeId>\n    <imageNumber>004</imageNumber>\n"
        "  </adsHeader>\n  <calibrationInformation>\n"
        "    <absoluteCalibrationConstant>1.000000e+00</absoluteCalibrationConstant>\n"
        f'  </calibrationInformation>\n  <calibrationVectorList count="{len(lines)}">\n'
        + "".join(vectors)
        + "  </calibrationVectorList>\n</calibration>\n"
    )


def product(root: Path, scene, lines, pixels, tables) -> Path:
    """The SAFE folder's measurement and calibration annotation; the measurement's path."""
    (root / "measurement").mkdir(parents=True)
    (root / "annotation" / "calibration").mkdir(parents=True)
    tiff = root / "measurement" / f"{NAME}.tiff"
    with rasterio.open(tiff, "w", driver="GTiff", width=COLS, height=ROWS, count=1,
                       dtype="complex_int16") as f:
        f.write(scene, 1)
    xml = root / "annotation" / "calibration" / f"calibration-{NAME}.xml"
    xml.write_text(annotation(lines, pixels, tables))
    return tiff


warnings.filterwarnings("ignore", category=rasterio.errors.NotGeoreferencedWarning)


def main(out: Path) -> None:
    import xarray as xr
    from xarray_sentinel import sentinel1

    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(49)
    ints = rng.integers(-300, 300, (2, ROWS, COLS))
    scene = (ints[0] + 1j * ints[1]).astype(np.complex64)
    lines = [-3 + 11 * k for k in range(5)]
    pixels = [8 * j for j in range(5)]
    li, pj = np.meshgrid(np.arange(5), np.arange(5), indexing="ij")
    tables = {
        "sigmaNought": 620.0 + 9.0 * pj - 4.0 * li + 1.5 * li * pj,
        "betaNought": np.full((5, 5), 473.0),
        "gamma": 560.0 + 7.0 * pj - 3.0 * li,
        "dn": np.full((5, 5), 400.0),
    }
    tiff = product(out / SAFE, scene, lines, pixels, tables)
    with rasterio.open(tiff) as f:
        stored = f.read(1).astype(np.complex64)
    xml = out / SAFE / "annotation" / "calibration" / f"calibration-{NAME}.xml"
    lut = sentinel1.open_calibration_dataset(xml)
    dn = xr.DataArray(stored, dims=("line", "pixel"),
                      coords={"line": np.arange(ROWS), "pixel": np.arange(COLS)})
    amplitude = sentinel1.calibrate_amplitude(dn, lut.sigmaNought)
    calibrated = np.asarray(amplitude.values, dtype=np.complex64)
    assert np.all(np.isfinite(calibrated)), "the vectors cover every line and pixel"
    np.save(out / "s1_sigma0.npy", calibrated)
    # The third vector's pixels shifted: no regular grid.
    bad = out / "bad_pixels.SAFE"
    shutil.copytree(out / SAFE, bad)
    bad_xml = bad / "annotation" / "calibration" / f"calibration-{NAME}.xml"
    text = bad_xml.read_text().split("<calibrationVector>")
    text[3] = text[3].replace(">0 8 16 24 32<", ">0 8 16 24 31<", 1)
    bad_xml.write_text("<calibrationVector>".join(text))


if __name__ == "__main__":
    main(Path(sys.argv[1]))
