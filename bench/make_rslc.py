"""A NISAR RSLC frame of random values for timing the calibrated cut (BENCHMARKS.md,
*Calibrating a NISAR frame*), written with h5py in isce3's layout: a complex64 scene
`/science/LSAR/RSLC/swaths/frequencyA/HH` of SIZE x SIZE in 256 x 256 chunks, uncompressed,
its zero-Doppler times and slant ranges, and the calibration tables posted every 50 lines and
samples (isce3's writer's spacing) over their own axes.

Usage: python bench/make_rslc.py OUT.h5 [SIZE]   (default 11584: 1.07 GB of values)
"""

import sys

import h5py
import numpy as np


def main(out: str, size: int) -> None:
    rng = np.random.default_rng(50)
    t = 1000.0 + 0.002 * np.arange(size)
    r = 850_000.0 + 3.5 * np.arange(size)
    units = np.bytes_("seconds since 2025-11-01T00:00:00.000000000")
    with h5py.File(out, "w") as f:
        root = f.create_group("science/LSAR/RSLC")
        freq = root.create_group("swaths/frequencyA")
        hh = freq.create_dataset("HH", (size, size), dtype=np.complex64, chunks=(256, 256))
        for r0 in range(0, size, 256):
            n = min(256, size - r0)
            v = rng.standard_normal((n, size), dtype=np.float32)
            w = rng.standard_normal((n, size), dtype=np.float32)
            hh[r0 : r0 + n] = v + 1j * w
        root["swaths/zeroDopplerTime"] = t
        root["swaths/zeroDopplerTime"].attrs["units"] = units
        freq["slantRange"] = r
        geometry = root.create_group("metadata/calibrationInformation/geometry")
        lt, lr = t[::50], r[::50]
        geometry["zeroDopplerTime"] = lt
        geometry["zeroDopplerTime"].attrs["units"] = units
        geometry["slantRange"] = lr
        theta = np.radians(np.linspace(30.0, 45.0, len(lr)))[None, :]
        along = 1.0 + 0.01 * np.sin(np.arange(len(lt)))[:, None]
        geometry["beta0"] = np.ones((len(lt), len(lr)), dtype=np.float32)
        geometry["sigma0"] = (along / np.sqrt(np.sin(theta))).astype(np.float32)
        geometry["gamma0"] = (along / np.sqrt(np.tan(theta))).astype(np.float32)


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 11584)
