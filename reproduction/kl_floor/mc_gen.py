"""Generation-aware floors: per-pixel and 8x8-area KL (real part) for each candidate
estimator when the generated set is made as in the dissertation's methods (see
mc_block.py for the generators; 'fit2c' = the uncorrelated second-order model of
Table 1: per pixel mu + sigma z, z complex circular, sample mean/variance of the original,
no exact matching).  rho = spatial correlation per pixel step.
Writes gen.csv with c = E[KL]/(1/n_orig + 1/n_gen) in nats, n = N (pixel) or 64 N (area).
Run: venv/bin/python mc_gen.py   (seed 20240607)"""
import csv, sys
import numpy as np
from kl_lib import hist_kl, gauss_kl
from mc_block import field, gen as gen0

SEED = 20240607
EST = ([(f"fixed{B}", dict(rule="fixed", B=B, on="union", outside="clip", empty="skip")) for B in (2, 3, 4, 5, 6, 7, 8, 10, 16)]
       + [("fixed32_pseudo(tool)", dict(rule="fixed", B=32, on="union", outside="clip", empty="pseudo")),
          ("hist10_orig", dict(rule="fixed", B=10, on="orig", outside="clip", empty="skip")),
          ("sturges_union", dict(rule="sturges", on="union", outside="clip", empty="skip")),
          ("scott_orig_drop", dict(rule="scott", on="orig", outside="drop", empty="skip")),
          ("auto_orig_drop", dict(rule="scott", on="orig", outside="drop", empty="skip", nice=True)),
          ("gauss", None)])


def gen(rng, X, M, rho, how):
    if how == "fit2c":
        mu = X.mean(0); sd = np.sqrt((np.abs(X - mu) ** 2).mean(0))
        z = (rng.standard_normal((M, X.shape[1])) + 1j * rng.standard_normal((M, X.shape[1]))) / np.sqrt(2)
        return mu + sd * z
    return gen0(rng, X, M, rho, how)


def kl(spec, x, y):
    if spec is None:
        return gauss_kl(x, y)
    return hist_kl(x, y, **spec)[0]


def main():
    rows = []
    for rho in (0.0, 0.5):
        for (N, M, R) in [(100, 100, 300), (1000, 1000, 80), (100, 1000, 200)]:
            gens = ("iid", "fit2c", "fullcov", "mm_cplx", "mm_part") if N == M else ("iid", "fit2c")
            for how in gens:
                rng = np.random.default_rng([SEED, N, M, int(rho * 100), len(how), ord(how[-1])])
                acc = {name: ([], [], [], []) for name, _ in EST}
                for r in range(R):
                    X = field(rng, N, rho); Y = gen(rng, X, M, rho, how)
                    xr, yr = X.real, Y.real
                    for name, spec in EST:
                        dp = kl(spec, xr.T, yr.T)
                        da = kl(spec, xr.reshape(1, -1), yr.reshape(1, -1))
                        a = acc[name]
                        a[0].append(dp[0].mean()); a[1].append(dp[1].mean())
                        a[2].append(da[0][0]); a[3].append(da[1][0])
                sp = 1 / N + 1 / M; sa = sp / 64
                for name, a in acc.items():
                    a = [np.array(v) for v in a]
                    rows.append(dict(rho=rho, N=N, M=M, R=R, gen=how, est=name,
                                     c_pix_pq=a[0].mean() / sp, c_pix_qp=a[1].mean() / sp,
                                     c_area_pq=a[2].mean() / sa, c_area_qp=a[3].mean() / sa,
                                     se_area_pq=a[2].std(ddof=1) / np.sqrt(R) / sa))
                print(f"rho={rho} N={N} M={M} {how}", file=sys.stderr, flush=True)
    with open("gen.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys())); w.writeheader(); w.writerows(rows)

if __name__ == "__main__":
    main()
