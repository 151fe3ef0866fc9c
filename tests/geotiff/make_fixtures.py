"""GeoTIFF fixtures for tests/geotiff.rs, written by GDAL through rasterio (not by the tool).

- `s1_0{k}.tif`, k = 0, 1, 2: three coregistered 40 x 30 scenes of complex int16 (GDAL's
  CInt16, as Sentinel-1 SLC measurement files store them), in strips, uncompressed, with
  ground control points in WGS 84 (as Sentinel-1's), and `window.npy`: rows 5..21 and
  columns 7..23 of each as rasterio reads them, an [N, H, W] complex64 stack, and
  `scenes.npy`: the whole scenes as rasterio reads them, a [3, 40, 30] time stack.
- `tiled_0{k}.tif`: the same pixels as complex float32 in 16 x 16 tiles, deflated, on a UTM
  grid (an affine transform), and `tiled_window.npy` from them.
- `gcp_0{k}.tif`: the same pixels as complex int16 with a 5 x 4 grid of ground control
  points on a bent map (longitude and latitude quadratic in row and column), `gcp_box.json`:
  a box of longitude and latitude and the pixel window GDAL's GCP transformer (rasterio's
  `GCPTransformer`, GDAL's default order) maps it to (17 points along each edge, rounded
  outwards), and `gcp_window.npy`: that window of each scene as rasterio reads it.
- `byte.tif`: an 8-bit unsigned image (not complex); `lzw.tif`: a CInt16 scene compressed
  with LZW; `nogeo.tif`: a CInt16 scene without georeferencing.

Usage: python make_fixtures.py OUT_DIR
"""

import json
import sys
import warnings
from pathlib import Path

import numpy as np
import rasterio
from rasterio.control import GroundControlPoint
from rasterio.crs import CRS
from rasterio.transform import GCPTransformer, from_origin

ROWS, COLS = 40, 30
WINDOW = rasterio.windows.Window(col_off=7, row_off=5, width=16, height=16)


def write(path: Path, z: np.ndarray, dtype: str, **options) -> None:
    with rasterio.open(path, "w", driver="GTiff", width=COLS, height=ROWS, count=1,
                       dtype=dtype, **options) as f:
        f.write(z, 1)


def main(out: Path) -> None:
    # byte.tif and lzw.tif are written without georeferencing on purpose.
    warnings.filterwarnings("ignore", category=rasterio.errors.NotGeoreferencedWarning)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(20261129)
    gcps = [GroundControlPoint(row=r, col=c, x=11.0 + c * 1e-4, y=48.0 - r * 1e-4, z=500.0)
            for r in (0, ROWS) for c in (0, COLS)]
    bent = [GroundControlPoint(row=r, col=c, x=11.0 + c * 1e-4 + r * c * 2e-6,
                               y=48.0 - r * 1e-4 + c * c * 3e-7, z=0.0)
            for r in (0, 10, 20, 30, 40) for c in (0, 10, 20, 30)]
    box_x, box_y = [11.0007, 11.0023], [47.9979, 47.9995]
    t = np.linspace(0.0, 1.0, 17)
    xs = np.concatenate([box_x[0] + (box_x[1] - box_x[0]) * t] * 2 + [np.full(17, box_x[0]),
                                                                   np.full(17, box_x[1])])
    ys = np.concatenate([np.full(17, box_y[0]), np.full(17, box_y[1])]
                        + [box_y[0] + (box_y[1] - box_y[0]) * t] * 2)
    rows, cols = GCPTransformer(bent).rowcol(xs, ys, op=float)
    r0, r1 = int(np.floor(min(rows))), int(np.ceil(max(rows)))
    c0, c1 = int(np.floor(min(cols))), int(np.ceil(max(cols)))
    (out / "gcp_box.json").write_text(json.dumps(
        {"x": box_x, "y": box_y, "rows": [r0, r1], "cols": [c0, c1]}))
    gcp_window = rasterio.windows.Window(col_off=c0, row_off=r0, width=c1 - c0, height=r1 - r0)
    windows, tiled, whole, gcp = [], [], [], []
    for k in range(3):
        ints = rng.integers(-2000 * (k + 1), 2000 * (k + 1), (2, ROWS, COLS))
        z = (ints[0] + 1j * ints[1]).astype(np.complex64)
        write(out / f"s1_0{k}.tif", z, "complex_int16", gcps=gcps, crs=CRS.from_epsg(4326))
        write(out / f"tiled_0{k}.tif", z * np.float32(0.25), "complex64", tiled=True,
              blockxsize=16, blockysize=16, compress="deflate", crs=CRS.from_epsg(32632),
              transform=from_origin(500000.0, 5300000.0, 2.5, 5.0))
        write(out / f"gcp_0{k}.tif", z, "complex_int16", gcps=bent, crs=CRS.from_epsg(4326))
        with rasterio.open(out / f"gcp_0{k}.tif") as f:
            gcp.append(f.read(1, window=gcp_window))
        # What rasterio reads back from the files, independently of the writer above.
        with rasterio.open(out / f"s1_0{k}.tif") as f:
            windows.append(f.read(1, window=WINDOW))
            whole.append(f.read(1))
        with rasterio.open(out / f"tiled_0{k}.tif") as f:
            tiled.append(f.read(1, window=WINDOW))
    np.save(out / "window.npy", np.stack(windows).astype(np.complex64))
    np.save(out / "scenes.npy", np.stack(whole).astype(np.complex64))
    np.save(out / "tiled_window.npy", np.stack(tiled).astype(np.complex64))
    np.save(out / "gcp_window.npy", np.stack(gcp).astype(np.complex64))
    write(out / "byte.tif", rng.integers(0, 255, (ROWS, COLS)).astype(np.uint8), "uint8")
    write(out / "lzw.tif", np.ones((ROWS, COLS), np.complex64), "complex_int16", compress="lzw")
    write(out / "nogeo.tif", np.ones((ROWS, COLS), np.complex64), "complex_int16")


if __name__ == "__main__":
    main(Path(sys.argv[1]))
