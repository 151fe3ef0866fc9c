"""'Mean over bins instead of sum' variants (iid N(0,1)): symmetric ln KL divided by the
number of bins B, or by the number of bins where both counts are > 0 (nanmean-like).
c = E[.]/(1/N+1/M).  Run: venv/bin/python mc_meanbins.py  (seed 20240607)"""
import numpy as np
from kl_lib import edges_for, counts, kl_from_counts
SEED = 20240607
sizes = [(100, 100, 1000), (1000, 1000, 400), (6400, 6400, 150), (64000, 64000, 40), (100, 1000, 1000)]
print("estimator                          " + "".join(f"{str((N,M)):>15s}" for N, M, R in sizes))
res = {}
for (N, M, R) in sizes:
    rng = np.random.default_rng([SEED, N, M, 7])
    X = rng.standard_normal((R, N)); Y = rng.standard_normal((R, M))
    s = 1 / N + 1 / M
    for B in (4, 5, 6, 10, 16, 32, 64):
        lo, w, nb = edges_for(X, Y, "fixed", "union", B)
        cx, cy, v = counts(X, Y, lo, w, nb, "clip")
        both = ((cx > 0) & (cy > 0)).sum(1)
        for e in ("skip", "pseudo"):
            d = kl_from_counts(cx, cy, v, e)
            sym = d[0] + d[1]
            res.setdefault(f"B={B:2d} {e:6s} sym/B", []).append((sym / B).mean() / s)
            res.setdefault(f"B={B:2d} {e:6s} pq/B", []).append((d[0] / B).mean() / s)
            if e == "skip":
                res.setdefault(f"B={B:2d} {e:6s} sym/B_both", []).append((sym / both).mean() / s)
for k, v in res.items():
    print(f"{k:34s} " + "".join(f"{x:15.3f}" for x in v))
