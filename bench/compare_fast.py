#!/usr/bin/env python3
"""Compares two run folders of a big sweep quickly: `compare_outputs.py` checks every value in
Python, which takes tens of minutes for the ten million rows of a 5,000-job sweep; this checks
the same things column by column with numpy.

    .venv/bin/python bench/compare_fast.py BEFORE_DIR AFTER_DIR

* every `*.parquet` table: the same file names, the same columns with the same types, and every
  value equal (NaN equals NaN, null equals null), the wall-time columns (`*_s`) left out;
* every file below `maps/` byte for byte;
* the manifest's jobs: id, identity, seed, data seed and status, in order.

Exit status 0 when everything is identical, 1 otherwise. Needs pyarrow and numpy (`make
bench-deps`).
"""
import filecmp
import json
import os
import sys

import numpy as np
import pyarrow.parquet as pq


def same_column(u, v):
    """Equal values; NaN equals NaN; nulls (None) equal."""
    if len(u) != len(v):
        return False
    if u.dtype.kind == "f" and v.dtype.kind == "f":
        return np.array_equal(u, v, equal_nan=True)
    if u.dtype.kind == "O" or v.dtype.kind == "O":
        return all(p == q or (p != p and q != q) for p, q in zip(u.tolist(), v.tolist()))
    return np.array_equal(u, v)


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    a, b = sys.argv[1], sys.argv[2]
    bad = 0
    tables = sorted(f for f in os.listdir(a) if f.endswith(".parquet"))
    if tables != sorted(f for f in os.listdir(b) if f.endswith(".parquet")):
        print("the folders hold other tables")
        sys.exit(1)
    for t in tables:
        x = pq.read_table(os.path.join(a, t))
        y = pq.read_table(os.path.join(b, t))
        if x.schema != y.schema:
            print(f"{t}: columns or types differ")
            bad += 1
            continue
        keep = [c for c in x.column_names if not c.endswith("_s")]
        ok = all(
            same_column(x.column(c).to_numpy(zero_copy_only=False),
                        y.column(c).to_numpy(zero_copy_only=False))
            for c in keep
        )
        print(f"{t}: {x.num_rows} rows, {len(keep)} columns compared: "
              f"{'identical' if ok else 'DIFFERENT'}")
        bad += not ok
    n = 0
    for root, _, files in os.walk(os.path.join(a, "maps")):
        for f in files:
            p = os.path.join(root, f)
            q = os.path.join(b, os.path.relpath(p, a))
            n += 1
            if not os.path.exists(q) or not filecmp.cmp(p, q, shallow=False):
                print("differs:", os.path.relpath(p, a))
                bad += 1
    print(f"{n} map files compared byte for byte")
    with open(os.path.join(a, "manifest.json")) as f:
        ma = json.load(f)
    with open(os.path.join(b, "manifest.json")) as f:
        mb = json.load(f)

    def ids(m):
        return [(j["job"], j["identity"], j["seed"], j.get("data_seed"), j["status"])
                for j in m["jobs"]]

    same = ids(ma) == ids(mb)
    print("manifest jobs, identities, seeds:", "identical" if same else "DIFFERENT")
    bad += not same
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
