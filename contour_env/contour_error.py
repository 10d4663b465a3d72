"""True contour error (unsigned shortest distance, m, from a point to the whole packed path),
the nearest path point (foot point) and task-frame error e = Fᵀ (x_d − x): numba scalar
kernels and a validated vectorised API."""

from __future__ import annotations

import math

import numpy as np
from numba import get_num_threads, njit, prange

__all__ = [
    "SEG_ARC",
    "SEG_CUBIC",
    "SEG_LINE",
    "arc_distance",
    "cubic_distance",
    "frame_error",
    "line_distance",
    "nearest_points",
    "path_distance",
    "path_distance_with_index",
    "segment_distance",
    "segment_foot",
    "task_frame_error",
    "true_contour_error",
]

SEG_LINE = 0
SEG_ARC = 1
SEG_CUBIC = 2

TWO_PI = 2.0 * math.pi

# Scalar kernels use error_model="numpy" (no Python exceptions: nothing here can raise) and
# are inlined, so that path_distance ends up with no call and no exception path: only then
# can numba drop the reference counting of its three array arguments, which otherwise costs
# more than the geometry of 1–2 segments. Light kernels that touch arrays are inlined at the
# numba level (_kernel); the long scalar-only ones (helix, cubic) by LLVM (_scalar_kernel),
# which keeps compilation fast.
_kernel = njit(cache=True, fastmath=False, error_model="numpy", inline="always")
_scalar_kernel = njit(cache=True, fastmath=False, error_model="numpy", forceinline=True)

# Batches smaller than this run on one thread: the thread start-up costs more than it saves.
_PARALLEL_MIN = 4096


# ----------------------------------------------------------------------------------------
# line
# ----------------------------------------------------------------------------------------


@_kernel
def _line_nearest(data, px, py, pz):
    # (p0, p1 − p0, q): the nearest point of the segment p0 → p1 in data[0:6] to (px, py, pz)
    # is p0 + q (p1 − p0), q ∈ [0, 1]
    x0 = data[0]
    y0 = data[1]
    z0 = data[2]
    dx = data[3] - x0
    dy = data[4] - y0
    dz = data[5] - z0
    qx = px - x0
    qy = py - y0
    qz = pz - z0
    dd = dx * dx + dy * dy + dz * dz
    q = 0.0
    if dd > 0.0:  # zero-length segment: p0
        q = (qx * dx + qy * dy + qz * dz) / dd
        if q < 0.0:
            q = 0.0
        elif q > 1.0:
            q = 1.0
    return x0, y0, z0, dx, dy, dz, q


@_kernel
def line_distance(data, px, py, pz):
    """Distance (m) from (px, py, pz) to the line segment p0 → p1 in ``data[0:6]``."""
    x0, y0, z0, dx, dy, dz, q = _line_nearest(data, px, py, pz)
    ex = (px - x0) - q * dx
    ey = (py - y0) - q * dy
    ez = (pz - z0) - q * dz
    return math.sqrt(ex * ex + ey * ey + ez * ez)


# ----------------------------------------------------------------------------------------
# arc / helix
# ----------------------------------------------------------------------------------------


@_scalar_kernel
def _helix_f(tau, th0, r, pitch, a, b, h):
    # squared distance from the local point (a, b, h) to the helix point at θ = θ0 + τ
    th = th0 + tau
    ex = r * math.cos(th) - a
    ey = r * math.sin(th) - b
    ez = pitch * tau - h
    return ex * ex + ey * ey + ez * ez


@_scalar_kernel
def _helix_g(tau, th0, r, pitch, a, b, h):
    # ½ d/dτ of _helix_f
    th = th0 + tau
    return r * (a * math.sin(th) - b * math.cos(th)) + pitch * (pitch * tau - h)


@_scalar_kernel
def _helix_root(lo, hi, th0, r, pitch, a, b, h):
    # Root of _helix_g on [lo, hi], where it is increasing with g(lo) ≤ 0 ≤ g(hi):
    # Newton steps, replaced by bisection whenever they leave the shrinking bracket.
    glo = _helix_g(lo, th0, r, pitch, a, b, h)
    if glo >= 0.0:
        return lo
    ghi = _helix_g(hi, th0, r, pitch, a, b, h)
    if ghi <= 0.0:
        return hi
    x = lo - glo * (hi - lo) / (ghi - glo)  # secant start
    tol = 4e-16 * (1.0 + abs(lo) + abs(hi))
    for _ in range(100):
        th = th0 + x
        c = math.cos(th)
        s = math.sin(th)
        gx = r * (a * s - b * c) + pitch * (pitch * x - h)
        if gx == 0.0:
            return x
        if gx < 0.0:
            lo = x
        else:
            hi = x
        dg = r * (a * c + b * s) + pitch * pitch
        xn = 0.5 * (lo + hi)
        if dg > 0.0:
            step = gx / dg
            # converged: test before the bracket check, since a root sitting on a bracket
            # end would otherwise turn every later step into a bisection
            if abs(step) <= tol:
                return x - step
            if lo < x - step < hi:
                xn = x - step
        if hi - lo <= tol:
            return xn
        x = xn
    return x


@_scalar_kernel
def _next_break(x, beta):
    # smallest β + 2πk strictly greater than x
    k = np.floor((x - beta) / TWO_PI) + 1.0
    y = beta + k * TWO_PI
    if y <= x:
        y += TWO_PI
    return y


@_scalar_kernel
def _helix_search(th0, sweep, r, pitch, a, b, h):
    # Exact minimisation of f(τ) = |helix(θ0 + τ) − q|², τ between 0 and sweep, with q = (a, b, h)
    # in the (u, v, w) frame: (the minimum of f, the τ where it is). ½ f'' = r (a cos θ +
    # b sin θ) + pitch² = r ρ cos(θ − φ) + pitch², so f' is monotone between consecutive zeros
    # of f'' (θ − φ = ±acos(−pitch²/(rρ)) + 2πk): on each such piece f has at most one
    # interior minimum, found by a bracketed root search. No sampling, hence no missed minimum
    # however many turns or however steep.
    tlo = min(0.0, sweep)
    thi = max(0.0, sweep)
    # Window: any τ with (pitch τ − h)² > f(τ*) cannot be the minimiser (τ* = nearest height).
    tc = h / pitch
    ts = min(max(tc, tlo), thi)
    best = _helix_f(ts, th0, r, pitch, a, b, h)
    tbest = ts
    half = math.sqrt(best) / abs(pitch)
    half = half * (1.0 + 1e-12) + 1e-15 * (1.0 + abs(tc))
    wlo = max(tlo, tc - half)
    whi = min(thi, tc + half)
    if wlo > whi:  # only through rounding; ts is inside the window
        return best, tbest
    f = _helix_f(wlo, th0, r, pitch, a, b, h)
    if f < best:
        best = f
        tbest = wlo
    f = _helix_f(whi, th0, r, pitch, a, b, h)
    if f < best:
        best = f
        tbest = whi
    rho = math.hypot(a, b)
    p2 = pitch * pitch
    if r * rho <= p2:
        # f'' ≥ 0 everywhere: f is convex, one minimum at most
        if _helix_g(wlo, th0, r, pitch, a, b, h) < 0.0 < _helix_g(whi, th0, r, pitch, a, b, h):
            tr = _helix_root(wlo, whi, th0, r, pitch, a, b, h)
            f = _helix_f(tr, th0, r, pitch, a, b, h)
            if f < best:
                best = f
                tbest = tr
        return best, tbest
    dr2 = (rho - r) * (rho - r)
    phi = math.atan2(b, a)
    alpha = math.acos(-p2 / (r * rho))
    beta1 = phi - th0 - alpha
    beta2 = phi - th0 + alpha
    lo = wlo
    glo = _helix_g(lo, th0, r, pitch, a, b, h)
    while lo < whi:
        hi = min(_next_break(lo, beta1), _next_break(lo, beta2), whi)
        if hi <= lo:  # 2π below the resolution of lo (absurd angles): one last piece
            hi = whi
        ghi = _helix_g(hi, th0, r, pitch, a, b, h)
        if glo <= 0.0 <= ghi and glo < ghi:  # f' rises through zero: a local minimum
            # skip it when f ≥ (ρ − r)² + (pitch τ − h)² already proves it no better
            dz = pitch * min(max(tc, lo), hi) - h
            if dr2 + dz * dz < best:
                tr = _helix_root(lo, hi, th0, r, pitch, a, b, h)
                f = _helix_f(tr, th0, r, pitch, a, b, h)
                if f < best:
                    best = f
                    tbest = tr
        lo = hi
        glo = ghi
    return best, tbest


@_scalar_kernel
def _helix_distance(th0, sweep, r, pitch, a, b, h):
    # distance from (a, b, h) to the helix: the root of _helix_search's minimum
    return math.sqrt(_helix_search(th0, sweep, r, pitch, a, b, h)[0])


@_kernel
def _arc_local(data, px, py, pz):
    # (local coordinates a, b, h of the point in the (u, v, w) frame of the arc, then the
    # arc's radius, start angle θ0, sweep and pitch)
    qx = px - data[0]
    qy = py - data[1]
    qz = pz - data[2]
    a = qx * data[3] + qy * data[4] + qz * data[5]
    b = qx * data[6] + qy * data[7] + qz * data[8]
    h = qx * data[9] + qy * data[10] + qz * data[11]
    return a, b, h, data[12], data[13], data[14], data[15]


@_scalar_kernel
def _within_sweep(a, b, th0, sweep):
    # whether the projection (a, b) lies in the swept angular range: its angle measured from
    # θ0 in the direction of travel, in [0, 2π), at most |sweep| (always for a full circle)
    if abs(sweep) >= TWO_PI:
        return True
    delta = math.atan2(b, a) - th0
    if sweep < 0.0:
        delta = -delta
    delta = delta % TWO_PI
    return delta <= abs(sweep)


@_scalar_kernel
def _arc_end_distances(r, th0, th1, a, b):
    # squared in-plane distances from (a, b) to the arc's end points at θ0 and θ1
    ex = r * math.cos(th0) - a
    ey = r * math.sin(th0) - b
    d0 = ex * ex + ey * ey
    ex = r * math.cos(th1) - a
    ey = r * math.sin(th1) - b
    d1 = ex * ex + ey * ey
    return d0, d1


@_kernel
def arc_distance(data, px, py, pz):
    """Distance (m) from (px, py, pz) to the arc / helix in ``data`` (ARCHITECTURE layout)."""
    a, b, h, r, th0, sweep, pitch = _arc_local(data, px, py, pz)
    if pitch != 0.0:
        return _helix_distance(th0, sweep, r, pitch, a, b, h)
    rho = math.sqrt(a * a + b * b)  # lengths in m: no overflow, cheaper than hypot
    # on the axis all points are equidistant
    if rho == 0.0 or _within_sweep(a, b, th0, sweep):
        dr = rho - r
        return math.sqrt(dr * dr + h * h)
    # outside the swept range: |p(θ) − q|² = r² + ρ² + h² − 2rρ cos(θ − φ) grows with the
    # angular distance, so the nearer end point is the nearest point
    d0, d1 = _arc_end_distances(r, th0, th0 + sweep, a, b)
    return math.sqrt(min(d0, d1) + h * h)


# ----------------------------------------------------------------------------------------
# cubic
# ----------------------------------------------------------------------------------------


@_scalar_kernel
def _q5(c0, c1, c2, c3, c4, c5, x):
    # c0 + c1 x + … + c5 x⁵ (Horner)
    return ((((c5 * x + c4) * x + c3) * x + c2) * x + c1) * x + c0


@_scalar_kernel
def _q5_root(c0, c1, c2, c3, c4, c5, lo, hi, prev):
    # The quintic c is monotone on [lo, hi]. Returns its root there if it has one (a zero at
    # an end counts), else ``prev`` (the previous break point, so that the break sequence
    # built from these results stays sorted; repeated values give empty intervals).
    flo = _q5(c0, c1, c2, c3, c4, c5, lo)
    fhi = _q5(c0, c1, c2, c3, c4, c5, hi)
    if flo == fhi or not ((flo <= 0.0 <= fhi) or (fhi <= 0.0 <= flo)):
        return prev
    if flo == 0.0:
        return lo
    if fhi == 0.0:
        return hi
    sgn = 1.0 if fhi > 0.0 else -1.0  # orient so that the function increases
    x = lo - flo * (hi - lo) / (fhi - flo)  # secant start
    for _ in range(100):
        fx = sgn * _q5(c0, c1, c2, c3, c4, c5, x)
        if fx == 0.0:
            return x
        if fx < 0.0:
            lo = x
        else:
            hi = x
        dfx = sgn * _q5(c1, 2.0 * c2, 3.0 * c3, 4.0 * c4, 5.0 * c5, 0.0, x)
        xn = 0.5 * (lo + hi)  # bisection unless the Newton step stays inside the bracket
        if dfx > 0.0:
            step = fx / dfx
            if abs(step) <= 4e-16:  # converged (tested first: see _helix_root)
                return x - step
            if lo < x - step < hi:
                xn = x - step
        if hi - lo <= 4e-16:
            return xn
        x = xn
    return x


@_scalar_kernel
def _cubic_f(a0x, a0y, a0z, a1x, a1y, a1z, a2x, a2y, a2z, a3x, a3y, a3z, q):
    # |P(q)|²
    ex = a0x + q * (a1x + q * (a2x + q * a3x))
    ey = a0y + q * (a1y + q * (a2y + q * a3y))
    ez = a0z + q * (a1z + q * (a2z + q * a3z))
    return ex * ex + ey * ey + ez * ez


@_kernel
def cubic_distance(data, px, py, pz):
    """Distance (m) from (px, py, pz) to the cubic piece a + b q + c q² + d q³, q ∈ [0, 1]."""
    return _cubic_distance(
        data[0] - px, data[1] - py, data[2] - pz,
        data[3], data[4], data[5], data[6], data[7], data[8], data[9], data[10], data[11],
    )  # fmt: skip


@_scalar_kernel
def _cubic_search(a0x, a0y, a0z, a1x, a1y, a1z, a2x, a2y, a2z, a3x, a3y, a3z):
    # |P(q)|² minimised over q ∈ [0, 1], P(q) = a0 + a1 q + a2 q² + a3 q³ (a0 = a − x):
    # (the minimum, the q where it is).
    # g(q) = ½ d/dq |P(q)|² = P·P' with P = (a − x) + b q + c q² + d q³ is a quintic. All its
    # roots in [0, 1] are isolated by walking down the derivative chain: g⁽⁴⁾ is linear, and
    # between consecutive roots of g⁽ᵏ⁺¹⁾ the polynomial g⁽ᵏ⁾ is monotone, so it has at most
    # one root there (bracketed Newton/bisection). The minimum of |P|² lies at q = 0, q = 1 or
    # a root of g. No sampling, hence no missed local minimum. Scalars only (no allocation):
    # the chain is written out level by level.
    d01 = a0x * a1x + a0y * a1y + a0z * a1z
    d02 = a0x * a2x + a0y * a2y + a0z * a2z
    d03 = a0x * a3x + a0y * a3y + a0z * a3z
    d11 = a1x * a1x + a1y * a1y + a1z * a1z
    d12 = a1x * a2x + a1y * a2y + a1z * a2z
    d13 = a1x * a3x + a1y * a3y + a1z * a3z
    d22 = a2x * a2x + a2y * a2y + a2z * a2z
    d23 = a2x * a3x + a2y * a3y + a2z * a3z
    d33 = a3x * a3x + a3y * a3y + a3z * a3z
    g0 = d01
    g1 = 2.0 * d02 + d11
    g2 = 3.0 * (d03 + d12)
    g3 = 4.0 * d13 + 2.0 * d22
    g4 = 5.0 * d23
    g5 = 3.0 * d33
    # g⁽⁴⁾ = 24 g4 + 120 g5 q: one root at most
    x0 = _q5_root(24.0 * g4, 120.0 * g5, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0)
    # g⁽³⁾ = 6 g3 + 24 g4 q + 60 g5 q²
    h0, h1, h2 = 6.0 * g3, 24.0 * g4, 60.0 * g5
    y0 = _q5_root(h0, h1, h2, 0.0, 0.0, 0.0, 0.0, x0, 0.0)
    y1 = _q5_root(h0, h1, h2, 0.0, 0.0, 0.0, x0, 1.0, y0)
    # g⁽²⁾ = 2 g2 + 6 g3 q + 12 g4 q² + 20 g5 q³
    h0, h1, h2, h3 = 2.0 * g2, 6.0 * g3, 12.0 * g4, 20.0 * g5
    z0 = _q5_root(h0, h1, h2, h3, 0.0, 0.0, 0.0, y0, 0.0)
    z1 = _q5_root(h0, h1, h2, h3, 0.0, 0.0, y0, y1, z0)
    z2 = _q5_root(h0, h1, h2, h3, 0.0, 0.0, y1, 1.0, z1)
    # g⁽¹⁾ = g1 + 2 g2 q + 3 g3 q² + 4 g4 q³ + 5 g5 q⁴
    h0, h1, h2, h3, h4 = g1, 2.0 * g2, 3.0 * g3, 4.0 * g4, 5.0 * g5
    w0 = _q5_root(h0, h1, h2, h3, h4, 0.0, 0.0, z0, 0.0)
    w1 = _q5_root(h0, h1, h2, h3, h4, 0.0, z0, z1, w0)
    w2 = _q5_root(h0, h1, h2, h3, h4, 0.0, z1, z2, w1)
    w3 = _q5_root(h0, h1, h2, h3, h4, 0.0, z2, 1.0, w2)
    # g itself: candidates for the minimum of |P|²
    best = _cubic_f(a0x, a0y, a0z, a1x, a1y, a1z, a2x, a2y, a2z, a3x, a3y, a3z, 0.0)
    qbest = 0.0
    f = _cubic_f(a0x, a0y, a0z, a1x, a1y, a1z, a2x, a2y, a2z, a3x, a3y, a3z, 1.0)
    if f < best:
        best = f
        qbest = 1.0
    lo = 0.0
    for k in range(5):
        if k == 0:
            hi = w0
        elif k == 1:
            hi = w1
        elif k == 2:
            hi = w2
        elif k == 3:
            hi = w3
        else:
            hi = 1.0
        if hi > lo:
            q = _q5_root(g0, g1, g2, g3, g4, g5, lo, hi, -1.0)
            if q >= 0.0:
                f = _cubic_f(a0x, a0y, a0z, a1x, a1y, a1z, a2x, a2y, a2z, a3x, a3y, a3z, q)
                if f < best:
                    best = f
                    qbest = q
            lo = hi
    return best, qbest


@_scalar_kernel
def _cubic_distance(a0x, a0y, a0z, a1x, a1y, a1z, a2x, a2y, a2z, a3x, a3y, a3z):
    # |P(q)| minimised over q ∈ [0, 1] (see _cubic_search)
    best = _cubic_search(a0x, a0y, a0z, a1x, a1y, a1z, a2x, a2y, a2z, a3x, a3y, a3z)[0]
    return math.sqrt(best)


# ----------------------------------------------------------------------------------------
# dispatch and whole path
# ----------------------------------------------------------------------------------------


@_kernel
def segment_distance(seg_type_i, data_row, px, py, pz):
    """Distance (m) from (px, py, pz) to one segment of type ``seg_type_i`` (0, 1 or 2)."""
    if seg_type_i == SEG_LINE:
        return line_distance(data_row, px, py, pz)
    if seg_type_i == SEG_ARC:
        return arc_distance(data_row, px, py, pz)
    if seg_type_i == SEG_CUBIC:
        return cubic_distance(data_row, px, py, pz)
    return np.inf  # unknown type (validated away by the Python API)


@_kernel
def _path_core(seg_type, seg_data, seg_bounds, px, py, pz, start):
    n = seg_type.shape[0]
    best = np.inf
    ibest = -1
    if n == 0:
        return best, ibest
    i = start % n
    if i < 0:
        i += n
    for _ in range(n):
        dx = px - seg_bounds[i, 0]
        dy = py - seg_bounds[i, 1]
        dz = pz - seg_bounds[i, 2]
        # exact lower bound of the distance to any point of the segment
        if math.sqrt(dx * dx + dy * dy + dz * dz) - seg_bounds[i, 3] < best:
            d = segment_distance(seg_type[i], seg_data[i], px, py, pz)
            if d < best:
                best = d
                ibest = i
        i += 1
        if i == n:
            i = 0
    return best, ibest


# The two public whole-path kernels are ordinary (not force-inlined) functions, each with
# its own inlined copy of _path_core: callers get a compact call, and the kernels themselves
# contain no calls, hence no reference counting.


@njit(cache=True, fastmath=False, error_model="numpy")
def path_distance_with_index(seg_type, seg_data, seg_bounds, px, py, pz, start=0):
    """(distance in m, index of the nearest segment) from (px, py, pz) to the whole path.

    Segments are visited cyclically from ``start`` (pass the previous nearest index to
    find a good bound at once); a segment is skipped when its bounding sphere proves it
    cannot be nearer: |x − centre| − radius ≥ best. Returns (inf, -1) for an empty path.
    """
    return _path_core(seg_type, seg_data, seg_bounds, px, py, pz, start)


@njit(cache=True, fastmath=False, error_model="numpy")
def path_distance(seg_type, seg_data, seg_bounds, px, py, pz):
    """True contour error (m): shortest distance from (px, py, pz) to the whole path.

    Unsigned (≥ 0), to the nearest point of any segment (not to the reference point);
    ``seg_*`` are the packed arrays of docs/ARCHITECTURE.md. inf for an empty path.
    """
    return _path_core(seg_type, seg_data, seg_bounds, px, py, pz, 0)[0]


@_kernel
def frame_error(frame, rx, ry, rz, px, py, pz):
    """Task-frame error e = Fᵀ (x_d − x) for one point: (e_t, e_n, e_b), m.

    ``frame`` (3, 3) has columns [t n b]; (rx, ry, rz) is the reference x_d, (px, py, pz)
    the actual position x. For a planar path pass z = 0 for both; then e_b = 0 when the
    frame's t and n lie in the plane.
    """
    ex = rx - px
    ey = ry - py
    ez = rz - pz
    et = frame[0, 0] * ex + frame[1, 0] * ey + frame[2, 0] * ez
    en = frame[0, 1] * ex + frame[1, 1] * ey + frame[2, 1] * ez
    eb = frame[0, 2] * ex + frame[1, 2] * ey + frame[2, 2] * ez
    return et, en, eb


# ----------------------------------------------------------------------------------------
# batched kernels
# ----------------------------------------------------------------------------------------


@njit(cache=True, fastmath=False, error_model="numpy")
def _distance_range(seg_type, seg_data, seg_bounds, pts, out, i0, i1):
    # consecutive points are usually near the same segment: start from the last nearest one
    # (a call, not an inlined copy: the batch API is not that hot, and it saves compile time)
    hint = 0
    for i in range(i0, i1):
        d, k = path_distance_with_index(
            seg_type, seg_data, seg_bounds, pts[i, 0], pts[i, 1], pts[i, 2], hint
        )
        out[i] = d
        if k >= 0:
            hint = k


@njit(cache=True, fastmath=False, error_model="numpy")
def _distance_batch(seg_type, seg_data, seg_bounds, pts, out):
    _distance_range(seg_type, seg_data, seg_bounds, pts, out, 0, pts.shape[0])


@njit(cache=True, fastmath=False, parallel=True)
def _distance_batch_parallel(seg_type, seg_data, seg_bounds, pts, out, n_chunks):
    n = pts.shape[0]
    for c in prange(n_chunks):
        i0 = c * n // n_chunks
        i1 = (c + 1) * n // n_chunks
        _distance_range(seg_type, seg_data, seg_bounds, pts, out, i0, i1)


# ----------------------------------------------------------------------------------------
# nearest point (foot point) on the path
# ----------------------------------------------------------------------------------------
# The same minimisations as the distance kernels above, returning where the minimum is: the
# foot point f of x on the path, with |x − f| equal to the true contour error. The searches
# are shared (_helix_search, _cubic_search); the distance kernels, which run every servo
# step, inline them and use only the minimum, so the bookkeeping of where it is compiles away.


@_scalar_kernel
def _helix_argmin(th0, sweep, r, pitch, a, b, h):
    # τ of the minimum of _helix_f over τ between 0 and sweep
    return _helix_search(th0, sweep, r, pitch, a, b, h)[1]


@njit(cache=True, fastmath=False, error_model="numpy")
def _arc_foot_angle(data, px, py, pz):
    # (θ of the nearest arc point, its height τ·pitch along w)
    a, b, h, r, th0, sweep, pitch = _arc_local(data, px, py, pz)
    if pitch != 0.0:
        tau = _helix_argmin(th0, sweep, r, pitch, a, b, h)
        return th0 + tau, pitch * tau
    rho = math.sqrt(a * a + b * b)
    if rho == 0.0:  # on the axis: every point is nearest; take the start
        return th0, 0.0
    if _within_sweep(a, b, th0, sweep):
        return math.atan2(b, a), 0.0
    th1 = th0 + sweep
    d0, d1 = _arc_end_distances(r, th0, th1, a, b)
    return (th0, 0.0) if d0 <= d1 else (th1, 0.0)


@_scalar_kernel
def _cubic_argmin(a0x, a0y, a0z, a1x, a1y, a1z, a2x, a2y, a2z, a3x, a3y, a3z):
    # q of the minimum of |P(q)|² on [0, 1]
    return _cubic_search(a0x, a0y, a0z, a1x, a1y, a1z, a2x, a2y, a2z, a3x, a3y, a3z)[1]


@njit(cache=True, fastmath=False, error_model="numpy")
def segment_foot(seg_type_i, data, px, py, pz):
    """Nearest point (fx, fy, fz) of one segment of type ``seg_type_i`` to (px, py, pz), m:
    where :func:`segment_distance` finds its minimum."""
    if seg_type_i == SEG_LINE:
        x0, y0, z0, dx, dy, dz, q = _line_nearest(data, px, py, pz)
        return x0 + q * dx, y0 + q * dy, z0 + q * dz
    if seg_type_i == SEG_ARC:
        th, rise = _arc_foot_angle(data, px, py, pz)
        c = data[12] * math.cos(th)
        s = data[12] * math.sin(th)
        return (
            data[0] + c * data[3] + s * data[6] + rise * data[9],
            data[1] + c * data[4] + s * data[7] + rise * data[10],
            data[2] + c * data[5] + s * data[8] + rise * data[11],
        )
    q = _cubic_argmin(
        data[0] - px, data[1] - py, data[2] - pz,
        data[3], data[4], data[5], data[6], data[7], data[8], data[9], data[10], data[11],
    )  # fmt: skip
    return (
        data[0] + q * (data[3] + q * (data[6] + q * data[9])),
        data[1] + q * (data[4] + q * (data[7] + q * data[10])),
        data[2] + q * (data[5] + q * (data[8] + q * data[11])),
    )


@njit(cache=True, fastmath=False, error_model="numpy")
def _foot_batch(seg_type, seg_data, seg_bounds, pts, out):
    hint = 0
    for i in range(pts.shape[0]):
        _, k = path_distance_with_index(
            seg_type, seg_data, seg_bounds, pts[i, 0], pts[i, 1], pts[i, 2], hint
        )
        if k < 0:
            k = 0
        hint = k
        fx, fy, fz = segment_foot(seg_type[k], seg_data[k], pts[i, 0], pts[i, 1], pts[i, 2])
        out[i, 0] = fx
        out[i, 1] = fy
        out[i, 2] = fz


# ----------------------------------------------------------------------------------------
# Python API
# ----------------------------------------------------------------------------------------


def _as_float_array(x, name):
    try:
        arr = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a real numeric array ({exc})") from None
    return arr


def _check_finite(arr, name):
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN or infinite values")


def _validate_table(seg_type, seg_data, seg_bounds):
    st = np.asarray(seg_type)
    if st.ndim != 1 or st.shape[0] == 0:
        raise ValueError(f"seg_type must be a non-empty 1-D array, got shape {st.shape}")
    if not (np.issubdtype(st.dtype, np.integer) or np.issubdtype(st.dtype, np.floating)):
        raise ValueError(f"seg_type must hold integers, got dtype {st.dtype}")
    if np.issubdtype(st.dtype, np.floating) and not np.all(st == np.round(st)):
        raise ValueError("seg_type must hold integers 0 (line), 1 (arc/helix), 2 (cubic)")
    st = np.ascontiguousarray(st, dtype=np.int64)
    if np.any((st < SEG_LINE) | (st > SEG_CUBIC)):
        raise ValueError("seg_type values must be 0 (line), 1 (arc/helix) or 2 (cubic)")
    n = st.shape[0]
    sd = np.ascontiguousarray(_as_float_array(seg_data, "seg_data"))
    if sd.shape != (n, 16):
        raise ValueError(f"seg_data must have shape ({n}, 16), got {sd.shape}")
    _check_finite(sd, "seg_data")
    sb = np.ascontiguousarray(_as_float_array(seg_bounds, "seg_bounds"))
    if sb.shape != (n, 4):
        raise ValueError(f"seg_bounds must have shape ({n}, 4), got {sb.shape}")
    _check_finite(sb, "seg_bounds")
    if np.any(sb[:, 3] < 0.0):
        raise ValueError("seg_bounds radii (column 3) must be ≥ 0")
    return st, sd, sb


def _points_2d(points):
    """(``points`` as a finite float (n, 2) or (n, 3) array, whether it was a single point)."""
    pts = _as_float_array(points, "points")
    single = pts.ndim == 1
    if single:
        pts = pts[None, :]
    if pts.ndim != 2 or pts.shape[1] not in (2, 3):
        raise ValueError(
            f"points must have shape (n, 2), (n, 3), (2,) or (3,), got {np.shape(points)}"
        )
    _check_finite(pts, "points")
    return pts, single


def _is_path(obj):
    return all(hasattr(obj, a) for a in ("seg_type", "seg_data", "seg_bounds"))


def true_contour_error(path_or_seg_type, seg_data=None, seg_bounds=None, points=None):
    """True contour error (m): shortest distance from each point to the whole path.

    Two call forms::

        true_contour_error(seg_type, seg_data, seg_bounds, points)
        true_contour_error(path, points)   # path: any object with seg_type, seg_data,
                                           # seg_bounds attributes (e.g. PathGeometry)

    ``points`` is ``(n, 2)`` or ``(n, 3)`` (2-D points get z = 0) → ndarray ``(n,)``, or a
    single point ``(2,)`` / ``(3,)`` → float. The distance is unsigned (≥ 0) and measured to
    the nearest point of any segment, not to the current reference point.
    """
    if _is_path(path_or_seg_type):
        if seg_bounds is not None or (seg_data is not None and points is not None):
            raise ValueError("true_contour_error(path, points) takes exactly one more argument")
        pts_in = points if seg_data is None else seg_data
        p = path_or_seg_type
        st, sd, sb = p.seg_type, p.seg_data, p.seg_bounds
    else:
        if seg_data is None or seg_bounds is None or points is None:
            raise ValueError(
                "true_contour_error needs (seg_type, seg_data, seg_bounds, points) or "
                "(path, points) with a path having seg_type/seg_data/seg_bounds"
            )
        pts_in = points
        st, sd, sb = path_or_seg_type, seg_data, seg_bounds
    if pts_in is None:
        raise ValueError("points is missing")
    st, sd, sb = _validate_table(st, sd, sb)

    pts, single = _points_2d(pts_in)
    if pts.shape[1] == 2:
        pts3 = np.zeros((pts.shape[0], 3))
        pts3[:, :2] = pts
    else:
        pts3 = np.ascontiguousarray(pts)
    out = np.empty(pts3.shape[0])
    n = pts3.shape[0]
    if n >= _PARALLEL_MIN and get_num_threads() > 1:
        n_chunks = min(n // 256, 8 * get_num_threads())
        _distance_batch_parallel(st, sd, sb, pts3, out, n_chunks)
    else:
        _distance_batch(st, sd, sb, pts3, out)
    return float(out[0]) if single else out


def task_frame_error(frame, reference, position):
    """Task-frame error e = Fᵀ (x_d − x) (Lee 2012, eq. 19 with eqs. 2–3), m.

    ``frame`` ``(n, 3, 3)`` has columns [t n b] (unit tangent, normal, binormal) at the
    reference points; ``reference`` x_d and ``position`` x are ``(n, d)`` with d = 2 or 3.
    Returns ``(n, d)``: (tangential, normal[, binormal]) components. For d = 2 the top-left
    2×2 block of the frame is used (t and n in the plane). Unbatched inputs ``(3, 3)``,
    ``(d,)`` give ``(d,)``. Sign: e_t > 0 when x lags behind x_d along t; e_n > 0 when x is
    offset from x_d opposite to n (outside a CCW circle whose n points to the centre).
    """
    F = _as_float_array(frame, "frame")
    xd = _as_float_array(reference, "reference")
    x = _as_float_array(position, "position")
    single = F.ndim == 2
    if single:
        F = F[None]
    if F.ndim != 3 or F.shape[1:] != (3, 3):
        raise ValueError(f"frame must have shape (n, 3, 3) or (3, 3), got {np.shape(frame)}")
    n = F.shape[0]
    if single:
        xd = xd[None] if xd.ndim == 1 else xd
        x = x[None] if x.ndim == 1 else x
    if xd.ndim != 2 or xd.shape[0] != n or xd.shape[1] not in (2, 3):
        shp = "(2,) or (3,)" if single else f"({n}, 2) or ({n}, 3)"
        raise ValueError(f"reference must have shape {shp}, got {np.shape(reference)}")
    if x.shape != xd.shape:
        raise ValueError(
            f"position must have the same shape as reference {np.shape(reference)}, "
            f"got {np.shape(position)}"
        )
    _check_finite(F, "frame")
    _check_finite(xd, "reference")
    _check_finite(x, "position")
    d = xd.shape[1]
    # e_j = Σ_i F[i, j] (x_d − x)_i
    e = np.einsum("kij,ki->kj", F[:, :d, :d], xd - x)
    return e[0] if single else e


def nearest_points(path, points):
    """Nearest point of the whole path (the foot point) to each point, m.

    ``path``: any object with ``seg_type``, ``seg_data``, ``seg_bounds`` (e.g. PathGeometry);
    ``points`` ``(n, d)`` or ``(d,)`` with d = 2 (z = 0) or 3. Returns the same shape as
    ``points`` (the foot's first d coordinates; for d = 2 the path is meant to lie in z = 0).
    The foot lies on the segment :func:`true_contour_error` finds nearest, where that
    segment's distance is smallest, so |point − foot| is the true contour error (to rounding)
    and point − foot is the contour-error vector. Where several points of the path are
    equally near (the centre of a circle), one of them.
    """
    if not _is_path(path):
        raise ValueError("nearest_points: path must have seg_type, seg_data, seg_bounds")
    st, sd, sb = _validate_table(path.seg_type, path.seg_data, path.seg_bounds)
    pts, single = _points_2d(points)
    d = pts.shape[1]
    pts3 = np.zeros((pts.shape[0], 3))
    pts3[:, :d] = pts
    out = np.empty_like(pts3)
    _foot_batch(st, sd, sb, pts3, out)
    return out[0, :d] if single else out[:, :d]
