#!/usr/bin/env python3
"""Compares two output folders of isar-clutter runs value for value.

Used to show that a change of code layout (or any refactoring) leaves every result unchanged:
run every shipped experiment before and after into two folders and compare them.

    .venv/bin/python bench/compare_outputs.py BEFORE_DIR AFTER_DIR

BEFORE_DIR and AFTER_DIR are either two run folders (each with a manifest.json) or two parents
of run folders (`outputs/`-like: every sub-folder with a manifest.json is compared with the one
of the same name). For each pair it compares

* every `*.parquet` table: the same columns in the same order with the same types, the same
  number of rows, and every value equal (NaN equals NaN, null equals null); columns that hold
  wall times or rates (`elapsed_s`, `*_s`, `*_seconds`, `*_per_second`) are left out, as they
  differ from run to run;
* every `.npy` file below `maps/`, `samples/`, `models/` and `kspace/` byte for byte, and the
  files of the models (JSON) with their timing-free keys;
* the manifest's per-job identities and seeds.

With `--rtol R` (after the two folders), floating-point values may differ by up to R times the
largest magnitude of their column (tables) or array (`.npy` of floats or complex numbers): for
a change that moves results by rounding only (another summation order, another `sin`). The
largest such difference seen, relative to that scale, is printed. Everything else (integers,
strings, shapes, the JSON of models) stays exact.

Exit status 0 when everything is identical (within R), 1 with one line per difference
otherwise, 2 on bad arguments. Needs pyarrow and numpy (`make bench-deps` installs them into
.venv).
"""

import json
import math
import sys
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq

TIMING_SUFFIXES = ("_s", "_seconds", "_per_second")
# Set from --rtol; WORST[0] is the largest scaled difference accepted.
RTOL = 0.0
WORST = [0.0]
FILE_FOLDERS = ("maps", "samples", "models", "kspace")


def is_timing(name: str) -> bool:
    return name.endswith(TIMING_SUFFIXES)


def same_value(a, b) -> bool:
    if isinstance(a, float) and isinstance(b, float):
        return (math.isnan(a) and math.isnan(b)) or a == b
    return a == b


def close(a, b, scale) -> bool:
    """Equal, or (with --rtol) two finite floats within RTOL x scale."""
    if same_value(a, b):
        return True
    if RTOL > 0 and isinstance(a, float) and isinstance(b, float) and math.isfinite(a) and math.isfinite(b):
        d = abs(a - b) / scale if scale > 0 else math.inf
        if d <= RTOL:
            WORST[0] = max(WORST[0], d)
            return True
    return False


def close_npy(pa: Path, pb: Path) -> bool:
    """Two `.npy` files of one float or complex dtype and shape within RTOL x the largest
    magnitude of the first, NaN where NaN."""
    a, b = np.load(pa), np.load(pb)
    if a.dtype != b.dtype or a.shape != b.shape or a.dtype.kind not in "fc":
        return False
    nan_a, nan_b = np.isnan(a), np.isnan(b)
    if not np.array_equal(nan_a, nan_b):
        return False
    fa, fb = a[~nan_a], b[~nan_b]
    if fa.size == 0:
        return True
    scale = float(np.max(np.abs(fa)))
    d = float(np.max(np.abs(fa - fb))) / scale if scale > 0 else (0.0 if np.array_equal(fa, fb) else math.inf)
    if d <= RTOL:
        WORST[0] = max(WORST[0], d)
        return True
    return False


def identical(ca, cb) -> bool:
    """The fast answer for two columns of one type that are the same: Arrow's own equality
    (nulls equal, NaN unequal), then, for numeric columns without nulls, numpy's with NaN equal
    to NaN. False sends the column to the value-by-value comparison below (which also applies
    --rtol and names the first differing row): a big sweep's tables have hundreds of millions
    of values, too many to compare one Python object at a time when nothing changed."""
    if ca.equals(cb):
        return True
    if ca.null_count or cb.null_count:
        return False
    try:
        na, nb = ca.to_numpy(), cb.to_numpy()
    except Exception:
        return False
    if na.dtype.kind == "f":
        return bool(np.array_equal(na, nb, equal_nan=True))
    return na.dtype.kind in "iub" and bool(np.array_equal(na, nb))


def compare_table(a: Path, b: Path, out: list) -> None:
    ta, tb = pq.read_table(a), pq.read_table(b)
    cols_a = [c for c in ta.column_names if not is_timing(c)]
    cols_b = [c for c in tb.column_names if not is_timing(c)]
    if cols_a != cols_b:
        out.append(f"{b}: columns {cols_b} differ from {cols_a}")
        return
    if ta.num_rows != tb.num_rows:
        out.append(f"{b}: {tb.num_rows} rows, before {ta.num_rows}")
        return
    for c in cols_a:
        ca, cb = ta.column(c), tb.column(c)
        if ca.type != cb.type:
            out.append(f"{b}: column {c} has type {cb.type}, before {ca.type}")
            continue
        if identical(ca, cb):
            continue
        va, vb = ca.to_pylist(), cb.to_pylist()
        floats = [x for x in va if isinstance(x, float) and math.isfinite(x)]
        scale = max((abs(x) for x in floats), default=0.0)
        bad = [i for i, (x, y) in enumerate(zip(va, vb)) if not close(x, y, scale)]
        if bad:
            i = bad[0]
            out.append(
                f"{b}: column {c} differs in {len(bad)} rows (first: row {i}, {va[i]!r} -> {vb[i]!r})"
            )


def strip_timing(v):
    if isinstance(v, dict):
        return {k: strip_timing(x) for k, x in v.items() if not is_timing(k) and k != "timing"}
    if isinstance(v, list):
        return [strip_timing(x) for x in v]
    return v


def compare_manifest(a: Path, b: Path, out: list) -> None:
    ma, mb = json.loads(a.read_text()), json.loads(b.read_text())
    keys = ("job", "dataset", "method", "identity", "seed", "data_seed", "generation_seed", "status", "error")
    ja = [{k: j.get(k) for k in keys} for j in ma.get("jobs", [])]
    jb = [{k: j.get(k) for k in keys} for j in mb.get("jobs", [])]
    # Jobs of the run as a whole (calibration, hypotheses) may be listed after the dataset jobs.
    jb = jb[: len(ja)] if len(jb) >= len(ja) else jb
    if ja != jb:
        out.append(f"{b}: manifest jobs differ")
    for k in ("master_seed", "spec_hash_sha256", "calibration_seed"):
        if ma.get(k) != mb.get(k):
            out.append(f"{b}: manifest {k} {mb.get(k)!r}, before {ma.get(k)!r}")


def files_below(root: Path):
    return sorted(p.relative_to(root) for p in root.rglob("*") if p.is_file() and not p.name.startswith("."))


def compare_run(a: Path, b: Path, out: list) -> int:
    tables = sorted(p.name for p in a.glob("*.parquet"))
    after = sorted(p.name for p in b.glob("*.parquet"))
    if tables != after:
        out.append(f"{b}: tables {after}, before {tables}")
    for name in tables:
        if (b / name).exists():
            compare_table(a / name, b / name, out)
    n = len(tables)
    for folder in FILE_FOLDERS:
        fa, fb = a / folder, b / folder
        la = files_below(fa) if fa.is_dir() else []
        lb = files_below(fb) if fb.is_dir() else []
        if la != lb:
            out.append(f"{fb}: files {sorted(set(la) ^ set(lb))[:5]} are in one folder only")
        in_b = set(lb)  # a set: a sweep's maps folder holds 100,000 files
        for rel in la:
            if rel not in in_b:
                continue
            pa, pb = fa / rel, fb / rel
            if pa.suffix == ".json":
                if strip_timing(json.loads(pa.read_text())) != strip_timing(json.loads(pb.read_text())):
                    out.append(f"{pb}: differs")
            elif pa.read_bytes() != pb.read_bytes() and not (RTOL > 0 and pa.suffix == ".npy" and close_npy(pa, pb)):
                out.append(f"{pb}: differs")
            n += 1
    compare_manifest(a / "manifest.json", b / "manifest.json", out)
    return n


def main() -> int:
    global RTOL
    args = sys.argv[1:]
    if len(args) == 4 and args[2] == "--rtol":
        try:
            RTOL = float(args[3])
        except ValueError:
            print(f"--rtol {args[3]!r} is not a number", file=sys.stderr)
            return 2
        args = args[:2]
    if len(args) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    a, b = Path(args[0]), Path(args[1])
    if (a / "manifest.json").exists():
        pairs = [(a, b)]
    else:
        runs = sorted(p.name for p in a.iterdir() if (p / "manifest.json").exists())
        if not runs:
            print(f"{a}: no run folders (with a manifest.json) found", file=sys.stderr)
            return 2
        pairs = [(a / r, b / r) for r in runs]
    out: list = []
    for pa, pb in pairs:
        if not (pb / "manifest.json").exists():
            out.append(f"{pb}: missing")
            continue
        n = compare_run(pa, pb, out)
        print(f"{pb.name}: {n} tables and files compared")
    for line in out:
        print(line)
    if RTOL > 0 and not out:
        print(f"largest difference accepted: {WORST[0]:.3g} of its column's or array's scale")
    print("identical" if not out else f"{len(out)} differences")
    return 0 if not out else 1


if __name__ == "__main__":
    sys.exit(main())
