#!/usr/bin/env python3
"""Generation benchmark for BENCHMARKS.md (issue 16): `isar-clutter generate` end to end next to
numpy, in one run, on models fitted to the same stack.

For every method (64 x 64, half-width 8), `isar-clutter generate --samples M --out x.npy` is
timed as a user runs it (process start, model load, sampling, the .npy written), the output file
removed before each repeat so that every run writes a new file, and its samples/s printed with
the peak RSS (constant memory: it must not grow with M). Next to it, in the same run:
  * numpy doing the same sampling, vectorised as a user would write it (a batch of white seeds,
    the spatially varying separable filter per row group as einsum over sliding windows, the
    scaling, np.save): Methods 1 and 2, full covariance (normals times the deviations),
    uncorrelated and fourth order;
  * writing the same number of bytes to a new file with numpy (np.save of a ready array), the
    cost of the output alone on this machine's page cache.
"""
import argparse
import json
import os
import platform
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view


def timed_generate(binary, model, samples, out, extra=(), repeats=3):
    rates, rss = [], []
    for _ in range(repeats):
        if out.exists():
            out.unlink()
        time.sleep(0.5)
        t = time.perf_counter()
        res = subprocess.run(["/usr/bin/time", "-f", "%M", binary, "generate", "--model", str(model), "--samples", str(samples),
                              "--seed", "1", "--out", str(out), *extra], check=True, capture_output=True, text=True)
        rates.append(samples / (time.perf_counter() - t))
        rss.append(int(res.stderr.strip().splitlines()[-1]) / 1e3)
    return float(np.median(rates)), max(rss)


def exponential_taps(alpha, k):
    d = np.arange(-k, k + 1)
    with np.errstate(divide="ignore"):
        mag = np.where(d == 0, 1.0, np.exp(-np.abs(d)[None] / np.abs(alpha)[..., None]))
    return np.where((alpha[..., None] < 0) & (d % 2 != 0), -mag, mag)


def dyadic_taps(r, k):
    """r: [L, ...] -> taps [..., 2k+1]."""
    d = np.abs(np.arange(-k, k + 1))
    band = np.where(d == 0, -1, np.floor(np.log2(np.maximum(d, 1))).astype(int))
    taps = np.ones(r.shape[1:] + (2 * k + 1,))
    for l in range(r.shape[0]):
        taps[..., band == l] = r[l][..., None]
    reach = 2 ** r.shape[0] - 1
    taps[..., d > reach] = 0.0
    return taps


def numpy_filter_method(model, samples, k=8, batch=250):
    """Methods 1 and 2 in numpy: per level-1 cell row, horizontal sums over the padded seed
    rows it reads, then the vertical sums, the scaling and the mean."""
    info = json.loads((model / "model.json").read_text())
    h, w = info["height"], info["width"]
    mean, std = np.load(model / "mean.npy"), np.load(model / "std.npy")
    if info["method"] == "method1":
        fh, fv = exponential_taps(np.load(model / "alpha_h.npy"), k), exponential_taps(np.load(model / "alpha_v.npy"), k)
    else:
        fh, fv = dyadic_taps(np.load(model / "r_h.npy"), k), dyadic_taps(np.load(model / "r_v.npy"), k)
    # Per pixel (cells of 2 x 2).
    fh = np.repeat(np.repeat(fh, 2, axis=0), 2, axis=1)  # [h, w, 2k+1]
    fv = np.repeat(np.repeat(fv, 2, axis=0), 2, axis=1)
    sd = np.sqrt((fh ** 2).sum(-1) * (fv ** 2).sum(-1))
    scale = std / sd
    rng = np.random.default_rng(1)
    out = np.empty((samples, h, w), np.complex64)
    n = 2 * k + 1
    for b0 in range(0, samples, batch):
        m = min(batch, samples - b0)
        seed = (rng.standard_normal((m, h + 2 * k, w + 2 * k)) + 1j * rng.standard_normal((m, h + 2 * k, w + 2 * k))) / np.sqrt(2)
        win = sliding_window_view(seed, n, axis=2)  # [m, H+2k, w, n]
        y = np.empty((m, h, w), np.complex128)
        for i0 in range(0, h, 2):
            rows = win[:, i0:i0 + 2 + 2 * k]  # seed rows of the group
            hs = np.einsum("mrjb,jb->mrj", rows, fh[i0])  # shared horizontal taps of the cell row
            for i in (i0, i0 + 1):
                y[:, i] = np.einsum("maj,ja->mj", hs[:, i - i0:i - i0 + n], fv[i])
        out[b0:b0 + m] = mean + y * scale
    return out


def numpy_full_covariance(model, samples):
    dev = np.load(model / "deviations.npy")
    n, h, w = dev.shape
    mean = np.load(model / "mean.npy")
    rng = np.random.default_rng(1)
    z = rng.standard_normal((samples, n))
    return (mean.reshape(-1) + z @ dev.reshape(n, -1)).reshape(samples, h, w).astype(np.complex64)


def numpy_uncorrelated(model, samples):
    mean, std = np.load(model / "mean.npy"), np.load(model / "std.npy")
    rng = np.random.default_rng(1)
    shape = (samples,) + mean.shape
    z = (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) / np.sqrt(2)
    return (mean + z * std).astype(np.complex64)


def numpy_fourth_order(model, samples):
    mean = np.load(model / "mean.npy")
    c, sd = np.load(model / "fleishman.npy"), np.load(model / "component_sd.npy")
    rng = np.random.default_rng(1)
    parts = []
    for comp in range(2):
        z = rng.standard_normal((samples,) + mean.shape)
        a, b, cc, d = c[comp]
        parts.append(sd[comp] * (a + z * (b + z * (cc + z * d))))
    return (mean + parts[0] + 1j * parts[1]).astype(np.complex64)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", required=True)
    ap.add_argument("--samples", type=int, default=20000, help="samples per generate command")
    ap.add_argument("--numpy-samples", type=int, default=2000, help="samples per numpy run (numpy is slower)")
    ap.add_argument("--workdir", default="bench-data")
    args = ap.parse_args()
    work = Path(args.workdir)
    work.mkdir(exist_ok=True)
    rng = np.random.default_rng(11)
    h = w = 64
    stacks = {}
    for n in (1000, 100):
        z = rng.standard_normal((n, h + 1, w + 1)) + 1j * rng.standard_normal((n, h + 1, w + 1))
        stacks[n] = work / f"gen_stack_{n}.npy"
        np.save(stacks[n], (z[:, :-1, :-1] + 0.6 * z[:, :-1, 1:] + 0.3 * z[:, 1:, :-1]).astype(np.complex64))
    cases = [("method1", 1000), ("method2", 1000), ("full_covariance", 100), ("full_covariance", 1000),
             ("fourth_order", 1000), ("uncorrelated", 1000)]
    numpy_of = {"method1": numpy_filter_method, "method2": numpy_filter_method, "full_covariance": numpy_full_covariance,
                "uncorrelated": numpy_uncorrelated, "fourth_order": numpy_fourth_order}
    out = work / "generated.npy"
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores; numpy {np.__version__}; 64 x 64, half-width 8; "
          f"{args.samples} samples per command, {args.numpy_samples} per numpy run")
    print()
    print("| method (fitted on N) | isar-clutter generate, end to end | peak RSS | numpy, same sampling + np.save | speed-up |")
    print("|---|---:|---:|---:|---:|")
    for method, n in cases:
        model = work / f"gen_model_{method}_{n}"
        subprocess.run([args.bin, "fit", "--input", str(stacks[n]), "--method", method, "--out", str(model)],
                       check=True, capture_output=True)
        rate, rss = timed_generate(args.bin, model, args.samples, out)
        with tempfile.TemporaryDirectory(dir=work) as d:
            t = time.perf_counter()
            x = numpy_of[method](model, args.numpy_samples)
            np.save(Path(d) / "x.npy", x)
            np_rate = args.numpy_samples / (time.perf_counter() - t)
        print(f"| {method} (N = {n}) | {rate:,.0f} samples/s | {rss:.0f} MB | {np_rate:,.0f} samples/s | {rate / np_rate:.0f}x |")
    model = work / "gen_model_method1_1000"
    rate, rss = timed_generate(args.bin, model, args.samples, out, extra=["--buffered"])
    print(f"| method1, `--buffered` (page cache instead of direct I/O) | {rate:,.0f} samples/s | {rss:.0f} MB | | |")
    # The output alone: the same bytes written to a new file.
    ready = np.zeros((args.samples, h, w), np.complex64)
    ready.real = 1.0
    times = []
    for _ in range(3):
        if out.exists():
            out.unlink()
        time.sleep(0.5)
        t = time.perf_counter()
        np.save(out, ready)
        times.append(time.perf_counter() - t)
    out.unlink()
    t = float(np.median(times))
    print()
    print(f"np.save of {ready.nbytes / 1e6:.0f} MB (the samples' bytes) to a new file: {t:.2f} s = "
          f"{args.samples / t:,.0f} samples/s through the page cache")


if __name__ == "__main__":
    main()
