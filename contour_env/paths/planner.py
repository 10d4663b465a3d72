"""Look-ahead feed planner: junction speeds from grbl's junction-deviation model, backward and
forward passes over the whole program, and jerk-bounded cosine transitions v0 → v1 between them.

Used by `contour_env.paths.feed.FeedProfile.build` when ``segment_blend_m`` or
``segment_dwell_s`` is given (docs/FEED_PLANNER.md). Units: m, s, m/s, m/s², m/s³, rad.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .geometry import PathGeometry

# Relative margin on a block's length in the look-ahead passes, so that round-off in the
# closed-form reachable speed never asks a block for more distance than it has (m / m).
_LENGTH_MARGIN = 1e-10
_BISECT_ITERS = 64


class Block(NamedTuple):
    """One stretch between junctions (or the path's ends): arc lengths ``s_start``, ``s_end``
    (m); speeds ``v_in`` at its start, ``peak_feed`` (the cruise speed), ``v_out`` at its end
    (m/s); ``t_start`` and ``t_end`` (s) of its motion; ``dwell_s`` (s) at rest after it."""

    s_start: float
    s_end: float
    v_in: float
    peak_feed: float
    v_out: float
    t_start: float
    t_end: float
    dwell_s: float


# planned-table columns (one row per block)
T0, S0, S1, VIN, VP, VOUT, TA1, TC, TA2, TMOVE, TEND = range(11)


def transition_time(dv, a_max: float, j_max: float):
    """Ta (s) of a cosine transition changing the speed by |dv| (m/s):
    max(π |dv| / (2 a_max), π sqrt(|dv| / (2 j_max))); peak |s̈| = a_max or |s⃛| = j_max."""
    dv = np.abs(dv)
    return np.maximum(math.pi * dv / (2 * a_max), math.pi * np.sqrt(dv / (2 * j_max)))


def transition_distance(v0, v1, a_max: float, j_max: float):
    """Distance (m) covered by the cosine transition v0 → v1 (m/s): (v0 + v1) Ta / 2."""
    return (
        0.5
        * (np.asarray(v0) + np.asarray(v1))
        * transition_time(np.asarray(v1) - np.asarray(v0), a_max, j_max)
    )


def reach_speed(v0: float, length: float, a_max: float, j_max: float) -> float:
    """Largest v ≥ v0 (m/s) whose transition v0 → v (or v → v0) fits in ``length`` m.

    D(v) = (v0 + v) Ta(v − v0) / 2 with Ta the larger of two branches, so D ≤ L on both:
    acceleration branch v = sqrt(v0² + 4 a L / π); jerk branch v = v0 + x² with x the real root
    of x³ + 2 v0 x = 2 sqrt(2 j) L / π (hyperbolic Cardano, one Newton polish).
    """
    if not length > 0:
        return v0
    va = math.sqrt(v0 * v0 + 4 * a_max * length / math.pi)
    c = 2 * math.sqrt(2 * j_max) * length / math.pi
    p = 2 * v0
    x = None
    if p > 0:
        z = 1.5 * c / p * math.sqrt(3 / p)
        if math.isfinite(z):
            x = 2 * math.sqrt(p / 3) * math.sinh(math.asinh(z) / 3)
    if x is None or not (math.isfinite(x) and x > 0):
        x = c ** (1 / 3)
    x -= (x * x * x + p * x - c) / (3 * x * x + p)
    v = min(va, v0 + x * x)
    # v − v0 rounds (badly when it is tiny next to v0): shrink until the distance computed as
    # the planner will compute it, from the rounded difference, fits
    dv0 = v - v0
    for i in range(52):
        dv = v - v0
        ta = max(math.pi * dv / (2 * a_max), math.pi * math.sqrt(dv / (2 * j_max)))
        if 0.5 * (v0 + v) * ta <= length:
            return v
        v = v0 + dv0 * (1.0 - 2.0 ** (i - 51))
    return v0


def junction_speed(theta, blend_m, a_max: float, j_max: float):
    """Corner speed (m/s) for a tangent jump ``theta`` (rad) within deviation ``blend_m`` (m).

    grbl: the corner is replaced by the circular arc tangent to both moves whose closest point
    is ``blend_m`` from the corner, radius R = δ sin(φ/2) / (1 − sin(φ/2)) with φ = π − θ the
    angle between the reversed incoming and the outgoing tangent, and passed at the speed whose
    centripetal acceleration is a_max: v = sqrt(a_max R). We also bound the jerk of uniform
    motion on that arc, v³ / R² ≤ j_max: v = min(sqrt(a_max R), (j_max R²)^(1/3)).
    sin(φ/2) = cos(θ/2) and 1 − cos(θ/2) = 2 sin²(θ/4) (no cancellation for small θ).
    """
    theta = np.asarray(theta, dtype=np.float64)
    delta = np.asarray(blend_m, dtype=np.float64)
    sin_half_phi = np.cos(0.5 * theta)
    one_minus = 2.0 * np.sin(0.25 * theta) ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        radius = np.where(one_minus > 0, delta * sin_half_phi / one_minus, np.inf)
    radius = np.maximum(radius, 0.0)
    return np.minimum(np.sqrt(a_max * radius), np.cbrt(j_max * radius * radius))


def junction_angles(path: PathGeometry) -> np.ndarray:
    """Tangent jump (rad, in [0, π]) at each interior junction k (end of segment k), (n − 1,)."""
    t_end, t_start = path._junction_tangents()
    a, b = t_end[:-1], t_start[1:]
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.sum(a * b, axis=1))


def _per_segment(name: str, values, n: int, what: str) -> np.ndarray:
    allowed = f"one finite number ≥ 0 {what} per segment ({n} values)"
    if isinstance(values, (str, bytes)):
        raise ValueError(f"{name}: expected {allowed}, got {values!r}")
    try:
        arr = np.asarray(values, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected {allowed}, got {values!r}") from None
    if arr.shape != (n,):
        raise ValueError(f"{name}: expected {allowed}, got {arr.shape[0]} values")
    bad = np.nonzero(~(np.isfinite(arr) & (arr >= 0)))[0]
    if bad.size:
        k = int(bad[0])
        raise ValueError(f"{name}: expected {allowed}, got {arr[k]!r} at segment {k}")
    return arr


def plan(
    path: PathGeometry,
    seg_feed: np.ndarray,
    a_max: float,
    j_max: float,
    corner_tol_rad: float,
    blend_m,
    dwell_s,
    start_dwell_s: float = 0.0,
) -> np.ndarray:
    """The planned table (one row per block; columns T0 … TEND above).

    ``start_dwell_s`` (s, ≥ 0): a pause at rest on the start point before the first block (a
    G04 before the first move); every time in the table is later by that much.

    ``seg_feed`` (n,) m/s; ``blend_m`` (n,) m or None (then every corner sharper than
    ``corner_tol_rad`` is an exact stop); ``dwell_s`` (n,) s or None. A junction is an
    interior joint k with a corner (θ > tol), a feed change or a dwell; except a G64 corner
    (δ > 0, same feed on both sides, no dwell) whose `junction_speed` is at least the feed,
    which constrains nothing. Its speed cap: 0 for a dwell, for δ = 0 (G61) and, with
    ``blend_m`` None, for every junction; else the smaller feed of the two sides, and at a
    corner also `junction_speed`.
    """
    jk, cap, dw = _junctions(path, seg_feed, a_max, j_max, corner_tol_rad, blend_m, dwell_s)
    m = jk.size + 1
    # a junction's arc length is the next segment's start (where segment_index puts it)
    s_bound = np.concatenate([[0.0], path.seg_s0[jk + 1], [path.total_length]])
    length = np.maximum(np.diff(s_bound), 0.0)
    first_seg = np.concatenate([[0], jk + 1])
    feed = seg_feed[first_seg]
    v = np.concatenate([[0.0], cap[jk], [0.0]])
    dwell = np.zeros(m)
    dwell[:-1] = dw[jk]
    if dwell_s is not None:
        dwell[-1] = dwell_s[-1]
    v = _look_ahead(v, length, a_max, j_max)
    v_in, v_out = v[:-1], v[1:]
    vp = _peak_feeds(feed, v_in, v_out, length, a_max, j_max)
    ta1 = transition_time(vp - v_in, a_max, j_max)
    ta2 = transition_time(vp - v_out, a_max, j_max)
    d1 = 0.5 * (v_in + vp) * ta1
    d2 = 0.5 * (vp + v_out) * ta2
    with np.errstate(divide="ignore", invalid="ignore"):
        tc = np.where(vp > 0, (length - d1 - d2) / vp, 0.0)
    tc = np.maximum(tc, 0.0)
    move = ta1 + tc + ta2
    t0 = start_dwell_s + np.concatenate([[0.0], np.cumsum(move + dwell)[:-1]])
    tab = np.empty((m, 11))
    tab[:, T0] = t0
    tab[:, S0] = s_bound[:-1]
    tab[:, S1] = s_bound[1:]
    tab[:, VIN] = v_in
    tab[:, VP] = vp
    tab[:, VOUT] = v_out
    tab[:, TA1] = ta1
    tab[:, TC] = tc
    tab[:, TA2] = ta2
    tab[:, TMOVE] = t0 + move
    tab[:, TEND] = t0 + move + dwell
    return tab


def _junctions(path, seg_feed, a_max, j_max, corner_tol_rad, blend_m, dwell_s) -> tuple:
    """(the interior joints k that are junctions, the speed cap (m/s) and the dwell (s) at
    every interior joint) — the rules of `plan`."""
    n = path.n_segments
    if n <= 1:
        return np.zeros(0, dtype=np.int64), np.zeros(0), np.zeros(0)
    theta = junction_angles(path)
    corner = theta > corner_tol_rad
    f_l, f_r = seg_feed[:-1], seg_feed[1:]
    change = f_l != f_r
    dw = dwell_s[:-1] if dwell_s is not None else np.zeros(n - 1)
    cap = np.minimum(f_l, f_r)
    if blend_m is None:
        cap = np.where(corner | change, 0.0, cap)
        is_j = corner | change | (dw > 0)
    else:
        delta = blend_m[:-1]
        v_corner = junction_speed(theta, delta, a_max, j_max)
        cap = np.where(corner, np.minimum(cap, v_corner), cap)
        cap = np.where(delta == 0.0, 0.0, cap)
        # a G64 corner that allows at least the (same) feed on both sides constrains
        # nothing: not a junction, so that ramps and cruises run through it (a finely
        # tessellated curve is one block)
        transparent = corner & ~change & (delta > 0) & (v_corner >= f_l)
        is_j = (corner & ~transparent) | change | (dw > 0)
    cap = np.where(dw > 0, 0.0, cap)
    return np.nonzero(is_j)[0], cap, dw


def _look_ahead(v: np.ndarray, length: np.ndarray, a_max: float, j_max: float) -> np.ndarray:
    """The block-boundary speeds ``v`` (m + 1,) lowered so that every block's transition
    fits its ``length`` (m,)."""
    # backward (each junction ≤ what the rest can still brake from), then forward (≤ what can
    # be reached from the previous one); D(v0, v1) is symmetric, so both passes together give
    # |transition| ≤ block length on every block
    m = length.size
    eff = (length * (1.0 - _LENGTH_MARGIN)).tolist()
    vl = v.tolist()
    for b in range(m - 1, -1, -1):
        if vl[b] > vl[b + 1]:
            r = reach_speed(vl[b + 1], eff[b], a_max, j_max)
            if r < vl[b]:
                vl[b] = r
    for b in range(m):
        if vl[b + 1] > vl[b]:
            r = reach_speed(vl[b], eff[b], a_max, j_max)
            if r < vl[b + 1]:
                vl[b + 1] = r
    return np.array(vl)


def _peak_feeds(feed, v_in, v_out, length, a_max: float, j_max: float) -> np.ndarray:
    """Peak per block: the feed if both transitions fit, else the largest vp whose two do
    (bisection on [max(v_in, v_out), F]; D(v_in, v_out) ≤ L after the look-ahead)."""

    def needed(a, vp, b):
        return transition_distance(a, vp, a_max, j_max) + transition_distance(vp, b, a_max, j_max)

    vp = feed.copy()
    short = needed(v_in, vp, v_out) > length
    if np.any(short):
        idx = np.nonzero(short)[0]
        vi, vo = v_in[idx], v_out[idx]
        lo = np.maximum(vi, vo)
        hi = feed[idx].copy()
        target = length[idx]
        for _ in range(_BISECT_ITERS):
            mid = 0.5 * (lo + hi)
            ok = needed(vi, mid, vo) <= target
            lo = np.where(ok, mid, lo)
            hi = np.where(ok, hi, mid)
        vp[idx] = lo
    return vp


def blocks(tab: np.ndarray) -> tuple:
    """The table's rows as `Block` tuples."""
    return tuple(
        Block(
            float(r[S0]),
            float(r[S1]),
            float(r[VIN]),
            float(r[VP]),
            float(r[VOUT]),
            float(r[T0]),
            float(r[TMOVE]),
            float(r[TEND] - r[TMOVE]),
        )
        for r in tab
    )


def sample(tab: np.ndarray, total_length: float, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(s m, ṡ m/s, s̈ m/s²) at times t (s), closed form per phase (vectorised; the sines and
    cosines only where a sample is in a transition)."""
    t = np.atleast_1d(np.asarray(t, dtype=np.float64)).reshape(-1)
    k = np.searchsorted(tab[:, T0], t, side="right") - 1
    np.clip(k, 0, len(tab) - 1, out=k)
    tau = t - tab[k, T0]
    np.maximum(tau, 0.0, out=tau)
    ta1 = tab[k, TA1]
    up = tau < ta1
    dn = tau >= ta1 + tab[k, TC]
    ended = t >= tab[k, TMOVE]
    s = np.empty_like(t)
    v = np.empty_like(t)
    a = np.zeros_like(t)
    # cruising at vp
    i = np.nonzero(~(up | dn | ended))[0]
    if i.size:
        ki = k[i]
        vp, ta = tab[ki, VP], tab[ki, TA1]
        s[i] = tab[ki, S0] + 0.5 * (tab[ki, VIN] + vp) * ta + vp * (tau[i] - ta)
        v[i] = vp
    # accelerating v_in → vp, measured from the block start
    i = np.nonzero(up & ~ended)[0]
    if i.size:
        ki = k[i]
        vi, dv, ta, tu = tab[ki, VIN], tab[ki, VP] - tab[ki, VIN], ta1[i], tau[i]
        w = math.pi / ta
        wt = w * tu
        s[i] = tab[ki, S0] + vi * tu + 0.5 * dv * (tu - np.sin(wt) / w)
        v[i] = vi + 0.5 * dv * (1 - np.cos(wt))
        a[i] = 0.5 * dv * w * np.sin(wt)
    # decelerating vp → v_out, measured back from the block end: r = time left ∈ [0, Ta2]
    i = np.nonzero(dn & ~up & ~ended)[0]
    if i.size:
        ki = k[i]
        vo, ta2 = tab[ki, VOUT], tab[ki, TA2]
        dv = tab[ki, VP] - vo
        r = np.clip(ta1[i] + tab[ki, TC] + ta2 - tau[i], 0.0, ta2)
        w = math.pi / np.where(ta2 > 0, ta2, 1.0)
        wr = w * r
        s[i] = tab[ki, S1] - (vo * r + 0.5 * dv * (r - np.sin(wr) / w))
        v[i] = vo + 0.5 * dv * (1 - np.cos(wr))
        a[i] = -0.5 * dv * w * np.sin(wr)
    # at the block end (and through its dwell): exactly s1 at v_out
    i = np.nonzero(ended)[0]
    if i.size:
        s[i] = tab[k[i], S1]
        v[i] = tab[k[i], VOUT]
    before = t < 0.0
    s[before], v[before], a[before] = 0.0, 0.0, 0.0
    np.clip(s, 0.0, total_length, out=s)
    return s, v, a
