"""Candidate KL estimators between two 1-D samples, vectorised over repeats.

X: (R, N) original, Y: (R, M) generated.  Every estimator returns (d_pq, d_qp) in NATS,
arrays of shape (R,): D(P||Q) (original || generated, Eq. 22 direction) and D(Q||P).
Symmetric (Eq. 23) = d_pq + d_qp.  Other log bases are pure rescalings (log2: /ln2,
log10: /ln10).
"""
import numpy as np

EPS = np.finfo(float).eps  # MATLAB eps = 2.22e-16
LN10 = np.log(10.0)
LN2 = np.log(2.0)


# ----------------------------------------------------------------------------- edges
def _nice_width(raw):
    """MATLAB binpicker 'nice' bin width (1, 2, 3, 5, 10 x power of ten)."""
    p10 = 10.0 ** np.floor(np.log10(raw))
    rel = raw / p10
    mult = np.select([rel < 1.5, rel < 2.5, rel < 4, rel < 7.5], [1, 2, 3, 5], 10)
    return mult * p10


def _iqr(a):
    q75, q25 = np.percentile(a, [75, 25], axis=1)
    return q75 - q25


def edges_for(X, Y, rule, on="union", B=None, nice=False):
    """Return lo (R,), width (R,), nbins (R,) int.

    rule: 'fixed' (needs B), 'scott', 'fd', 'sturges', 'sqrt'.
    on:   'union' (min..max and statistics of X and Y pooled) or 'orig' (X only).
    nice: MATLAB histcounts style nice width + left edge on a multiple of the width.
    """
    D = np.concatenate([X, Y], axis=1) if on == "union" else X
    n = D.shape[1]
    lo = D.min(axis=1)
    hi = D.max(axis=1)
    rng = hi - lo
    if rule == "fixed":
        w = rng / B
    elif rule == "scott":
        w = 3.5 * D.std(axis=1, ddof=1) * n ** (-1.0 / 3)
    elif rule == "fd":
        w = 2.0 * _iqr(D) * n ** (-1.0 / 3)
    elif rule == "sturges":
        w = rng / np.ceil(np.log2(n) + 1)
    elif rule == "sqrt":
        w = rng / np.ceil(np.sqrt(n))
    else:
        raise ValueError(rule)
    if nice and rule in ("scott", "fd"):
        w = _nice_width(w)
        lo = np.minimum(w * np.floor(lo / w), lo)
    nb = np.maximum(1, np.ceil((hi - lo) / w - 1e-9)).astype(int)
    w = np.where(nb * w < hi - lo, (hi - lo) / nb, w)  # guard: cover the range
    return lo, w, nb


def counts(X, Y, lo, w, nb, outside="clip"):
    """Histogram counts with shared edges. outside: 'clip' (into end bins, MATLAB hist
    with centres) or 'drop' (histcounts with explicit edges). Returns cx, cy of shape
    (R, Bmax) and a mask of valid bins."""
    R = X.shape[0]
    Bmax = int(nb.max())
    out = []
    for Z in (X, Y):
        idx = np.floor((Z - lo[:, None]) / w[:, None]).astype(np.int64)
        top = nb[:, None]
        # right edge belongs to the last bin
        idx = np.where((idx == top) & (Z <= (lo + w * nb)[:, None] + 1e-12), top - 1, idx)
        if outside == "clip":
            idx = np.clip(idx, 0, top - 1)
            keep = np.ones_like(idx, dtype=bool)
        else:
            keep = (idx >= 0) & (idx < top)
        flat = (np.arange(R)[:, None] * Bmax + idx)[keep]
        out.append(np.bincount(flat, minlength=R * Bmax).reshape(R, Bmax).astype(float))
    valid = np.arange(Bmax)[None, :] < nb[:, None]
    return out[0], out[1], valid


# ----------------------------------------------------------------------------- KL from counts
def kl_from_counts(cx, cy, valid, empty="skip", width=None):
    """empty:
       'skip'    : sum over bins where both counts > 0, p,q normalised over all bins
                   (no renormalisation to the common support)
       'skipren' : same but p,q renormalised over the common support
       'eps'     : p+eps, q+eps (MATLAB eps), 0*log0 = 0 for p = 0
       'pseudo'  : empty bins (in that histogram) get 0.5 counts, then normalise (tool)
       'laplace' : +1 in every valid bin
    width: if given (R,), use 'pdf' normalisation (density, not multiplied by width)."""
    cx = cx * valid
    cy = cy * valid
    if empty == "pseudo":
        cx = np.where(valid & (cx == 0), 0.5, cx)
        cy = np.where(valid & (cy == 0), 0.5, cy)
    elif empty == "laplace":
        cx = cx + valid
        cy = cy + valid
    nx = cx.sum(1, keepdims=True)
    ny = cy.sum(1, keepdims=True)
    p = cx / nx
    q = cy / ny
    if empty == "skipren":
        both = (cx > 0) & (cy > 0)
        p = np.where(both, p, 0)
        q = np.where(both, q, 0)
        p = p / p.sum(1, keepdims=True)
        q = q / q.sum(1, keepdims=True)
    if width is not None:
        p = p / width[:, None]
        q = q / width[:, None]
    if empty == "eps":
        pe, qe = p + EPS, q + EPS
        with np.errstate(divide="ignore", invalid="ignore"):
            t1 = np.where(p > 0, pe * np.log(pe / qe), 0.0)
            t2 = np.where(q > 0, qe * np.log(qe / pe), 0.0)
    else:
        both = (p > 0) & (q > 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            t1 = np.where(both, p * np.log(p / q), 0.0)
            t2 = np.where(both, q * np.log(q / p), 0.0)
    return t1.sum(1), t2.sum(1)


def hist_kl(X, Y, rule="fixed", B=10, on="union", outside="clip", empty="skip",
            nice=False, pdf=False):
    lo, w, nb = edges_for(X, Y, rule, on, B, nice)
    cx, cy, valid = counts(X, Y, lo, w, nb, outside)
    d = kl_from_counts(cx, cy, valid, empty, width=w if pdf else None)
    occ = ((cx + cy) * valid > 0).sum(1)
    occ_both = ((cx > 0) & (cy > 0)).sum(1)
    return d, nb, occ, occ_both


# ----------------------------------------------------------------------------- parametric / KDE
def gauss_kl(X, Y):
    m1, m2 = X.mean(1), Y.mean(1)
    v1, v2 = X.var(1, ddof=1), Y.var(1, ddof=1)
    dpq = 0.5 * (np.log(v2 / v1) + (v1 + (m1 - m2) ** 2) / v2 - 1)
    dqp = 0.5 * (np.log(v1 / v2) + (v2 + (m1 - m2) ** 2) / v1 - 1)
    return dpq, dqp


def kde_kl(X, Y, G=2048, rule="silverman"):
    """Gaussian KDE of each set (own bandwidth; Silverman 0.9 min(sd, IQR/1.34) n^-1/5
    or MATLAB ksdensity's 1.06*MAD/0.6745*n^-1/5 ('ksdensity')), evaluated on a common
    grid via linear binning + FFT, KL by the Riemann sum."""
    R = X.shape[0]
    lo = np.minimum(X.min(1), Y.min(1))
    hi = np.maximum(X.max(1), Y.max(1))

    def bw(Z):
        n = Z.shape[1]
        if rule == "silverman":
            s = np.minimum(Z.std(1, ddof=1), _iqr(Z) / 1.34)
            return 0.9 * s * n ** -0.2
        mad = np.median(np.abs(Z - np.median(Z, 1, keepdims=True)), 1) / 0.6745
        return (4.0 / (3 * n)) ** 0.2 * mad

    hx, hy = bw(X), bw(Y)
    pad = 4 * np.maximum(hx, hy)
    a, b = lo - pad, hi + pad
    dx = (b - a) / (G - 1)
    dens = []
    for Z, h in ((X, hx), (Y, hy)):
        t = (Z - a[:, None]) / dx[:, None]
        i0 = np.floor(t).astype(np.int64)
        fr = t - i0
        base = (np.arange(R)[:, None] * G)
        grid = (np.bincount((base + i0).ravel(), (1 - fr).ravel(), R * G)
                + np.bincount((base + np.minimum(i0 + 1, G - 1)).ravel(), fr.ravel(), R * G)
                ).reshape(R, G)
        k = np.fft.rfftfreq(2 * G)
        # Gaussian kernel in Fourier domain, bandwidth in grid units
        s = (h / dx)[:, None]
        K = np.exp(-2 * (np.pi * k[None, :] * s) ** 2)
        f = np.fft.irfft(np.fft.rfft(grid, 2 * G) * K, 2 * G)[:, :G]
        f = np.maximum(f, 1e-300)
        f /= f.sum(1, keepdims=True)
        dens.append(f)
    f, g = dens
    tiny = 1e-12
    f = np.maximum(f, tiny); g = np.maximum(g, tiny)
    f /= f.sum(1, keepdims=True); g /= g.sum(1, keepdims=True)
    return (f * np.log(f / g)).sum(1), (g * np.log(g / f)).sum(1)
