#!/usr/bin/env python3
"""Pairs of `isar-clutter run` started at the same moment into one folder (issue 26).

For each pair, two runs are started together into a new folder: half of the pairs with the same
job ids and different seeds, half with different sweeps. Counted: pairs where both succeeded
(must be 0), where neither did, folders that mix two runs (the tables, values without the
timing columns, and the maps, bytes, must equal the winner's results run alone), and refusals
whose message does not name the holder's pid.

    .venv/bin/python bench/race_pairs.py --bin target/release/isar-clutter --pairs 200
"""

import argparse
import hashlib
import os
import subprocess
import sys
import tempfile

import pyarrow.parquet as pq

SPEC = """name: race
seed: {seed}
datasets:
  - id: a
    kind: filtered_noise
    family: exponential
    alpha_h: 1.0
    alpha_v: 0.5
    size: [32, 32]
    samples: 300
    half_width: 4
  - id: b
    kind: filtered_noise
    family: exponential
    alpha_h: 0.5
    alpha_v: 2.0
    size: [32, 32]
    samples: 300
    half_width: 4
analysis:
  levels: 2
sweep:
  grid:
    datasets.*.mean: {means}
"""


def fingerprint(folder):
    """The folder's results: every table's values without `*_s` columns, every map's bytes."""
    out = {}
    for name in sorted(os.listdir(folder)):
        if name.endswith(".parquet"):
            t = pq.read_table(os.path.join(folder, name))
            keep = [c for c in t.column_names if not c.endswith("_s")]
            out[name] = repr(t.select(keep).to_pydict())
    maps = os.path.join(folder, "maps")
    for root, _, files in os.walk(maps):
        for f in files:
            p = os.path.join(root, f)
            with open(p, "rb") as fh:
                out[os.path.relpath(p, folder)] = hashlib.sha256(fh.read()).hexdigest()
    return out


def run(bin_, spec, out):
    return subprocess.Popen(
        [bin_, "run", spec, "--out", out, "--no-report", "--quiet"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", required=True)
    ap.add_argument("--pairs", type=int, default=200)
    args = ap.parse_args()
    tmp = tempfile.mkdtemp(prefix="race-")
    specs = []
    for i, (seed, means) in enumerate([(1, "[0, 1, 2]"), (2, "[0, 1, 2]"), (1, "[5, 6]")]):
        p = os.path.join(tmp, f"s{i}.yaml")
        with open(p, "w") as f:
            f.write(SPEC.format(seed=seed, means=means))
        specs.append(p)
    refs = []
    for i, s in enumerate(specs):
        out = os.path.join(tmp, f"ref{i}")
        p = run(args.bin, s, out)
        _, err = p.communicate()
        if p.returncode != 0:
            sys.exit(f"reference {i} failed: {err}")
        refs.append(fingerprint(out))
    both = neither = mixed = unnamed = 0
    kinds = {"same ids, other seed": (0, 1), "other sweep": (0, 2)}
    for n in range(args.pairs):
        kind = list(kinds)[n % 2]
        x, y = kinds[kind]
        if n % 4 >= 2:
            x, y = y, x
        out = os.path.join(tmp, f"pair{n}")
        a, b = run(args.bin, specs[x], out), run(args.bin, specs[y], out)
        ea, eb = a.communicate()[1], b.communicate()[1]
        ok = (a.returncode == 0, b.returncode == 0)
        if all(ok):
            both += 1
        elif not any(ok):
            neither += 1
            print(f"pair {n}: neither succeeded:\n{ea}\n{eb}")
        else:
            holder, msg = (a.pid, eb) if ok[0] else (b.pid, ea)
            if f"locked by a run (pid {holder}," not in msg:
                unnamed += 1
                print(f"pair {n}: refusal without the holder's pid {holder}: {msg}")
        fp = fingerprint(out)
        winners = [w for w, o in zip((x, y), ok) if o]
        if winners and not any(fp == refs[w] for w in winners):
            mixed += 1
            print(f"pair {n} ({kind}): the folder mixes runs")
        elif n == 0:
            print(f"pair 0: refused run said: {(eb if ok[0] else ea).strip()}")
    print(
        f"{args.pairs} pairs: both succeeded {both}, neither {neither}, mixed folders {mixed}, "
        f"refusals not naming the holder {unnamed}"
    )
    subprocess.run(["rm", "-rf", tmp])
    sys.exit(1 if both or mixed or unnamed or neither else 0)


if __name__ == "__main__":
    main()
