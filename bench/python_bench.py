#!/usr/bin/env python3
"""Generation rate from Python beside the command line's, in one run (issue 29's speed check).

    ISAR_CLUTTER_BIN=... python bench/python_bench.py [--samples 20000] [--method method1]
        [--size 48 64] [--no-loader]

Fits Method 2 (or --method; half-width 8) to 200 samples of 64 x 64 clutter (or --size) with
the command line, then
times, best of --repeats:
  * `isar-clutter generate` of --samples samples into a `.npy` in a temporary folder (its own
    rate line, which excludes the process start but includes writing the file);
  * `Model.generate(n, seed)` in this process, all cores (the numpy array is the output);
  * a torch DataLoader over ClutterDataset with 0 and 2 workers, batch 64, a consumer that
    does nothing.
"""

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import isar_clutter as ic


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--samples", type=int, default=20000)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--method", default="method2")
    ap.add_argument("--size", type=int, nargs=2, default=[64, 64], metavar=("ROWS", "COLS"))
    ap.add_argument("--no-loader", action="store_true", help="skip the DataLoader rates")
    args = ap.parse_args()
    binary = os.environ.get("ISAR_CLUTTER_BIN", "target/release/isar-clutter")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        rng = np.random.default_rng(1)
        shape = (200, *args.size)
        z = rng.standard_normal(shape) + 1j * rng.standard_normal(shape)
        z = (z + 0.6 * np.roll(z, 1, 2) + 0.3 * np.roll(z, 1, 1)).astype(np.complex64)
        np.save(tmp / "stack.npy", z)
        folder = tmp / "model"
        subprocess.run([binary, "fit", "--input", tmp / "stack.npy", "--method", args.method,
                        "--half-width", "8", "--out", folder], check=True, capture_output=True)
        model = ic.Model.load(folder)
        n = args.samples
        cli = []
        for r in range(args.repeats):
            out = subprocess.run([binary, "generate", "--model", folder, "--samples", str(n),
                                  "--seed", str(r), "--out", tmp / "x.npy"],
                                 check=True, capture_output=True, text=True)
            cli.append(float(re.search(r"\(([\d.]+) samples/s\)", out.stderr).group(1)))
            os.remove(tmp / "x.npy")
        py = []
        for r in range(args.repeats):
            t = time.perf_counter()
            model.generate(n, r)
            py.append(n / (time.perf_counter() - t))
        print("command line:", " ".join(f"{v:.0f}" for v in cli), file=sys.stderr)
        print("Python:      ", " ".join(f"{v:.0f}" for v in py), file=sys.stderr)
        rates = {"command line generate (samples/s)": max(cli),
                 "Model.generate in Python (samples/s)": max(py)}
        try:
            if args.no_loader:
                raise ImportError
            import torch  # noqa: F401
            from torch.utils.data import DataLoader
            from isar_clutter.torch import ClutterDataset
        except ImportError:
            print("torch missing: no DataLoader rate", file=sys.stderr)
        else:
            for workers in (0, 2):
                best = 0.0
                for r in range(args.repeats):
                    data = ClutterDataset(model, seed=r, samples=n, block=64)
                    t = time.perf_counter()
                    for _ in DataLoader(data, batch_size=64, num_workers=workers):
                        pass
                    best = max(best, n / (time.perf_counter() - t))
                rates[f"DataLoader, {workers} workers, batch 64 (samples/s)"] = best
        for k, v in rates.items():
            print(f"{k:55s} {v:10.0f}")
        print(f"Python / command line: {max(py) / max(cli):.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
