"""Reading radar scene stacks: the tool's GeoTIFF and SICD readers (``isar_clutter.load``,
the same code as ``kind: geotiff`` / ``kind: sicd``) against the field's reference readers
(rasterio/GDAL, sarpy) and ``cat`` of the same files, warm, in one loop (BENCHMARKS.md,
*Reading GeoTIFF and SICD stacks*).

    python bench/scene_read_bench.py DIR [--scenes 64] [--rows 2048] [--cols 1024] [--rounds 3]

Writes DIR once (CInt16 GeoTIFF scenes in GDAL's default strips, as Sentinel-1 stores them;
CFloat32 scenes in 256 x 256 deflated tiles; RE16I_IM16I SICDs written by sarpy), then each
round times every reader on the whole stack and checks that the tool's arrays equal the
reference's.
"""

import argparse
import logging
import subprocess
import time
import warnings
from pathlib import Path

import numpy as np


def write(d: Path, scenes: int, rows: int, cols: int) -> dict:
    import rasterio
    from sarpy.io.complex.sicd import SICDWriter

    import importlib.util

    spec = importlib.util.spec_from_file_location(
        "fx", Path(__file__).resolve().parents[1] / "tests" / "sicd" / "make_fixtures.py")
    fx = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(fx)
    fx.ROWS, fx.COLS = rows, cols
    warnings.filterwarnings("ignore", category=rasterio.errors.NotGeoreferencedWarning)
    logging.disable(logging.CRITICAL)
    sets = {"cint16": [], "cfloat32_tiled_deflate": [], "sicd_re16i": []}
    rng = np.random.default_rng(1)
    d.mkdir(parents=True, exist_ok=True)
    for k in range(scenes):
        paths = [d / f"cint16_{k:03d}.tif", d / f"tiled_{k:03d}.tif", d / f"sicd_{k:03d}.nitf"]
        for name, p in zip(sets, paths):
            sets[name].append(p)
        if all(p.exists() for p in paths):
            continue
        ints = rng.integers(-3000, 3000, (2, rows, cols), dtype=np.int16)
        z = (ints[0] + 1j * ints[1]).astype(np.complex64)
        common = dict(driver="GTiff", width=cols, height=rows, count=1)
        with rasterio.open(paths[0], "w", dtype="complex_int16", **common) as f:
            f.write(z, 1)
        with rasterio.open(paths[1], "w", dtype="complex64", tiled=True, blockxsize=256,
                           blockysize=256, compress="deflate", **common) as f:
            f.write(z, 1)
        with SICDWriter(str(paths[2]), fx.meta("RE16I_IM16I", 1), check_existence=False) as w:
            w.write_chip(z)
    return sets


def read_rasterio(paths):
    import rasterio

    out = []
    for p in paths:
        with rasterio.open(p) as f:
            out.append(f.read(1).astype(np.complex64, copy=False))
    return np.stack(out)


def read_sarpy(paths):
    from sarpy.io.complex.converter import open_complex

    return np.stack([open_complex(str(p))[:, :] for p in paths]).astype(np.complex64, copy=False)


def timed(f):
    t = time.perf_counter()
    x = f()
    return time.perf_counter() - t, x


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("dir", type=Path)
    p.add_argument("--scenes", type=int, default=64)
    p.add_argument("--rows", type=int, default=2048)
    p.add_argument("--cols", type=int, default=1024)
    p.add_argument("--rounds", type=int, default=3)
    a = p.parse_args()
    sets = write(a.dir, a.scenes, a.rows, a.cols)
    import isar_clutter as ic

    refs = {"cint16": read_rasterio, "cfloat32_tiled_deflate": read_rasterio,
            "sicd_re16i": read_sarpy}
    print("| round | files | MB | `cat` | `isar_clutter.load` | reference | reference reader |")
    print("|---:|---|---:|---:|---:|---:|---|")
    for r in range(a.rounds):
        for name, paths in sets.items():
            mb = sum(p.stat().st_size for p in paths) / 1e6
            t_cat, _ = timed(lambda: subprocess.run(["cat", *map(str, paths)], check=True,
                                                    stdout=subprocess.DEVNULL))
            t_ic, x = timed(lambda: ic.load(paths))
            t_ref, y = timed(lambda: refs[name](paths))
            assert np.array_equal(x, y), name
            del x, y
            ref = "sarpy 1.3.64" if name.startswith("sicd") else "rasterio 1.4.3 (GDAL 3.9.3)"
            print(f"| {r + 1} | {name} | {mb:.0f} | {t_cat:.2f} s | {t_ic:.2f} s | {t_ref:.2f} s | {ref} |",
                  flush=True)


if __name__ == "__main__":
    main()
