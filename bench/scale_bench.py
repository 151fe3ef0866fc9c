#!/usr/bin/env python3
"""Scale benchmark (issue 31): sweeps of tiny jobs (filtered noise 32 x 32, 50 samples,
levels 2, --no-report) run locally and as 4 shards + merge, with wall time, peak RSS (each
process's own, from wait4), files and bytes in the output folder, and the tool's time per job
beyond the jobs' own computation. Peak RSS is each process's own (`wait4`); Linux counts the
parent's peak in it (see `census`), so this script keeps itself small (about 15 MB: the floor
of every figure).

    python bench/scale_bench.py --bin target/release/isar-clutter --jobs 1000 10000 100000
    python bench/scale_bench.py --bin ... --jobs 2000 --maps      # with the default npy maps

Prints one Markdown row per (jobs, mode). `--maps` keeps `npy_maps` at its default (20 map
files a job); without it the spec sets `npy_maps: false`, what docs/spec.md advises for a big
sweep. `--threads` sets --jobs of the tool (default 2).
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time


def spec(path, n, maps):
    values = ", ".join(f"{1.0 + i * 1e-4:.5f}" for i in range(n))
    outputs = "" if maps else "outputs:\n  npy_maps: false\n"
    with open(path, "w") as f:
        f.write(
            f"name: tiny{n}\nseed: 7\ndatasets:\n  - id: t\n    kind: filtered_noise\n"
            f"    family: exponential\n    alpha_h: 1.0\n    alpha_v: 1.0\n    size: [32, 32]\n"
            f"    samples: 50\n    half_width: 4\nanalysis:\n  levels: 2\n{outputs}"
            f"sweep:\n  zip:\n    datasets.t.alpha_h: [{values}]\n"
        )


def timed(cmd):
    """Wall seconds and peak RSS (bytes) of one process."""
    t = time.perf_counter()
    p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(p.pid, 0)
    wall = time.perf_counter() - t
    err = p.stderr.read().decode(errors="replace")
    if os.waitstatus_to_exitcode(status) != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{err}")
    return wall, usage.ru_maxrss * 1024


def census(out):
    """Names of regular files (a map hard-linked into the job store counts twice: two names
    for a file system's metadata) and bytes on disk (each file once: `du` counts a hard link
    once). Both counted by child processes, their output a line: walking a folder of a million
    files here grew this process by hundreds of MB, and a child's peak RSS as Linux reports it
    is never below its parent's peak (Python starts children with vfork, and `exec` records the
    peak of the memory it leaves, the parent's)."""
    count = subprocess.run(["sh", "-c", 'find "$1" -type f | wc -l', "sh", out], check=True,
                           capture_output=True)
    files = int(count.stdout)
    du = subprocess.run(["du", "-s", "--block-size=1", out], check=True, capture_output=True)
    return files, int(du.stdout.split()[0])


def compute_s(out):
    """Seconds the jobs spent in their own computation (the manifest's elapsed_s), summed, by
    a child process: the manifest of a sweep with maps lists every file, and parsing it here
    grew this process to 250 MB, the floor of every later figure (see `census`)."""
    code = ("import json,sys; m=json.load(open(sys.argv[1])); "
            "print(sum(j['elapsed_s'] for j in m['jobs']))")
    r = subprocess.run([sys.executable, "-c", code, os.path.join(out, "manifest.json")],
                       check=True, capture_output=True)
    return float(r.stdout)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", required=True)
    ap.add_argument("--jobs", type=int, nargs="+", default=[1000, 10000])
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--shards", type=int, default=4)
    ap.add_argument("--maps", action="store_true")
    ap.add_argument("--dir", default=None, help="where to run (default: a temporary folder)")
    ap.add_argument("--keep", action="store_true")
    a = ap.parse_args()
    base = a.dir or tempfile.mkdtemp(prefix="isar-scale-")
    os.makedirs(base, exist_ok=True)
    t = str(a.threads)
    print("| jobs | mode | wall s | peak RSS MB | file names | MB on disk | tool ms/job beyond the jobs |")
    print("|---:|---|---:|---:|---:|---:|---:|")
    for n in a.jobs:
        s = os.path.join(base, f"tiny{n}.yaml")
        spec(s, n, a.maps)
        local = os.path.join(base, f"local{n}")
        shutil.rmtree(local, ignore_errors=True)
        wall, rss = timed([a.bin, "run", s, "--out", local, "--no-report", "-q", "--jobs", t])
        files, size = census(local)
        beyond = (wall - compute_s(local) / a.threads) / n * 1e3
        print(f"| {n} | local | {wall:.1f} | {rss / 1e6:.0f} | {files} | {size / 1e6:.0f} | {beyond:.2f} |",
              flush=True)
        sharded = os.path.join(base, f"sharded{n}")
        shutil.rmtree(sharded, ignore_errors=True)
        walls, rsss = [], []
        for i in range(a.shards):
            w, r = timed([a.bin, "run", s, "--out", sharded, "--no-report", "-q", "--jobs", t,
                          "--shards", str(a.shards), "--shard", str(i)])
            walls.append(w)
            rsss.append(r)
        mw, mr = timed([a.bin, "merge", sharded, "--no-report", "-q", "--jobs", t])
        files, size = census(sharded)
        total = sum(walls) + mw
        beyond = (total - compute_s(sharded) / a.threads) / n * 1e3
        print(f"| {n} | {a.shards} shards one after another + merge | {sum(walls):.1f} + {mw:.1f} "
              f"| {max(rsss) / 1e6:.0f} / {mr / 1e6:.0f} | {files} | {size / 1e6:.0f} | {beyond:.2f} |",
              flush=True)
        if not a.keep:
            shutil.rmtree(local, ignore_errors=True)
            shutil.rmtree(sharded, ignore_errors=True)
    if not a.keep and a.dir is None:
        shutil.rmtree(base, ignore_errors=True)


if __name__ == "__main__":
    main()
