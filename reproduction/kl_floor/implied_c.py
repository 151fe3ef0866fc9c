"""Implied c = printed KL / (1/N + 1/M) for every printed KL value (per area: 64N, 64M).
Run: venv/bin/python implied_c.py > implied_c.md"""
import numpy as np
T1 = {"2nd": [-21.53, -21.75, -21.51, -21.52, -21.49, -21.62], "4th": [-21.90, -22.12, -21.86, -21.90, -21.84, -21.98]}
T2 = {"2nd": [-13.32, -12.31, -12.36, -12.97, -13.22, -12.22], "4th": [-13.71, -12.97, -13.36, -12.76, -14.09, -12.91]}
# Tables 8-10: (pix re, pix im, area re, area im) for exp / non-exp rows
T810 = {"T8 full cov": [(0.0017, 0.0017, 3.53e-6, 3.35e-6), (0.0016, 0.0016, 3.80e-6, 3.81e-6)],
        "T9 method 1": [(0.0013, 0.0013, 2.89e-5, 2.75e-5), (0.0013, 0.0013, 2.96e-5, 2.80e-5)],
        "T10 method 2": [(0.0013, 0.0013, 2.89e-5, 2.67e-5), (0.0013, 0.0013, 3.02e-5, 2.92e-5)]}
T1315 = {"T13 full cov": [(0.0144, 0.0147, 3.03e-4, 2.86e-4), (0.0151, 0.0149, 2.94e-4, 2.89e-4), (0.0151, 0.0151, 2.83e-4, 2.97e-4), (0.0155, 0.0158, 2.81e-4, 2.89e-4)],
         "T14 method 1": [(0.0145, 0.0142, 3.03e-4, 2.84e-4), (0.0146, 0.0145, 2.92e-4, 2.96e-4), (0.0146, 0.0146, 2.96e-4, 3.08e-4), (0.0142, 0.0143, 2.86e-4, 2.83e-4)],
         "T15 method 2": [(0.0145, 0.0144, 2.75e-4, 2.87e-4), (0.0147, 0.0143, 2.91e-4, 2.87e-4), (0.0146, 0.0145, 2.96e-4, 3.15e-4), (0.0144, 0.0142, 2.84e-4, 2.72e-4)]}
s = lambda N, M: 1 / N + 1 / M
print("| table / rows | printed (mean, range) | N | M | 1/N+1/M | implied c (mean, range) |")
print("|---|---|---|---|---|---|")
for k, v in T1.items():
    lin = 10 ** (np.array(v) / 10)
    for M in (100, 1000, 5000, 10**9):
        Ms = "inf" if M == 10**9 else M
        print(f"| Table 1 {k}-order mean, 6 rows | {lin.mean():.5f} ({lin.min():.5f}-{lin.max():.5f}) = {np.mean(v):.2f} dB | 100 | {Ms} | {s(100,M):.4f} | {lin.mean()/s(100,M):.3f} ({lin.min()/s(100,M):.3f}-{lin.max()/s(100,M):.3f}) |")
for k, v in T2.items():
    lin = 10 ** (np.array(v) / 10)
    d = np.array(v) - np.array(T1[k])
    print(f"| Table 2 {k}-order worst, 6 rows | {lin.mean():.4f} ({lin.min():.4f}-{lin.max():.4f}); worst - mean = {d.mean():.2f} dB ({d.min():.2f} to {d.max():.2f}) | 100 | ? | | (max over 4096 pixels, not a floor) |")
for k, rows in T810.items():
    for lab, r in zip(("exp", "non-exp"), rows):
        for (N, M) in ((1000, 1000), (100, 100)) if lab == "non-exp" else ((1000, 1000),):
            pix = np.array(r[:2]); ar = np.array(r[2:])
            print(f"| {k}, {lab}, per pixel | {pix.mean():.4g} | {N} | {M} | {s(N,M):.4g} | {pix.mean()/s(N,M):.3f} |")
            print(f"| {k}, {lab}, 8x8 area | {ar.mean():.3g} | {64*N} | {64*M} | {s(64*N,64*M):.3g} | {ar.mean()/s(64*N,64*M):.3f} |")
for k, rows in T1315.items():
    a = np.array(rows)
    pix = a[:, :2].ravel(); ar = a[:, 2:].ravel()
    print(f"| {k}, per pixel (8 values) | {pix.mean():.4g} ({pix.min():.4g}-{pix.max():.4g}) | 100 | 100 | 0.02 | {pix.mean()/0.02:.3f} ({pix.min()/0.02:.3f}-{pix.max()/0.02:.3f}) |")
    print(f"| {k}, 8x8 area (8 values) | {ar.mean():.3g} ({ar.min():.3g}-{ar.max():.3g}) | 6400 | 6400 | 3.125e-4 | {ar.mean()/3.125e-4:.3f} ({ar.min()/3.125e-4:.3f}-{ar.max()/3.125e-4:.3f}) |")
