"""Block model: how the way the generated set is made changes the histogram-KL floor.

Original: N samples of an 8x8 block of a complex circular Gaussian field with separable
exponential spatial correlation rho^|lag| (rho per pixel step), unit variance.
Generated (M samples) by
  iid      : an independent draw of the same process
  fullcov  : x = mu + (1/sqrt(N)) sum_i z_i (x_i - mu), z_i real N(0,1)   (the tool's
             full-covariance method: exact sample covariance + pseudo-covariance in law)
  mm_cplx  : same process, then per pixel scaled to the original's complex sample mean and
             complex sample variance (|.|^2 summed), i.e. variance split equally between
             real and imaginary parts (methods 1-2, circular)
  mm_part  : same process, then real and imaginary parts each scaled to the original's
             per-part sample mean and sample variance (methods 1-2, per part)
KL on the real part: per pixel (N vs M values) averaged over the 64 pixels, and per area
(64N vs 64M pooled values).
Writes block.csv. Run: venv/bin/python mc_block.py  (seed 20240607)
"""
import csv
import sys
import numpy as np
from kl_lib import hist_kl, gauss_kl

SEED = 20240607
BS = 8
EST = [("fixed", B) for B in (2, 3, 4, 5, 6, 8, 10, 32)] + [("gauss", None)]


def field(rng, n, rho):
    """(n, 64) complex samples, unit complex variance, separable exponential corr."""
    idx = np.arange(BS)
    C1 = rho ** np.abs(idx[:, None] - idx[None, :])
    L = np.linalg.cholesky(np.kron(C1, C1) + 1e-12 * np.eye(BS * BS))
    z = (rng.standard_normal((n, BS * BS)) + 1j * rng.standard_normal((n, BS * BS))) / np.sqrt(2)
    return z @ L.T


def gen(rng, X, M, rho, how):
    N = X.shape[0]
    if how == "fullcov":
        mu = X.mean(0)
        Z = rng.standard_normal((M, N))
        return mu + Z @ (X - mu) / np.sqrt(N)
    Y = field(rng, M, rho)
    if how == "iid":
        return Y
    if how == "mm_cplx":
        mx, my = X.mean(0), Y.mean(0)
        vx = (np.abs(X - mx) ** 2).mean(0)
        vy = (np.abs(Y - my) ** 2).mean(0)
        return mx + (Y - my) * np.sqrt(vx / vy)
    if how == "mm_part":
        out = []
        for f in (np.real, np.imag):
            x, y = f(X), f(Y)
            out.append(x.mean(0) + (y - y.mean(0)) * x.std(0) / y.std(0))
        return out[0] + 1j * out[1]
    raise ValueError(how)


def kl(est, x, y):
    """x: (R, n), y: (R, m) real -> (d_pq, d_qp) nats."""
    kind, B = est
    if kind == "gauss":
        return gauss_kl(x, y)
    return hist_kl(x, y, "fixed", B, "union", "clip", "skip")[0]


def main(out="block.csv", cases=None):
    if cases is None:
        cases = [(100, 100, 150), (1000, 1000, 40)]
    rows = []
    for rho in (0.0, 0.5, 0.8):
        for (N, M, R) in cases:
            rng = np.random.default_rng([SEED, N, M, int(rho * 100)])
            acc = {}
            for r in range(R):
                X = field(rng, N, rho)
                for how in ("iid", "fullcov", "mm_cplx", "mm_part"):
                    Y = gen(rng, X, M, rho, how)
                    xr, yr = X.real, Y.real
                    for est in EST:
                        dp = kl(est, xr.T, yr.T)            # 64 pixels as repeats
                        da = kl(est, xr.reshape(1, -1), yr.reshape(1, -1))
                        a = acc.setdefault((how, est), [[], [], [], []])
                        a[0].append(dp[0].mean()); a[1].append((dp[0] + dp[1]).mean())
                        a[2].append(da[0][0]); a[3].append(da[0][0] + da[1][0])
            for (how, est), a in acc.items():
                sp = 1 / N + 1 / M
                sa = 1 / (64 * N) + 1 / (64 * M)
                a = [np.array(v) for v in a]
                rows.append(dict(rho=rho, N=N, M=M, R=R, gen=how,
                                 est=f"{est[0]}{est[1] or ''}",
                                 c_pix_pq=a[0].mean() / sp, c_pix_sym=a[1].mean() / sp,
                                 c_area_pq=a[2].mean() / sa,
                                 se_area_pq=a[2].std(ddof=1) / np.sqrt(R) / sa,
                                 c_area_sym=a[3].mean() / sa))
            print(f"rho={rho} N={N} done", file=sys.stderr, flush=True)
    with open(out, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader(); w.writerows(rows)


if __name__ == "__main__":
    main()
