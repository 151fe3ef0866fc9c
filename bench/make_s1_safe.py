"""A Sentinel-1 SAFE product of random values for timing the calibrated cut (BENCHMARKS.md,
*Calibrating a Sentinel-1 measurement*): a 16,384 x 16,384 CInt16 measurement in GDAL's
default strips (1.07 GB, written by rasterio) and its calibration annotation (vectors every 512
lines, pixels every 40), in the layout of tests/geotiff/make_s1_calibration.py.

Usage: python bench/make_s1_safe.py OUT_DIR
"""

import sys
import warnings
from pathlib import Path

import numpy as np
import rasterio

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "geotiff"))
import make_s1_calibration as m
warnings.filterwarnings("ignore")
N = 16384
root = Path(sys.argv[1]) / m.SAFE
(root / "measurement").mkdir(parents=True, exist_ok=True)
(root / "annotation" / "calibration").mkdir(parents=True, exist_ok=True)
tiff = root / "measurement" / f"{m.NAME}.tiff"
rng = np.random.default_rng(5)
with rasterio.open(tiff, "w", driver="GTiff", width=N, height=N, count=1, dtype="complex_int16") as f:
    for r0 in range(0, N, 1024):
        a = rng.integers(-300, 300, (2, 1024, N)).astype(np.float32)
        f.write((a[0] + 1j * a[1]).astype(np.complex64), 1, window=rasterio.windows.Window(0, r0, N, 1024))
lines = list(range(-100, N + 512, 512))
pixels = list(range(0, N + 40, 40))
li, pj = np.meshgrid(np.arange(len(lines)), np.arange(len(pixels)), indexing="ij")
tables = {"sigmaNought": 600 + 0.05 * pj + li, "betaNought": 473 + 0 * pj, "gamma": 560 + 0.04 * pj, "dn": 400 + 0 * pj}
(root / "annotation" / "calibration" / f"calibration-{m.NAME}.xml").write_text(m.annotation(lines, pixels, tables))
print(tiff, tiff.stat().st_size)
