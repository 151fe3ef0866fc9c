"""Compact iid floor table c(N=M) in printed units for selected estimator definitions.
Run: venv/bin/python ctable.py > ctable.md  (reads floor.csv)"""
import csv, math
fl = {(r["est"], int(r["N"]), int(r["M"])): r for r in csv.DictReader(open("floor.csv"))}
L10, L2 = math.log(10), math.log(2)
rows = [("fixed5_union|skip", "pq", L10, "5 bins, union range, log10, one direction"),
        ("fixed6_union|skip", "pq", L10, "6 bins, union range, log10, one direction"),
        ("fixed4_union|skip", "pq", L10, "4 bins, union range, log10, one direction"),
        ("fixed3_union|skip", "sym", L10, "3 bins, union range, log10, symmetric sum"),
        ("fixed2_union|skip", "pq", L2, "2 bins, union range, log2, one direction"),
        ("fixed3_union|skip", "pq", 1, "3 bins, union range, ln, one direction"),
        ("fixed10_union|skip", "sym", 10, "10 bins, ln, symmetric, / B (mean over bins)"),
        ("fixed16_union|pseudo", "sym", 16, "16 bins+0.5 pseudo, ln, symmetric, / B"),
        ("fixed32_union|pseudo", "sym", 32, "32 bins+0.5 pseudo, ln, symmetric, / B"),
        ("fixed32_union|pseudo", "sym", 1, "tool now: 32 bins+0.5 pseudo, ln, symmetric"),
        ("fixed32_union|pseudo", "pq", 1, "tool, one direction"),
        ("fixed32_union|skip", "pq", 1, "32 bins, skip empty, ln, one direction"),
        ("fixed32_union|eps", "pq", 1, "32 bins, +eps, ln, one direction"),
        ("fixed10_union|eps", "pq", L10, "10 bins, +eps, log10, one direction"),
        ("fixed10_orig_clip(hist)|skip", "pq", L10, "MATLAB hist default (10 bins on original, open ends), log10, one dir"),
        ("fixed10_orig_clip(hist)|skip", "pq", 1, "MATLAB hist default, ln, one dir"),
        ("sturges_union|skip", "pq", 1, "Sturges on union, ln, one dir"),
        ("sqrt_union|skip", "pq", 1, "sqrt rule on union, ln, one dir"),
        ("scott_union|skip", "pq", 1, "Scott on union, ln, one dir"),
        ("scott_orig_drop|skip", "pq", 1, "Scott on original, gen. outside dropped, ln"),
        ("auto(scott,nice)_orig_drop|skip", "pq", 1, "histcounts 'auto' on original (nice edges), ln"),
        ("auto(scott,nice)_orig_drop|pseudo", "pq", 1, "histcounts 'auto' on original, pseudo, ln"),
        ("fd_union|skip", "pq", 1, "Freedman-Diaconis on union, ln"),
        ("fixed10_union|skip|pdf", "pq", 1, "10 bins 'pdf' normalisation (N(0,1) units), ln"),
        ("gauss_fit", "pq", 1, "Gaussian fit (parametric), ln, one direction"),
        ("gauss_fit", "sym", L10, "Gaussian fit, log10, symmetric"),
        ("kde_silverman", "pq", 1, "KDE Silverman, ln, one direction"),
        ("kde_ksdensity", "pq", 1, "KDE ksdensity bandwidth, ln, one direction")]
sizes = [(100, 100), (1000, 1000), (6400, 6400), (64000, 64000), (100, 1000)]
print("| estimator | " + " | ".join(f"N={N},M={M}" for N, M in sizes) + " | max/min over N=M |")
print("|---|" + "---|" * (len(sizes) + 1))
for est, d, div, lab in rows:
    v = []
    for N, M in sizes:
        r = fl[(est, N, M)]
        e = float(r["E_pq"]) if d == "pq" else float(r["E_sym"])
        v.append(e / div / (1 / N + 1 / M))
    print(f"| {lab} | " + " | ".join(f"{x:.3g}" for x in v) + f" | {max(v[:4])/min(v[:4]):.2f} |")
