"""Compiled (numba) plant step shared by the single and the vectorised environment.

One call advances a batch of n-axis feed drives by one servo period T:

- the linear part of each axis exactly (matrix exponential, zero-order hold on u);
- friction, force ripple and disturbance as a force w on the moving mass, integrated with a
  first-order-hold predictor–corrector (second order) over the period;
- near a velocity reversal (or while stuck) the period is split into substeps with a
  stick–slip treatment: the mass sticks when the non-friction force it feels is within the
  static friction (no chattering, no energy gain); it breaks away when it exceeds it. The
  smooth stretches of such a period (holding, sliding without reversal) are crossed in chunks
  of substeps up to a predicted event, and an event found by bisection to the substep (see
  MAX_CHUNK).

Packed per-(env, axis) arrays (built by :class:`contour_env.plants.model.Plant`):

- ``mat_T``: (P, A, ns, ns + 3) = [Phi | Gu | Ga | Gb] over T;
- ``mat_h``: (P · L, A, ns, ns + 3), the same over the substep lengths T / n_sub, T / 2,
  T / 3, T / 4 and the chunks of c = 2, 3, …, min(n_sub, MAX_CHUNK) fine substeps, c · T / n_sub
  (L = n_sub_levels(n_sub) rows per parameter set, row p · L + level; see SUB_LEVEL_DIVISORS,
  MAX_CHUNK and sub_level_lengths);
- ``cont``: (P, A, ns + 2) = row 1 of the continuous A, then B_u[1], B_w[1];
- ``nl``: (P, A, NL_SIZE) nonlinear parameters, indices below;

with P parameter sets (1 for a batch of identical envs: the arrays stay in L1 cache) and an
int64 map ``pidx`` (B,) from env to parameter set.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

# indices into the nonlinear-parameter vector ``nl``; NL_KR (2π / ripple period, rad/m),
# NL_WD (2π · disturbance frequency, rad/s) and NL_INV_RES (1 / encoder resolution, 0 for an
# exact encoder) are derived once when the parameters are packed, so the step multiplies
# instead of dividing
(
    NL_FC,
    NL_FS,
    NL_VS,
    NL_AR,
    NL_PR,
    NL_AD,
    NL_FD,
    NL_PHASE,
    NL_FMAX,
    NL_RES,
    NL_MASS,
    NL_KR,
    NL_WD,
    NL_INV_RES,
) = range(14)
NL_SIZE = 14

# largest deviation of friction from its first-order hold over one period (fraction of the
# static friction) for which the whole-period step is kept in the Stribeck region
FOH_FRICTION_TOL = 1e-3
# substep lengths with discretised matrices. Levels 0–3: T / d for d in SUB_LEVEL_DIVISORS
# (level 0: the plant's friction_substeps, the fine substeps h = T / n_sub of velocity
# reversals, sticking and break-away). A period in the Stribeck band whose first-order-hold
# deviation is q · FOH_FRICTION_TOL with q <= d² is split into d equal substeps instead of the
# fine ones: the deviation falls with the square of the step.
SUB_LEVEL_DIVISORS = (0, 2, 3, 4)
# Levels 4…: chunks of c = 2 … max_chunk(n_sub) fine substeps (c · h), every length. Inside a
# period that needs the fine grid, the stretches before and after an event (break-away,
# sticking, a reversal) are smooth: they are crossed in chunks, accepted under the same tests
# as a whole period (no sign change, first-order-hold deviation within FOH_FRICTION_TOL; while
# stuck, the non-friction force within f_s at both ends), and the event itself is found by
# bisection down to the fine substep, where the fine treatment is unchanged. A chunk runs to
# the predicted event (a break-away: where the non-friction force, through its values at the
# start, middle and end of the held period, reaches f_s), half-way to a suspected one (a chunk
# that failed on a sign change), or to the end of the period; while sliding it is no longer
# than the first-order hold allows: after a chunk of c substeps whose deviation was
# q · FOH_FRICTION_TOL, at most CAP_SAFETY · c / √q (the deviation grows with the square of the
# length) and at most 2 c.
CHUNK_LEVEL0 = len(SUB_LEVEL_DIVISORS)  # level of a chunk of 2 substeps; c substeps: c + 2
MAX_CHUNK = 32
# chunk length after a first-order-hold failure: this fraction of the length it predicts
CAP_SAFETY = 0.8


def max_chunk(n_sub: int) -> int:
    """Longest chunk of fine substeps with its own matrices: min(n_sub, MAX_CHUNK)."""
    return min(n_sub, MAX_CHUNK)


def n_sub_levels(n_sub: int) -> int:
    """Levels of ``mat_h`` per parameter set: the four T / d, chunks of 2 … max_chunk."""
    return CHUNK_LEVEL0 + max(0, max_chunk(n_sub) - 1)


def sub_level_lengths(T: float, n_sub: int) -> list[float]:
    """Substep length (s) of every level of ``mat_h``, in level order."""
    fixed = [T / (d if d else n_sub) for d in SUB_LEVEL_DIVISORS]
    return fixed + [c * T / n_sub for c in range(2, max_chunk(n_sub) + 1)]


@njit(cache=True, inline="always")
def friction_force(v, fc, fs, vs):
    """Stribeck friction (f_c + (f_s − f_c) e^{−(v/v_s)²}) sgn(v), N; zero at v = 0."""
    if v == 0.0 or fs == 0.0:
        return 0.0
    mag = fc
    # Beyond 6 v_s the Stribeck term is below 3e-16 of (f_s − f_c): skip the division and the
    # exponential. The one-trip loop (instead of an if) stops LLVM from speculating the exp
    # call on every path, which made the common case several times slower.
    for _ in range(1 if abs(v) <= 6.0 * vs else 0):
        r = v / vs
        x = r * r
        # e^{-x}: below x = 0.01 (|v| < v_s / 10, where a stick–slip random walk spends its
        # time) from its Taylor series to x⁵ (remainder below x⁶/720 < 1.4e-15), else the
        # library's exp, again behind a one-trip loop
        e = 1.0 - x * (1.0 - x * (0.5 - x * (1.0 / 6.0 - x * (1.0 / 24.0 - x * (1.0 / 120.0)))))
        for _ in range(0 if x < 0.01 else 1):
            e = math.exp(-x)
        mag += (fs - fc) * e
    return mag if v > 0.0 else -mag


@njit(cache=True, inline="always")
def _disturbance_force(t, nl, p, i):
    # the periodic disturbance A_d sin(2π f_d t + φ) of axis i, N
    f = 0.0
    for _ in range(1 if nl[p, i, NL_AD] != 0.0 else 0):
        f += nl[p, i, NL_AD] * math.sin(nl[p, i, NL_WD] * t + nl[p, i, NL_PHASE])
    return f


@njit(cache=True, inline="always")
def external_force(x, t, nl, p, i):
    """Ripple + disturbance (N) acting against the drive of axis i (parameter set p), at
    position x (m) and time t (s): A_r sin(2π x / P_r) + A_d sin(2π f_d t + φ)."""
    f = 0.0
    # one-trip loops rather than ifs: LLVM speculates an if-guarded sin (computing it even when
    # the amplitude is zero); a loop it leaves alone
    for _ in range(1 if nl[p, i, NL_AR] != 0.0 else 0):
        f += nl[p, i, NL_AR] * math.sin(nl[p, i, NL_KR] * x)
    return f + _disturbance_force(t, nl, p, i)


# |Δ| below which sin(a + Δ) is taken from sin a, cos a and Taylor series of sin Δ, cos Δ to
# Δ⁵ (remainder below Δ⁶/720 < 1.4e-9 of the amplitude): the slow path evaluates ripple and
# disturbance many times within one period, a short way from where it started
NEAR_ANGLE = 0.1


@njit(cache=True, inline="always")
def _sin_near(a0, s0, c0, d):
    # sin(a0 + d) from s0 = sin a0, c0 = cos a0
    if abs(d) >= NEAR_ANGLE:
        return math.sin(a0 + d)
    d2 = d * d
    sin_d = d * (1.0 - d2 * (1.0 / 6.0 - d2 * (1.0 / 120.0)))
    cos_d = 1.0 - d2 * (0.5 - d2 * (1.0 / 24.0 - d2 * (1.0 / 720.0)))
    return s0 * cos_d + c0 * sin_d


@njit(cache=True, inline="always")
def _near_cache(x0, t0, nl, p, i):
    # the ripple and disturbance phases at (x0, t0) with their sines and cosines, for
    # external_force_near: (x0, a_r, sin a_r, cos a_r, t0, a_d, sin a_d, cos a_d)
    a_r = nl[p, i, NL_KR] * x0
    a_d = nl[p, i, NL_WD] * t0 + nl[p, i, NL_PHASE]
    s_r, c_r, s_d, c_d = 0.0, 1.0, 0.0, 1.0
    for _ in range(1 if nl[p, i, NL_AR] != 0.0 else 0):
        s_r = math.sin(a_r)
        c_r = math.cos(a_r)
    for _ in range(1 if nl[p, i, NL_AD] != 0.0 else 0):
        s_d = math.sin(a_d)
        c_d = math.cos(a_d)
    return (x0, a_r, s_r, c_r, t0, a_d, s_d, c_d)


@njit(cache=True, inline="always")
def external_force_near(x, t, nl, p, i, ec):
    """:func:`external_force` at (x, t) near the point of the cache ``ec`` (_near_cache)."""
    f = 0.0
    for _ in range(1 if nl[p, i, NL_AR] != 0.0 else 0):
        f += nl[p, i, NL_AR] * _sin_near(ec[1], ec[2], ec[3], nl[p, i, NL_KR] * (x - ec[0]))
    for _ in range(1 if nl[p, i, NL_AD] != 0.0 else 0):
        f += nl[p, i, NL_AD] * _sin_near(ec[5], ec[6], ec[7], nl[p, i, NL_WD] * (t - ec[4]))
    return f


@njit(cache=True, inline="always")
def _advance_n(Z, zr, O, orow, mat, p, i, u, w0, w1, ns):
    for r in range(ns):
        acc = mat[p, i, r, ns] * u + mat[p, i, r, ns + 1] * w0 + mat[p, i, r, ns + 2] * w1
        for c in range(ns):
            acc += mat[p, i, r, c] * Z[zr, c]
        O[orow, r] = acc


@njit(cache=True, inline="always")
def _advance(Z, zr, O, orow, mat, p, i, u, w0, w1, ns):
    # O[orow] = Phi Z[zr] + Gu u + Ga w0 + Gb w1 (rows of 2-D arrays, never the same row),
    # with the matrices of axis i, parameter set p. Literal sizes let the compiler unroll the
    # small mat-vec (about 3x faster than a loop over a run-time size).
    if ns == 2:
        _advance_n(Z, zr, O, orow, mat, p, i, u, w0, w1, 2)
    elif ns == 3:
        _advance_n(Z, zr, O, orow, mat, p, i, u, w0, w1, 3)
    elif ns == 4:
        _advance_n(Z, zr, O, orow, mat, p, i, u, w0, w1, 4)
    else:
        _advance_n(Z, zr, O, orow, mat, p, i, u, w0, w1, 5)


@njit(cache=True, inline="always")
def _add_gb_n(S, s, mat, p, i, dw, ns):
    for r in range(ns):
        S[s, r] += mat[p, i, r, ns + 2] * dw


@njit(cache=True, inline="always")
def _add_gb(S, s, mat, p, i, dw, ns):
    # S[s] += Gb dw (Gb: last column of the packed matrices), with a literal size (unrolled)
    if ns == 2:
        _add_gb_n(S, s, mat, p, i, dw, 2)
    elif ns == 3:
        _add_gb_n(S, s, mat, p, i, dw, 3)
    elif ns == 4:
        _add_gb_n(S, s, mat, p, i, dw, 4)
    else:
        _add_gb_n(S, s, mat, p, i, dw, 5)


@njit(cache=True, inline="always")
def _copy_row_n(S, s, Z, zr, ns):
    for r in range(ns):
        Z[zr, r] = S[s, r]


@njit(cache=True, inline="always")
def _copy_row(S, s, Z, zr, ns):
    # Z[zr] = S[s], with a literal size (unrolled)
    if ns == 2:
        _copy_row_n(S, s, Z, zr, 2)
    elif ns == 3:
        _copy_row_n(S, s, Z, zr, 3)
    elif ns == 4:
        _copy_row_n(S, s, Z, zr, 4)
    else:
        _copy_row_n(S, s, Z, zr, 5)


@njit(cache=True, inline="always")
def _nonfriction_force(Z, zr, u, wnf, cont, p, i, ns):
    # Force on the moving mass excluding friction: m * (A[1,:] z + B_u[1] u + B_w[1] wnf).
    acc = cont[p, i, ns] * u + cont[p, i, ns + 1] * wnf
    for c in range(ns):
        acc += cont[p, i, c] * Z[zr, c]
    return acc / cont[p, i, ns + 1]


@njit(cache=True, inline="always")
def axis_step(Z, zr, stuck, u, t0, T, n_sub, mat_T, mat_h, cont, nl, p, i, S, s, w_extra):
    """Advance the axis state in row ``zr`` of the 2-D state array Z (in place) by T seconds
    with the held force command u (N); matrices and parameters of axis i, parameter set p
    (full packed arrays, indexed); rows s and s + 1 of the 2-D scratch array S are work space.
    Rows and indices rather than 1-D views: a view costs two atomic reference-count updates on
    its parent array, which the threads of the vectorised env would contend for.

    ``w_extra`` is an additional force on the moving mass held over the period (N), e.g. a
    random disturbance. Returns the new stuck flag (1.0 while held by static friction).
    """
    ns = Z.shape[1]
    fc = nl[p, i, NL_FC]
    fs = nl[p, i, NL_FS]
    vs = nl[p, i, NL_VS]
    v0 = Z[zr, 1]
    # substeps if the whole period is not accepted: the fine ones (level 0) unless set below
    n_use = n_sub
    cap0 = n_sub
    # without static friction nothing holds the mass: a stuck flag (e.g. the case's initial
    # flag, with per-env parameters that have none) is void, and the slow path, whose tests
    # are fractions of f_s, is never entered
    if fs == 0.0:
        stuck = 0.0
    if stuck == 0.0 and (fs == 0.0 or v0 != 0.0):
        # whole period, first-order-hold predictor–corrector
        f0 = friction_force(v0, fc, fs, vs)
        w0 = -(f0 + (external_force(Z[zr, 0], t0, nl, p, i) - w_extra))
        _advance(Z, zr, S, s, mat_T, p, i, u, w0, w0, ns)
        v1 = S[s, 1]
        w1 = -(
            friction_force(v1, fc, fs, vs) + (external_force(S[s, 0], t0 + T, nl, p, i) - w_extra)
        )
        if w1 != w0:  # equal when w does not depend on the state (e.g. pure Coulomb at speed)
            # the map is linear in w1: add the end-of-period term's change, Gb (w1 − w0),
            # instead of a second full mat-vec
            _add_gb(S, s, mat_T, p, i, w1 - w0, ns)
        v2 = S[s, 1]
        # accepted unless the velocity changes sign (reversal: substeps with stick–slip) or
        # crosses the Stribeck region in large steps (friction then varies too fast for the
        # first-order hold: its value at the mid-period velocity differs from the mean of the
        # end values by more than FOH_FRICTION_TOL of the static friction)
        accept = fs == 0.0
        if not accept and (
            (v0 > 0.0 and v1 > 0.0 and v2 > 0.0) or (v0 < 0.0 and v1 < 0.0 and v2 < 0.0)
        ):
            accept = abs(v2 - v0) < 0.1 * vs or min(abs(v0), abs(v2)) > 5.0 * vs
            for _ in range(0 if accept else 1):
                f_mid = friction_force(0.5 * (v0 + v2), fc, fs, vs)
                f_ends = 0.5 * (f0 + friction_force(v2, fc, fs, vs))
                q = abs(f_mid - f_ends) / (FOH_FRICTION_TOL * fs)
                accept = q <= 1.0
                # no reversal, friction merely curved: d equal substeps with d² >= 2 q (the
                # deviation falls with the square of the step; a factor 2 to spare)
                if not accept and q <= 8.0:
                    d = 2 if q <= 2.0 else (3 if q <= 4.5 else 4)
                    if d < n_sub:
                        n_use = d
                # on the fine grid, chunks short enough for the deviation (∝ length²)
                if not accept:
                    cap0 = max(1, int(CAP_SAFETY * n_sub / math.sqrt(q)))
        if accept:
            _copy_row(S, s, Z, zr, ns)
            return 0.0
    # held by static friction over the whole period (the usual case at rest): the non-friction
    # force within f_s at both ends. Tried here, without the call to the slow path; where it
    # fails, the slow path takes the forces at the two ends from here (f_a, f_b)
    f_a = math.nan
    f_b = 0.0
    if stuck != 0.0:
        wnf = -(external_force(Z[zr, 0], t0, nl, p, i) - w_extra)
        f_a = _nonfriction_force(Z, zr, u, wnf, cont, p, i, ns)
        if abs(f_a) <= fs:
            _advance(Z, zr, S, s, mat_T, p, i, u, wnf - f_a, wnf - f_a, ns)
            S[s, 0] = Z[zr, 0]
            S[s, 1] = 0.0
            wnf1 = -(external_force(Z[zr, 0], t0 + T, nl, p, i) - w_extra)
            f_b = _nonfriction_force(S, s, u, wnf1, cont, p, i, ns)
            if abs(f_b) <= fs:
                _copy_row(S, s, Z, zr, ns)
                return 1.0
    # the substep level (SUB_LEVEL_DIVISORS): fine (0) or d equal substeps (d − 1); computed
    # here from run-time values, so that the slow path is compiled for one signature (a
    # constant 0 would be typed as a literal and give it a second one)
    level = 0 if n_use == n_sub else n_use - 1
    return _axis_step_slow(
        Z, zr, stuck, u, t0, T, n_use, level, cap0, mat_T, mat_h, cont, nl, p, i, S, s,
        w_extra, f_a, f_b,
    )  # fmt: skip


@njit(cache=True, inline="always")
def _chunk_level(c):
    # level of mat_h for a chunk of c = 2^k fine substeps (k >= 1)
    level = CHUNK_LEVEL0 - 1
    while c > 1:
        c >>= 1
        level += 1
    return level


@njit(cache=True, inline="always")
def _pow2_floor(n):
    # largest power of two <= n (n >= 1), at most MAX_CHUNK
    c = 1
    while c * 2 <= n and c < MAX_CHUNK:
        c *= 2
    return c


@njit(cache=True, inline="always")
def _correct(S, s, mat_h, row, nl, p, i, w0, t_end, w_extra, ns, ec):
    # corrector of the first-order hold: the force at the predicted end state (row s of S) in
    # place of w0 there, added through the Gb column (the map is linear in the end value)
    v1 = S[s, 1]
    w1 = -(
        friction_force(v1, nl[p, i, NL_FC], nl[p, i, NL_FS], nl[p, i, NL_VS])
        + (external_force_near(S[s, 0], t_end, nl, p, i, ec) - w_extra)
    )
    _add_gb(S, s, mat_h, row, i, w1 - w0, ns)


@njit(cache=True, inline="always")
def _hold_whole_period(
    Z, zr, u, t0, T, mat_T, mat_h, ph2, cont, nl, p, i, S, s, w_extra, fs, ns, ec, f_a0, f_b0
):
    # held by static friction over the whole period if the non-friction force stays within
    # f_s at both ends of the period (the usual case at rest: no substeps needed). Returns
    # -1.0 when held; otherwise where in the period (a fraction) the non-friction force
    # reaches f_s: from its values at the start, the middle (row ph2 of mat_h: T / 2) and the
    # end, through an exponential (a current lag's shape; a chord where that does not fit)
    wnf = -(external_force_near(Z[zr, 0], t0, nl, p, i, ec) - w_extra)
    if f_a0 == f_a0:
        # the ends already tried (axis_step): not held
        f_a, f_b = f_a0, f_b0
        if abs(f_a) > fs:
            return 0.0
    else:
        f_a = _nonfriction_force(Z, zr, u, wnf, cont, p, i, ns)
        if abs(f_a) > fs:
            return 0.0
        _advance(Z, zr, S, s, mat_T, p, i, u, wnf - f_a, wnf - f_a, ns)
        S[s, 0] = Z[zr, 0]
        S[s, 1] = 0.0
        wnf1 = -(external_force_near(Z[zr, 0], t0 + T, nl, p, i, ec) - w_extra)
        f_b = _nonfriction_force(S, s, u, wnf1, cont, p, i, ns)
        if abs(f_b) <= fs:
            _copy_row(S, s, Z, zr, ns)
            return -1.0
    edge = fs if f_b > 0.0 else -fs
    alpha = (edge - f_a) / (f_b - f_a)
    _advance(Z, zr, S, s + 1, mat_h, ph2, i, u, wnf - f_a, wnf - f_a, ns)
    S[s + 1, 0] = Z[zr, 0]
    S[s + 1, 1] = 0.0
    wnfm = -(external_force_near(Z[zr, 0], t0 + 0.5 * T, nl, p, i, ec) - w_extra)
    d1 = _nonfriction_force(S, s + 1, u, wnfm, cont, p, i, ns) - f_a
    if d1 != 0.0:
        q = (f_b - f_a - d1) / d1  # e^{-T / (2 tau)} for f = f_inf + (f_a - f_inf) e^{-t / tau}
        if 0.0 < q < 1.0:
            arg = 1.0 - (edge - f_a) * (1.0 - q) / d1
            if arg > 0.0:
                a2 = 0.5 * math.log(arg) / math.log(q)
                if 0.0 <= a2 <= 1.0:
                    alpha = a2
    return alpha


@njit(cache=True, inline="always")
def _hold(Z, zr, u, wnf, f_nf, t_end, c, mat_h, ph, cont, nl, p, i, S, s, w_extra, fs, ns, ec):
    # held over c substeps from a state within f_s: the load's acceleration cancelled (the
    # rest of the state, e.g. a motor behind a compliant screw, moves on). A chunk (c > 1) is
    # accepted only if the non-friction force is within f_s at its end as well; a fine substep
    # on the check at its start, as always. Returns whether the hold was taken.
    x_hold = Z[zr, 0]
    _advance(Z, zr, S, s, mat_h, ph, i, u, wnf - f_nf, wnf - f_nf, ns)
    S[s, 0] = x_hold
    S[s, 1] = 0.0
    if c > 1:
        wnf1 = -(external_force_near(x_hold, t_end, nl, p, i, ec) - w_extra)
        if abs(_nonfriction_force(S, s, u, wnf1, cont, p, i, ns)) > fs:
            return False
    _copy_row(S, s, Z, zr, ns)
    return True


@njit(cache=True, inline="always")
def _break_away(Z, zr, u, wnf, f_nf, t, h, mat_h, ph, nl, p, i, S, s, w_extra, ns, ec):
    # one fine substep from rest in the direction of the net force, friction starting at f_s;
    # returns the new stuck flag (1.0 if the mass stopped again within the substep)
    fs = nl[p, i, NL_FS]
    direction = 1.0 if f_nf > 0.0 else -1.0
    w0 = wnf - direction * fs
    _advance(Z, zr, S, s, mat_h, ph, i, u, w0, w0, ns)
    v1 = S[s, 1]
    if v1 * direction > 0.0:
        _correct(S, s, mat_h, ph, nl, p, i, w0, t + h, w_extra, ns, ec)
    _copy_row(S, s, Z, zr, ns)
    if Z[zr, 1] * direction <= 0.0:
        Z[zr, 1] = 0.0
        return 1.0
    return 0.0


@njit(cache=True, inline="always")
def _slide_chunk(Z, zr, u, t, hc, mat_h, pc, nl, p, i, S, s, w_extra, ns, ec):
    # a chunk of sliding substeps in one first-order-hold predictor–corrector step, accepted
    # under the whole period's tests (axis_step): no sign change, friction within
    # FOH_FRICTION_TOL · f_s of its first-order hold. Returns whether it was taken.
    fc = nl[p, i, NL_FC]
    fs = nl[p, i, NL_FS]
    vs = nl[p, i, NL_VS]
    v0 = Z[zr, 1]
    f0 = friction_force(v0, fc, fs, vs)
    w0 = -(f0 + (external_force_near(Z[zr, 0], t, nl, p, i, ec) - w_extra))
    _advance(Z, zr, S, s, mat_h, pc, i, u, w0, w0, ns)
    v1 = S[s, 1]
    if v0 * v1 <= 0.0:
        return -1.0
    _correct(S, s, mat_h, pc, nl, p, i, w0, t + hc, w_extra, ns, ec)
    v2 = S[s, 1]
    if v0 * v2 <= 0.0:
        return -1.0
    q = 0.0
    if not (abs(v2 - v0) < 0.1 * vs or min(abs(v0), abs(v2)) > 5.0 * vs):
        f_mid = friction_force(0.5 * (v0 + v2), fc, fs, vs)
        f_ends = 0.5 * (f0 + friction_force(v2, fc, fs, vs))
        q = abs(f_mid - f_ends) / (FOH_FRICTION_TOL * fs)
    if q <= 1.0:
        _copy_row(S, s, Z, zr, ns)
    return q


@njit(cache=True, inline="always")
def _slide_fine(Z, zr, u, t, h, mat_h, ph, cont, nl, p, i, S, s, w_extra, ns, ec):
    # one fine sliding substep; a velocity reversal inside it is located by interpolation and
    # the mass sticks there if the non-friction force is within f_s, or slips through with
    # friction's time average. Returns (stuck flag, whether a reversal happened).
    fc = nl[p, i, NL_FC]
    fs = nl[p, i, NL_FS]
    vs = nl[p, i, NL_VS]
    v0 = Z[zr, 1]
    f0 = friction_force(v0, fc, fs, vs)
    w0 = -(f0 + (external_force_near(Z[zr, 0], t, nl, p, i, ec) - w_extra))
    _advance(Z, zr, S, s, mat_h, ph, i, u, w0, w0, ns)
    v1 = S[s, 1]
    if v0 * v1 > 0.0:
        _correct(S, s, mat_h, ph, nl, p, i, w0, t + h, w_extra, ns, ec)
        v1 = S[s, 1]
    if v0 * v1 > 0.0 or fs == 0.0 or v0 == 0.0:
        _copy_row(S, s, Z, zr, ns)
        return 0.0, False
    s2 = s + 1
    alpha = v0 / (v0 - v1)
    for r in range(ns):
        S[s2, r] = Z[zr, r] + alpha * (S[s, r] - Z[zr, r])
    S[s2, 1] = 0.0
    wnf = -(external_force_near(S[s2, 0], t + alpha * h, nl, p, i, ec) - w_extra)
    f_nf = _nonfriction_force(S, s2, u, wnf, cont, p, i, ns)
    if abs(f_nf) <= fs:
        _copy_row(S, s2, Z, zr, ns)
        return 1.0, True
    # slips through: friction reverses at the crossing; its time average over the substep
    f_after = fs if f_nf > 0.0 else -fs
    f_avg = alpha * f0 + (1.0 - alpha) * f_after
    w = -(f_avg + (external_force_near(Z[zr, 0], t, nl, p, i, ec) - w_extra))
    _advance(Z, zr, S, s, mat_h, ph, i, u, w, w, ns)
    _copy_row(S, s, Z, zr, ns)
    return 0.0, True


@njit(cache=True, inline="always")
def _chunk_substeps(level, j, target, suspect, hi, n_sub, limit):
    """Substeps of the next chunk of :func:`_axis_step_slow` from substep j: one off the fine
    grid (level > 0); on it, up to the predicted event (``target``), half-way to a suspected
    one (bisection up to ``hi``), else the rest of the period — at most ``limit`` (stuck: the
    largest chunk; sliding: as long as the first-order hold allows), at least 1."""
    c = 1
    if level == 0:
        if target > j:
            c = target - j
        elif suspect:
            c = (hi - j) // 2
        else:
            c = n_sub - j
        c = min(c, limit)
        if c < 1:
            c = 1
    return c


@njit(cache=True, error_model="numpy")
def _axis_step_slow(
    Z,
    zr,
    stuck,
    u,
    t0,
    T,
    n_sub,
    level,
    cap0,
    mat_T,
    mat_h,
    cont,
    nl,
    p,
    i,
    S,
    s,
    w_extra,
    f_a0,
    f_b0,
):
    # Stuck, breaking away, near a velocity reversal, or in the Stribeck band: n_sub substeps
    # of T / n_sub with the matrices of substep level ``level`` (row p · N_SUB_LEVELS + level of
    # mat_h). Kept out of line so the common moving case stays small where it is inlined.
    # Rows s and s + 1 of S are work space.
    #
    # On the fine grid (level 0) the smooth stretches are crossed in chunks of c substeps (see
    # CHUNK_SIZES): an event is suspected before substep ``hi`` (at first n_sub: the whole
    # period failed), a chunk is tried over half of [j, hi), a failed chunk moves ``hi`` to its
    # end (bisection), and a fine substep that meets the event (break-away, sticking, reversal)
    # clears the suspicion, after which the rest of the period is tried in the largest chunks.
    ns = Z.shape[1]
    n_levels = mat_h.shape[0] // mat_T.shape[0]
    cmax = n_levels - CHUNK_LEVEL0 + 1
    cap = min(cap0, cmax)
    p0 = p * n_levels
    ph = p0 + level
    fs = nl[p, i, NL_FS]
    if stuck == 0.0 and Z[zr, 1] == 0.0 and fs > 0.0:
        stuck = 1.0
    # ripple and disturbance at the start of the period, and from there by series (see
    # external_force_near): one sine and cosine however many evaluations follow
    ec = _near_cache(Z[zr, 0], t0, nl, p, i)
    h = T / n_sub
    hi = n_sub
    suspect = True
    j = 0
    target = -1  # the substep where the event is predicted (-1: none)
    if cap0 < n_sub:
        suspect = False  # sent here by the first-order hold's deviation, not by an event
    if stuck != 0.0:
        alpha = _hold_whole_period(
            Z, zr, u, t0, T, mat_T, mat_h, p0 + 1, cont, nl, p, i, S, s, w_extra, fs, ns, ec,
            f_a0, f_b0,
        )  # fmt: skip
        if alpha < 0.0:
            return 1.0
        if level == 0:
            target = int(alpha * n_sub)
            hi = min(n_sub, target + 2)
    while j < n_sub:
        t = t0 + j * h
        if suspect and j >= hi:
            suspect, hi = False, n_sub
        if stuck == 0.0 and Z[zr, 1] == 0.0 and fs > 0.0:
            stuck = 1.0
        c = _chunk_substeps(level, j, target, suspect, hi, n_sub, cmax if stuck != 0.0 else cap)
        pc = ph if c == 1 else p0 + CHUNK_LEVEL0 + c - 2
        if stuck != 0.0:
            wnf = -(external_force_near(Z[zr, 0], t, nl, p, i, ec) - w_extra)
            f_nf = _nonfriction_force(Z, zr, u, wnf, cont, p, i, ns)
            if abs(f_nf) <= fs:
                held = _hold(
                    Z, zr, u, wnf, f_nf, t + c * h, c, mat_h, pc, cont, nl, p, i, S, s, w_extra,
                    fs, ns, ec,
                )  # fmt: skip
                if held:
                    j += c
                else:
                    suspect, hi, target = True, j + c, -1
                continue
            stuck = _break_away(
                Z, zr, u, wnf, f_nf, t, h, mat_h, ph, nl, p, i, S, s, w_extra, ns, ec
            )
            suspect, hi, target = False, n_sub, -1
            j += 1
        elif c > 1:
            q = _slide_chunk(Z, zr, u, t, c * h, mat_h, pc, nl, p, i, S, s, w_extra, ns, ec)
            if q < 0.0:
                # the velocity changes sign within the chunk: an event there
                suspect, hi = True, j + c
            else:
                if q <= 1.0:
                    j += c
                # the next chunk as long as the first-order hold allows (deviation ∝ length²)
                grow = 2 * c if q <= 1.0 else c
                if q > 0.0:
                    grow = min(grow, int(CAP_SAFETY * c / math.sqrt(q)))
                cap = max(1, min(cmax, grow))
        else:
            stuck, event = _slide_fine(
                Z, zr, u, t, h, mat_h, ph, cont, nl, p, i, S, s, w_extra, ns, ec
            )
            if event:
                suspect, hi = False, n_sub
            j += 1
            cap = min(cmax, 2 * cap)
    return stuck


@njit(cache=True, inline="always")
def delayed_saturated(delay, u_pending, command, b, i, limit):
    """The command of axis i applied over this period: with the computation ``delay`` the
    previous one (``u_pending``, which then takes this one), else this one; clipped to ±limit.
    """
    if delay:
        u = u_pending[b, i]
        u_pending[b, i] = command[b, i]
    else:
        u = command[b, i]
    if u > limit:
        u = limit
    elif u < -limit:
        u = -limit
    return u


@njit(cache=True)
def plant_step_batch(
    z,
    stuck,
    u_pending,
    action_force,
    t0,
    T,
    n_sub,
    delay,
    mat_T,
    mat_h,
    cont,
    nl,
    pidx,
    applied_out,
    w_extra,
):
    """Advance every env of the batch by one servo period, in place.

    z (B, A, ns), stuck (B, A), u_pending (B, A): state; pidx (B,) int64: the parameter set
    (first index of mat_T, cont, nl; of mat_h see the module docstring) of each env;
    action_force (B, A): the command computed at this sample, N (or the velocity-command
    unit). With ``delay`` the command applied over this period is the previous one
    (``u_pending``) and this one is stored.
    applied_out (B, A) receives the applied (saturated) command; w_extra (B, A) is an extra
    force on each mass held over the period (N; zeros for none).
    """
    n_env, n_axes, ns = z.shape
    work = np.empty((2, ns))
    cur = np.empty((1, ns))
    for b in range(n_env):
        p = pidx[b]
        for i in range(n_axes):
            u = delayed_saturated(delay, u_pending, action_force, b, i, nl[p, i, NL_FMAX])
            applied_out[b, i] = u
            for r in range(ns):
                cur[0, r] = z[b, i, r]
            stuck[b, i] = axis_step(
                cur,
                0,
                stuck[b, i],
                u,
                t0,
                T,
                n_sub,
                mat_T,
                mat_h,
                cont,
                nl,
                p,
                i,
                work,
                0,
                w_extra[b, i],
            )
            for r in range(ns):
                z[b, i, r] = cur[0, r]
