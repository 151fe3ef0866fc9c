"""Counts over run folders of experiments/hypotheses.yaml (one per master seed) in how many
Table 16's ordering of the plants' mean pixel variance (A > B > C, no wind and light wind) and
each hypothesis row's verdict hold: the stand-in plants are calibrated at one seed
(docs/definitions.md section 10), and a verdict that holds only in some seeds is not a finding.

Usage: python count.py FOLDER...  (reads FOLDER/hypotheses.parquet with pyarrow)."""

import sys
from collections import defaultdict

import pyarrow.parquet as pq


def rows(folder):
    t = pq.read_table(f"{folder}/hypotheses.parquet").to_pydict()
    return list(zip(t["hypothesis"], t["dataset"], t["statistic"], t["value"], t["verdict"]))


def main(folders):
    order = defaultdict(int)
    verdicts = defaultdict(lambda: defaultdict(int))
    variance = defaultdict(list)
    for f in folders:
        rs = rows(f)
        v = {d: x for h, d, s, x, _ in rs if h == "table16"}
        for wind in ["none", "light"]:
            a, b, c = (v[f"plant_{p}_{wind}"] for p in "ABC")
            variance[f"A {wind}"].append(a)
            variance[f"B {wind}"].append(b)
            variance[f"C {wind}"].append(c)
            order[wind] += a > b > c
        for h, d, s, _, verdict in rs:
            if h != "table16" and verdict is not None:
                verdicts[(h, d, s)][verdict] += 1
    n = len(folders)
    print(f"{n} seeds")
    for wind in ["none", "light"]:
        print(f"Table 16 ordering A > B > C, {wind} wind: {order[wind]} of {n}")
    for k, xs in variance.items():
        m = sum(xs) / len(xs)
        sd = (sum((x - m) ** 2 for x in xs) / max(len(xs) - 1, 1)) ** 0.5
        print(f"mean pixel variance {k}: {m:.4g} +- {sd:.3g} (min {min(xs):.4g}, max {max(xs):.4g})")
    print("| hypothesis | dataset | statistic | verified | not verified |")
    print("|---|---|---|---:|---:|")
    for (h, d, s), c in sorted(verdicts.items()):
        print(f"| {h} | {d} | {s} | {c.get('verified', 0)} | {c.get('not verified', 0)} |")


if __name__ == "__main__":
    main(sys.argv[1:])
