"""The start of a fit: linear regressions on Savitzky–Golay derivatives (the friction curve,
then the mass) and the periodic forces the model leaves out, looked for in the regression's
residual force (peaks of its periodogram in time and in position)."""

from __future__ import annotations

import numpy as np
from scipy.ndimage import maximum_filter1d, minimum_filter1d

from .simulate import _delayed, _derivatives

REGRESSION_SMOOTH_S = 0.02  # smoothing of the regression's derivatives (and command), s
DETECT_SMOOTH_S = 0.02  # smoothing of the residual force searched for periodic forces, s
PEAK_RATIO = 6.0  # a periodic force is a candidate where its share is 6× the median's
MAX_SCAN_SAMPLES = 8_000
# at most this many frequencies (or wavenumbers) per scan: the grid's spacing (a quarter of the
# trace's resolution) is coarsened beyond it, so that a long trace or a long stroke costs
# bounded memory and time (8e3 samples × 2e4 points: ~1 s, the arrays 0.5 MB)
MAX_SCAN_POINTS = 20_000
PEAK_CANDIDATES = 6


def _regression_start(u, y, T, lo, hi, d, friction):
    """Initial (m, b, f_c, f_s − f_c, v_s) and the residual RMS, from linear regressions on
    the delayed command and Savitzky–Golay derivatives smoothed alike: the friction curve
    (b |v| + f_c + (f_s − f_c) e^{−(v/v_s)²}, v_s from a grid) on the quasi-steady samples
    (small acceleration), then the mass on all moving samples with that friction."""
    reg = _regression_data(u, y, T, lo, hi, d, smooth_s=REGRESSION_SMOOTH_S)
    v, a, uf = reg["v"], reg["a"], reg["u"]
    # quasi-steady: the velocity within ±10 % of its value over the smoothing window on both
    # sides (a plateau; not a reversal, a break-away or a chirp)
    span = 2 * int(round(REGRESSION_SMOOTH_S / T)) + 1
    v_range = maximum_filter1d(v, span) - minimum_filter1d(v, span)
    steady_all = v_range < 0.2 * np.abs(v)
    mov = reg["moving"]
    v, a, uf, steady = v[mov], a[mov], uf[mov], steady_all[mov]
    vmax = float(np.max(np.abs(v)))
    if steady.sum() < 50:
        steady = np.abs(a) <= np.quantile(np.abs(a), 0.2)
    vs_, ys = np.abs(v[steady]), uf[steady] * np.sign(v[steady])
    best = None
    grid = np.geomspace(max(1e-5, 1e-3 * vmax), max(2e-5, 0.5 * vmax), 14) if friction else [1.0]
    for vs in grid[::-1]:
        if friction and best is not None and np.count_nonzero(vs_ < 2 * vs) < 30:
            continue  # a Stribeck band the steady samples hardly reach: not supported
        cols = [vs_] + ([np.ones_like(vs_), np.exp(-((vs_ / vs) ** 2))] if friction else [])
        X = np.column_stack(cols)
        coef, *_ = np.linalg.lstsq(X, ys, rcond=None)
        coef = np.maximum(coef, 0.0)
        res = float(np.sqrt(np.mean((X @ coef - ys) ** 2)))
        if best is None or res < best[0]:
            best = (res, coef, vs)
    _, coef, vs = best
    b = float(coef[0])
    fc = float(coef[1]) if friction else 0.0
    dfs = float(coef[2]) if friction else 0.0
    fr = b * v + (fc + dfs * np.exp(-((v / vs) ** 2))) * np.sign(v)
    m = float(a @ (uf - fr) / max(float(a @ a), 1e-300))
    res = float(np.sqrt(np.mean((m * a + fr - uf) ** 2)))
    return np.array([m, b, fc, dfs, vs]), res


def _regression_data(u, y, T, lo, hi, d, smooth_s=None) -> dict:
    """Savitzky–Golay velocity and acceleration of the positions in [lo, hi) (edges trimmed;
    window ``smooth_s``, default about 8 ms), the delayed command smoothed alike, the times,
    positions and the moving samples."""
    from scipy.signal import savgol_filter

    v, a, win = _derivatives(y, T, smooth_s)
    ua = _delayed(u, d)
    # the force over [k − 1, k + 1) ≈ the mean of the two applied commands
    uf = savgol_filter(0.5 * (ua + np.concatenate([[ua[0]], ua[:-1]])), win, 3)
    sl = slice(lo + win, hi - win)
    v, a, uf, x = v[sl], a[sl], uf[sl], y[sl]
    t = np.arange(lo + win, hi - win) * T
    vmax = float(np.max(np.abs(v))) if len(v) else 0.0
    moving = np.abs(v) > 1e-3 * vmax
    if moving.sum() < 10:
        moving = np.ones_like(v, dtype=bool)
    return {"v": v, "a": a, "u": uf, "x": x, "t": t, "moving": moving}


def _sinusoid_scan(s, r, omegas, chunk_elems=2_000_000):
    """Least-squares fit of r ≈ c_s sin(ω s) + c_c cos(ω s) at every ω: the explained share of
    r's variance and the amplitudes (c_s, c_c), computed in chunks (memory bounded)."""
    n = len(s)
    share = np.empty(len(omegas))
    cs = np.empty(len(omegas))
    cc = np.empty(len(omegas))
    rr = float(r @ r) or 1.0
    step = max(1, chunk_elems // max(n, 1))
    for i in range(0, len(omegas), step):
        w = omegas[i : i + step]
        ph = np.outer(w, s)
        S, C = np.sin(ph), np.cos(ph)
        a11, a22, a12 = (S * S).sum(1), (C * C).sum(1), (S * C).sum(1)
        b1, b2 = S @ r, C @ r
        det = a11 * a22 - a12 * a12
        det = np.where(det > 1e-12 * a11 * a22, det, np.inf)
        x1 = (a22 * b1 - a12 * b2) / det
        x2 = (a11 * b2 - a12 * b1) / det
        share[i : i + step] = (x1 * b1 + x2 * b2) / rr
        cs[i : i + step], cc[i : i + step] = x1, x2
    return share, cs, cc


def _peaks(share: np.ndarray, k: int) -> list:
    """Indices of up to ``k`` local maxima of ``share`` standing out (PEAK_RATIO × median),
    largest first."""
    if share.size < 3:
        return []
    level = PEAK_RATIO * float(np.median(share))
    inner = np.flatnonzero(
        (share[1:-1] >= share[:-2]) & (share[1:-1] >= share[2:]) & (share[1:-1] > level)
    )
    idx = inner + 1
    return [int(i) for i in idx[np.argsort(share[idx])[::-1]][:k]]


def _grid(lo: float, hi: float, step: float) -> np.ndarray:
    """``np.arange(lo, hi, step)``, or MAX_SCAN_POINTS evenly spaced points when that is more."""
    if (hi - lo) / step > MAX_SCAN_POINTS:
        return np.linspace(lo, hi, MAX_SCAN_POINTS, endpoint=False)
    return np.arange(lo, hi, step)


def _periodic_candidates(u, y, T, lo, hi, d, theta5, n_total) -> dict:
    """Candidates for a periodic force the model leaves out, from the regression's residual
    force on the quasi-steady samples (moving, small acceleration): a disturbance in time
    (frequency 3 / duration … min(50 Hz, 0.05 / T)) and a ripple in position (period 1 mm …
    half the stroke). {"disturbance": [(c_s, c_c, f_hz), ...], "ripple": [(c_s, c_c, k_rad_m),
    ...]}: the PEAK_CANDIDATES largest peaks standing out (PEAK_RATIO), largest first."""
    # smoothed over 20 ms: the periodic forces looked for are slow, the encoder's noise in a
    # second derivative is not
    reg = _regression_data(u, y, T, lo, hi, d, smooth_s=DETECT_SMOOTH_S)
    m, b, fc, dfs, vs = theta5
    v, a = reg["v"], reg["a"]
    model = m * a + b * v + (fc + dfs * np.exp(-((v / max(vs, 1e-12)) ** 2))) * np.sign(v)
    r = reg["u"] - model
    amax = float(np.max(np.abs(a))) or 1.0
    mask = reg["moving"] & (np.abs(a) < 0.1 * amax)
    if mask.sum() < 500:
        mask = reg["moving"]
    idx = np.flatnonzero(mask)
    if len(idx) > MAX_SCAN_SAMPLES:
        idx = idx[np.round(np.linspace(0, len(idx) - 1, MAX_SCAN_SAMPLES)).astype(int)]
    r = r[idx] - np.mean(r[idx])
    out: dict = {}
    t = reg["t"][idx]
    dur = n_total * T
    f_hi = min(50.0, 0.05 / T)
    f_lo = 3.0 / dur
    if f_hi > 2 * f_lo:
        f = _grid(f_lo, f_hi, 1.0 / (4.0 * dur))
        share, cs, cc = _sinusoid_scan(t, r, 2 * np.pi * f)
        found = [(float(cs[k]), float(cc[k]), float(f[k])) for k in _peaks(share, PEAK_CANDIDATES)]
        if found:
            out["disturbance"] = found
    x = reg["x"][idx]
    span = float(np.ptp(x))
    if span > 4e-3:
        k_lo, k_hi = 2 * np.pi / (0.5 * span), 2 * np.pi / 1e-3
        kk = _grid(k_lo, k_hi, 2 * np.pi / (4.0 * span))
        share, cs, cc = _sinusoid_scan(x, r, kk)
        found = [(float(cs[k]), float(cc[k]), float(kk[k])) for k in _peaks(share, PEAK_CANDIDATES)]
        if found:
            out["ripple"] = found
    return out
