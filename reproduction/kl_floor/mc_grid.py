"""Fixed global grid (bin width w in units of the true sigma, edges at multiples of w,
the same for every pixel, i.e. not adapted to the sample): iid N(0,1) floor c_pq (nats).
Run: venv/bin/python mc_grid.py  (seed 20240607)"""
import numpy as np
from kl_lib import counts, kl_from_counts
SEED = 20240607
print("w/sigma  " + "  ".join(f"{str((N,M)):>14s}" for N,M,R in [(100,100,0),(1000,1000,0),(6400,6400,0),(64000,64000,0)]))
for wdt in (0.5, 1.0, 1.5, 2.0, 2.5, 3.0):
    out = []
    for (N, M, R) in [(100, 100, 2000), (1000, 1000, 1000), (6400, 6400, 300), (64000, 64000, 60)]:
        rng = np.random.default_rng([SEED, N, int(wdt * 10)])
        X = rng.standard_normal((R, N)); Y = rng.standard_normal((R, M))
        nb = int(np.ceil(20 / wdt)) * 2
        lo = np.full(R, -nb / 2 * wdt - wdt / 2); w = np.full(R, wdt); nbv = np.full(R, nb)
        cx, cy, v = counts(X, Y, lo, w, nbv, "clip")
        d = kl_from_counts(cx, cy, v, "skip")
        occ = ((cx + cy) > 0).sum(1).mean()
        out.append(f"{d[0].mean()/(1/N+1/M):7.3f}[{occ:4.1f}]")
    print(f"{wdt:6.2f}  " + "  ".join(f"{o:>14s}" for o in out))
