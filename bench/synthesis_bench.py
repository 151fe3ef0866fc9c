#!/usr/bin/env python3
"""Full-covariance synthesis against numpy (BENCHMARKS.md, issue 3 item 7).

Side by side in one run, on the same stack of 100 complex64 samples of 64 x 64 (P = 4096
pixels), fit included, M generated samples:
  * isar-clutter: `fit --method full_covariance` then `generate --samples M` (process start,
    .npy read and write included);
  * numpy, what a user would pick instead: the sample mean and the 8192 x 8192 sample
    covariance of the real and imaginary parts, then `rng.multivariate_normal(mean, cov, M)`
    (which factorises the covariance by SVD).
"""
import argparse
import os
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", required=True)
    ap.add_argument("--samples", type=int, default=2000, help="M, samples generated")
    ap.add_argument("--fit-samples", type=int, default=100)
    args = ap.parse_args()
    rng = np.random.default_rng(11)
    n, h, w = args.fit_samples, 64, 64
    z = rng.standard_normal((n, h + 1, w + 1)) + 1j * rng.standard_normal((n, h + 1, w + 1))
    stack = (z[:, :-1, :-1] + 0.6 * z[:, :-1, 1:] + 0.3 * z[:, 1:, :-1]).astype(np.complex64)
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        np.save(d / "stack.npy", stack)
        t = time.perf_counter()
        subprocess.run([args.bin, "fit", "--input", str(d / "stack.npy"), "--method", "full_covariance", "--out", str(d / "model")], check=True, capture_output=True)
        subprocess.run([args.bin, "generate", "--model", str(d / "model"), "--samples", str(args.samples), "--seed", "1", "--out", str(d / "gen.npy")], check=True, capture_output=True)
        t_tool = time.perf_counter() - t
        gen = np.load(d / "gen.npy", mmap_mode="r")
        assert gen.shape == (args.samples, h, w)

    t = time.perf_counter()
    x = np.concatenate([stack.real.reshape(n, -1), stack.imag.reshape(n, -1)], axis=1).astype(np.float64)
    mean = x.mean(axis=0)
    cov = np.cov(x, rowvar=False, bias=True)
    t_fit = time.perf_counter() - t
    t = time.perf_counter()
    y = np.random.default_rng(1).multivariate_normal(mean, cov, size=args.samples, method="svd", check_valid="ignore")
    t_gen = time.perf_counter() - t
    assert y.shape == (args.samples, 2 * h * w)
    t_numpy = t_fit + t_gen
    print(f"machine: {os.cpu_count()} cores, numpy {np.__version__}; fit on {n} samples of {h}x{w}, {args.samples} generated")
    print("| what | time |")
    print("|---|---:|")
    print(f"| isar-clutter fit + generate (2 processes) | {t_tool:.2f} s |")
    print(f"| numpy sample covariance (8192 x 8192) | {t_fit:.2f} s |")
    print(f"| numpy multivariate_normal (SVD + draws) | {t_gen:.2f} s |")
    print(f"speed-up, fit included: {t_numpy / t_tool:.0f}x")


if __name__ == "__main__":
    main()
