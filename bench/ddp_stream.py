#!/usr/bin/env python3
"""The stream into DistributedDataParallel (issue 51): samples/s of examples/ddp_train.py on 2
ranks (torchrun, gloo, one DataLoader worker each) against one process with a DataLoader of
2 workers, in the same run, drawing only (`--stream-only`) and training the example's network.

A Method 1 model fitted to 64 x 64 clutter (half-width 8) streams `--samples` samples per
epoch in batches of 64; every configuration runs `--repeats` times and the median is printed.

    python bench/ddp_stream.py [--samples 20000] [--repeats 3]
"""
import argparse
import platform
import re
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

import isar_clutter as ic

ROOT = Path(__file__).resolve().parents[1]


def rate(cmd):
    out = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
    return float(re.search(r"all ranks: \d+ samples in [\d.]+ s, (\d+) samples/s", out).group(1))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=20000)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    z = rng.standard_normal((200, 64, 64)) + 1j * rng.standard_normal((200, 64, 64))
    z = (z + 0.6 * np.roll(z, 1, axis=2) + 0.3 * np.roll(z, 1, axis=1)).astype(np.complex64)
    with tempfile.TemporaryDirectory() as tmp:
        ic.fit(z, method="method1", half_width=8).save(Path(tmp) / "m")
        example = [str(ROOT / "examples" / "ddp_train.py"), "--model", str(Path(tmp) / "m"),
                   "--samples", str(args.samples), "--batch-size", "64", "--epochs", "1"]
        single = [sys.executable, *example, "--workers", "2"]
        ddp = [sys.executable, "-m", "torch.distributed.run", "--standalone", "--nproc-per-node=2",
               *example, "--workers", "1"]
        print(f"{platform.processor() or platform.machine()}, {len(__import__('os').sched_getaffinity(0))} CPUs; "
              f"{args.samples} samples of 64 x 64, batch 64, median of {args.repeats}\n")
        print("| | one process, 2 workers (samples/s) | DDP 2 ranks x 1 worker (samples/s) | ratio |")
        print("|---|---|---|---|")
        for name, extra in (("stream only", ["--stream-only"]), ("stream + training", [])):
            a = statistics.median(rate(single + extra) for _ in range(args.repeats))
            b = statistics.median(rate(ddp + extra) for _ in range(args.repeats))
            print(f"| {name} | {a:.0f} | {b:.0f} | {b / a:.2f} |", flush=True)


if __name__ == "__main__":
    main()
