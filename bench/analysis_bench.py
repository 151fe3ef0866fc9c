#!/usr/bin/env python3
"""Analysis benchmark for BENCHMARKS.md (issue 2, item 8).

Side by side, in one run, on the same complex64 stack:
  * `isar-clutter run` end to end (process start, .npy load, 3-level analysis, Parquet, .npy
    maps, manifest, the job store): redone with --fresh without and with its report (figures
    unchanged), resumed from the job store, the first run on an input (hashed for the job's
    key), the first run into a new folder (every figure drawn), and the kernel alone (the
    manifest's analysis_s); the cases run in turn (round robin) so that the machine's drift
    falls on all alike, numpy's included;
  * (a) forming the full P x P sample covariance with numpy/OpenBLAS (what the method avoids);
  * (b) a straightforward vectorised numpy implementation of the same estimator, which is
    also checked against the tool's maps (max abs difference printed).
With --big, also a 100 x 1024 x 1024 stack under /usr/bin/time, reporting the peak RSS
against the input size.
"""
import argparse
import json
import os
import platform
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np


def median_time(fn, repeats):
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return float(np.median(times)), times


def numpy_estimator(stack, levels):
    """The estimator of docs/definitions.md section 3, vectorised with numpy, in complex128."""
    x = stack.astype(np.complex128)
    n = x.shape[0]
    mean = x.mean(axis=0)
    variance = (np.abs(x - mean) ** 2).mean(axis=0)
    out = {"mean": mean, "variance": variance}
    units = x
    for level in range(1, levels + 1):
        h, w = units.shape[1] // 2 * 2, units.shape[2] // 2 * 2
        u = units[:, :h, :w]
        c = u - u.mean(axis=0)
        u1, u2, u3, u4 = c[:, 0::2, 0::2], c[:, 0::2, 1::2], c[:, 1::2, 0::2], c[:, 1::2, 1::2]
        cov = lambda a, b: (a * b.conj()).real.mean(axis=0)
        s1, s2, s3, s4 = (np.sqrt(cov(a, a)) for a in (u1, u2, u3, u4))
        pairs = {
            "H": (cov(u1, u2) + cov(u3, u4), s1 * s2 + s3 * s4),
            "V": (cov(u1, u3) + cov(u2, u4), s1 * s3 + s2 * s4),
            "D": (cov(u1, u4) + cov(u2, u3), s1 * s4 + s2 * s3),
        }
        for d, (csum, denom) in pairs.items():
            with np.errstate(invalid="ignore", divide="ignore"):
                out[f"level{level}_correlation_{d}"] = np.where(denom == 0, np.nan, csum / denom)
            out[f"level{level}_covariance_{d}"] = csum / 2
        units = u[:, 0::2, 0::2] + u[:, 0::2, 1::2] + u[:, 1::2, 0::2] + u[:, 1::2, 1::2]
    return out


def full_covariance(stack):
    """(a): the P x P sample covariance in complex128."""
    n = stack.shape[0]
    x = stack.reshape(n, -1).astype(np.complex128)
    x -= x.mean(axis=0)
    return (x.conj().T @ x) / n


def write_spec(path, name, npy, levels):
    path.write_text(
        f"name: {name}\nseed: 1\ndatasets:\n  - id: bench\n    kind: npy\n    path: {npy.name}\n"
        f"analysis:\n  levels: {levels}\n"
    )


def run_tool(binary, spec, out, threads, report=False, fresh=True, touch=None, new_out=False):
    """One `isar-clutter run`; `fresh`: the job is redone (--fresh), not resumed from the job
    store, so that the analysis really runs; `touch`: the input's times are moved first, so
    that the run hashes it for the job's key as a first run on new data does; `new_out`: into
    an empty output folder, so that the report draws every figure."""
    extra = ([] if report else ["--no-report"]) + (["--fresh"] if fresh else [])
    if touch is not None:
        os.utime(touch)
    if new_out:
        shutil.rmtree(out, ignore_errors=True)
    subprocess.run([binary, "run", str(spec), "--out", str(out), "--jobs", str(threads), "--quiet", *extra], check=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", required=True)
    ap.add_argument("--samples", type=int, default=1000)
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--levels", type=int, default=3)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--full-repeats", type=int, default=2)
    ap.add_argument("--big", action="store_true", help="also run the 100 x 1024 x 1024 memory check")
    ap.add_argument("--workdir", default="bench-data")
    args = ap.parse_args()

    work = Path(args.workdir)
    work.mkdir(exist_ok=True)
    rng = np.random.default_rng(2020)
    shape = (args.samples, args.size, args.size)
    stack = (rng.standard_normal(shape, dtype=np.float32) + 1j * rng.standard_normal(shape, dtype=np.float32)).astype(np.complex64)
    npy = work / f"stack_{args.samples}x{args.size}x{args.size}.npy"
    np.save(npy, stack)
    spec = work / "bench.yaml"
    write_spec(spec, "bench", npy, args.levels)
    out = work / "out"
    # The first-run case hashes its own copy of the input (moving a file's times makes every
    # run that reads it hash it again).
    npy_first = work / "stack_first.npy"
    shutil.copyfile(npy, npy_first)
    spec_first = work / "bench_first.yaml"
    write_spec(spec_first, "bench", npy_first, args.levels)
    # Inputs older than a second (their hashes may be remembered) and on disk, so that no
    # write-back runs beside the timings.
    time.sleep(1.1)
    os.sync()

    b, th = args.bin, args.threads
    cases = {
        # --fresh: the job is redone, not resumed from the store; without the report.
        "noreport": lambda: run_tool(b, spec, out, th),
        # With its report; the figures found unchanged.
        "report": lambda: run_tool(b, spec, work / "out_report", th, report=True),
        # A re-run that finds its job done in the store, with the report.
        "resumed": lambda: run_tool(b, spec, work / "out_report", th, report=True, fresh=False),
        # The first run on new data: the input is hashed for the job's key.
        "first": lambda: run_tool(b, spec_first, work / "out_first", th, report=True, touch=npy_first),
        # The first run into a new output folder: every figure drawn.
        "new": lambda: run_tool(b, spec, work / "out_new", th, report=True, new_out=True),
        "numpy": lambda: numpy_estimator(stack, args.levels),
    }
    for fn in cases.values():  # the page cache, the figures, the store
        fn()
    # Round robin, so that the machine's drift falls on every case alike.
    times = {k: [] for k in cases}
    kernels = []
    for _ in range(args.repeats):
        for name, fn in cases.items():
            t = time.perf_counter()
            fn()
            times[name].append(time.perf_counter() - t)
            if name == "noreport":
                m = json.loads((out / "manifest.json").read_text())
                kernels.append(m["jobs"][0]["timing"]["analysis_s"])
    med = {k: float(np.median(v)) for k, v in times.items()}
    t_run, t_report, t_resumed, t_first, t_new, t_numpy = (
        med[k] for k in ("noreport", "report", "resumed", "first", "new", "numpy"))
    t_kernel = float(np.median(kernels))
    t_full, _ = median_time(lambda: full_covariance(stack), args.full_repeats)

    # Cross-check the tool's maps against the numpy estimator.
    ref = numpy_estimator(stack, args.levels)
    maps = out / "maps" / "bench"
    worst = 0.0
    for key, value in ref.items():
        got = np.load(maps / f"{key}.npy")
        worst = max(worst, float(np.nanmax(np.abs(got - value))))

    nbytes = stack.nbytes
    rows = [
        ("isar-clutter run --fresh --no-report (end to end, process included)", t_run),
        ("  of which the analysis kernel", t_kernel),
        ("isar-clutter run --fresh with its report (figures unchanged)", t_report),
        ("isar-clutter run, resumed (job done in the store), with its report", t_resumed),
        ("isar-clutter run, first on this input (hashed for the key), with its report", t_first),
        ("isar-clutter run into a new folder (input hashed, every figure drawn)", t_new),
        ("(b) numpy vectorised estimator", t_numpy),
        ("(a) numpy full P x P sample covariance", t_full),
    ]
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, {platform.processor() or platform.platform()}")
    print(f"stack: {shape} complex64 = {nbytes / 1e6:.1f} MB, levels {args.levels}, threads {args.threads}, numpy {np.__version__}")
    print()
    print("| what | median time | input throughput |")
    print("|---|---:|---:|")
    for name, t in rows:
        print(f"| {name} | {t * 1e3:.1f} ms | {nbytes / t / 1e9:.2f} GB/s |")
    print()
    print(f"speed-up of the whole run: {t_numpy / t_run:.1f}x vs (b), {t_full / t_run:.0f}x vs (a)")
    print(f"speed-up of the whole run with its report: {t_numpy / t_report:.1f}x vs (b); resumed: {t_numpy / t_resumed:.1f}x; "
          f"first on this input: {t_numpy / t_first:.1f}x; new folder: {t_numpy / t_new:.1f}x")
    print(f"kernel: {nbytes / t_kernel / 1e9:.2f} GB/s of complex64 input")
    print(f"max |tool - numpy| over all maps: {worst:.2e}")

    if args.big:
        big(args, work)


def big(args, work):
    n, h, w = 100, 1024, 1024
    npy = work / f"stack_{n}x{h}x{w}.npy"
    if not npy.exists():
        rng = np.random.default_rng(7)
        arr = np.lib.format.open_memmap(npy, mode="w+", dtype=np.complex64, shape=(n, h, w))
        for i in range(n):
            arr[i] = rng.standard_normal((h, w), dtype=np.float32) + 1j * rng.standard_normal((h, w), dtype=np.float32)
        arr.flush()
        del arr
    spec = work / "big.yaml"
    write_spec(spec, "big", npy, args.levels)
    out = work / "big_out"
    t = time.perf_counter()
    res = subprocess.run(["/usr/bin/time", "-v", args.bin, "run", str(spec), "--out", str(out), "--jobs", str(args.threads), "--quiet"],
                         check=True, capture_output=True, text=True)
    wall = time.perf_counter() - t
    rss_kb = next(int(l.split(":")[1]) for l in res.stderr.splitlines() if "Maximum resident set size" in l)
    m = json.loads((out / "manifest.json").read_text())
    timing = m["jobs"][0]["timing"]
    input_mb = n * h * w * 8 / 1e6
    print()
    print(f"big stack {n}x{h}x{w} complex64 ({input_mb:.0f} MB): wall {wall:.2f} s, load {timing['data_s']:.2f} s, "
          f"kernel {timing['analysis_s']:.2f} s ({timing['analysis_gb_per_s']:.2f} GB/s), peak RSS {rss_kb / 1e3:.0f} MB "
          f"= input + {rss_kb / 1e3 - input_mb:.0f} MB")


if __name__ == "__main__":
    sys.exit(main())
