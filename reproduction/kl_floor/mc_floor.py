"""Monte Carlo sampling floor E[KL] of candidate estimators, both sets iid N(0,1).

Writes floor.csv: one row per (estimator, N, M) with mean D(P||Q), D(Q||P) in nats, their
standard errors, c_pq = E[D(P||Q)]/(1/N+1/M), c_sym = E[D(P||Q)+D(Q||P)]/(1/N+1/M) (nats),
mean number of bins and occupied bins.
Run: venv/bin/python mc_floor.py      (seed 20240607, ~ a few minutes on 1-2 cores)
"""
import csv
import sys
import time
import numpy as np
from kl_lib import edges_for, counts, kl_from_counts, gauss_kl, kde_kl

SEED = 20240607
SIZES = [(100, 100, 2000), (1000, 1000, 1000), (6400, 6400, 400), (64000, 64000, 150),
         (100, 1000, 2000), (100, 5000, 1000)]
CHUNK_VALUES = 4_000_000  # values per chunk (memory)

BINNINGS = []  # (name, rule, on, outside, B, nice, empties)
for B in (2, 3, 4, 5, 6, 8, 10, 16, 32, 64):
    BINNINGS.append((f"fixed{B}_union", "fixed", "union", "clip", B, False,
                     ("skip", "eps", "pseudo", "skipren")))
BINNINGS.append(("fixed10_orig_clip(hist)", "fixed", "orig", "clip", 10, False, ("skip", "eps", "pseudo")))
BINNINGS.append(("fixed10_orig_drop", "fixed", "orig", "drop", 10, False, ("skip", "eps", "pseudo")))
for rule in ("scott", "fd", "sturges", "sqrt"):
    BINNINGS.append((f"{rule}_union", rule, "union", "clip", None, False, ("skip", "eps", "pseudo")))
    BINNINGS.append((f"{rule}_orig_drop", rule, "orig", "drop", None, False, ("skip", "eps", "pseudo")))
BINNINGS.append(("auto(scott,nice)_orig_drop", "scott", "orig", "drop", None, True, ("skip", "eps", "pseudo")))
BINNINGS.append(("auto(scott,nice)_union", "scott", "union", "clip", None, True, ("skip", "eps", "pseudo")))
PDF = [("fixed10_union", "fixed", "union", "clip", 10, False), ("scott_union", "scott", "union", "clip", None, False)]


def main(out="floor.csv", sizes=SIZES):
    rows = []
    for (N, M, R) in sizes:
        t0 = time.time()
        rng = np.random.default_rng([SEED, N, M])
        acc = {}

        def add(name, d, nb=None, occ=None):
            a = acc.setdefault(name, {"pq": [], "qp": [], "nb": [], "occ": []})
            a["pq"].append(d[0]); a["qp"].append(d[1])
            if nb is not None:
                a["nb"].append(nb); a["occ"].append(occ)

        chunk = max(1, min(R, CHUNK_VALUES // (N + M)))
        done = 0
        while done < R:
            r = min(chunk, R - done)
            X = rng.standard_normal((r, N))
            Y = rng.standard_normal((r, M))
            for (name, rule, on, outside, B, nice, empties) in BINNINGS:
                lo, w, nb = edges_for(X, Y, rule, on, B, nice)
                cx, cy, valid = counts(X, Y, lo, w, nb, outside)
                occ = ((cx + cy) * valid > 0).sum(1)
                for e in empties:
                    add(f"{name}|{e}", kl_from_counts(cx, cy, valid, e), nb, occ)
            for (name, rule, on, outside, B, nice) in PDF:
                lo, w, nb = edges_for(X, Y, rule, on, B, nice)
                cx, cy, valid = counts(X, Y, lo, w, nb, outside)
                add(f"{name}|skip|pdf", kl_from_counts(cx, cy, valid, "skip", width=w), nb,
                    ((cx + cy) * valid > 0).sum(1))
            add("gauss_fit", gauss_kl(X, Y))
            add("kde_silverman", kde_kl(X, Y, rule="silverman"))
            add("kde_ksdensity", kde_kl(X, Y, rule="ksdensity"))
            done += r
        s = 1.0 / N + 1.0 / M
        for name, a in acc.items():
            pq = np.concatenate(a["pq"]); qp = np.concatenate(a["qp"])
            sym = pq + qp
            row = dict(est=name, N=N, M=M, R=len(pq),
                       E_pq=pq.mean(), se_pq=pq.std(ddof=1) / np.sqrt(len(pq)),
                       E_qp=qp.mean(), E_sym=sym.mean(),
                       se_sym=sym.std(ddof=1) / np.sqrt(len(pq)),
                       c_pq=pq.mean() / s, c_sym=sym.mean() / s,
                       nbins=np.concatenate(a["nb"]).mean() if a["nb"] else np.nan,
                       occ=np.concatenate(a["occ"]).mean() if a["occ"] else np.nan)
            rows.append(row)
        print(f"N={N} M={M} R={R} {time.time()-t0:.1f}s", file=sys.stderr, flush=True)
    with open(out, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)


if __name__ == "__main__":
    main()
