"""Jee & Lee (2007) design tools with the cross-coupling controller (eqs. 8, 15–32, Figs. 4–5).

The controller (``agents.jee_ccc``, eqs. 8, 11–12) is ``U = K_P E + G_C(z) ε`` with
``G_C(z) = C_P + C_I T z/(z − 1) + C_D (z − 1)/(T z)`` and our contour-error model
``ε = Π E``, ``Π = I − t tᵀ`` (t the unit tangent at the reference point). Equation numbers
are the paper's (``/work/shared/papers/001_*``).

**The range of M (eq. 16).** For a matched system ``G(z) = g(z) I`` and a frozen path point,
eq. (15) is ``det[I + g (K_P I + G_C Π)] = 0``. Π is a symmetric projection with eigenvalue 0
on the tangent and 1 on the normal plane, so in its eigenbasis the determinant factors into
``(1 + g K_P) (1 + g (K_P + G_C))^{n−1}``: eq. (16) with ``Ω1`` (the tangent, M = 0) times
``Ω2`` with **M = 1** (every normal direction). Jee's M (eq. 13) is the trace of the
rank-one projected-plane maps of eqs. (2)–(7) (``M_xy = [C1; C2][cos ν1, sin ν1]``, trace
``A1x + B1y``), i.e. their non-zero eigenvalue, which varies with the angles and must be bounded
numerically; with ε = Π E it is exactly 1, so the "range of M" is the two values {0, 1} and
the regions below are the intersection of the Jury conditions of Ω1 (M = 0, eq. 17) and Ω2
(M = 1). ``m_values`` lets a caller intersect over more values (e.g. ``linspace(0, 1)`` for an
estimate of ε whose gain on the normal plane is between 0 and 1); for Table 1 this changes
nothing (checked in the tests).

**Stability regions (Figs. 4a/4b).** Clearing G_C's denominator (minimal: ``z − 1`` only with
C_I ≠ 0, ``z`` only with C_D ≠ 0) gives the characteristic polynomial

    Ω2(z) · T z (z − 1) = A(z) T z (z − 1)
        + (H1 z + H0) [K_P T z (z − 1) + M (C_P T z (z − 1) + C_I T² z² + C_D (z − 1)²)],

``A(z) = (z − 1)(z − r)`` for the paper's model (eq. 9) and ``A(z) = z (z − 1)(z − r)`` for the
realistic plant's one-period computation delay (``G_i(z) z⁻¹``). Jury's criterion is applied to
every such polynomial (a vectorised copy of :func:`~contour_env.analysis.jee.jury_stable`).
The mismatched Table 1 is handled as the paper says: the matched analysis with each axis's
(H1, H0, r), and the common region is the intersection over the axes.

**Steady state with cross-coupling (eqs. 18–32).** Two predictions:

- *Paper, eq. (21):* the cross-coupling acts on the true contour-error vector
  ``ε = z^{−d} R − P`` (eq. 18), so for a matched axis
  ``H = g [K_P + e^{−jωTd} G_C] / (1 + g [K_P + G_C])`` at ``z = e^{jωT}`` and d solves eq. (32)
  (the foot of the normal from P(k) is R(k − d): ``d = −∠H/(ωT)``, iterated to a fixed point);
  contour error ``R0 (|H| − 1)`` (eq. 29), tracking error ``R0 |1 − H|`` (eq. 31).
- *The controller law* (what ``agents.jee_ccc`` does): ε = Π(k) E(k) with the tangent of the
  reference point, a projection that turns with the path. On a circle in the plane (u, v),
  ``t(k) = Re{w e^{jωkT}}``, ``w = v + j u``, so ``Π(k) = Π0 + Π2 e^{2jωkT} + conj``, with
  ``Π0 = I − (u uᵀ + v vᵀ)/2`` and ``Π2 = −w wᵀ/4``: a signal at the harmonic m of ω is mapped
  to m and m ± 2. The periodic steady state is found by harmonic balance over the odd harmonics
  ±1, ±3, … (``harmonics`` of them); for matched axes the orbit is an exact circle (the loop is
  invariant under rotations about the plane's normal) and one harmonic is exact, in closed
  form: in the frame of the reference point (radial real, tangential imaginary) the tracking
  error E solves ``E (1 + g K_P) + g G_C Re{E} = R0``.

  The frozen-projection eq. (21) misses one effect of ε = Π E: a lag θ = ωTd puts R(k) a chord
  ahead of the foot of the normal, whose radial part ``R0 (1 − cos θ)`` the controller reads as
  contour error, and the integral action of G_C then pushes the orbit outwards by about
  ``R0 (1/cos θ − 1) ≈ E²/(2 R0)`` (E the tracking error). It is second order in E and small on
  the paper's ideal plant, but it sets a floor on the contour error at low K_P (the realistic
  plant's margin-limited gains): E = 1.6 mm on R0 = 50 mm gives 25 µm.

Both are compared with a simulation of the law on the plant (:func:`simulate_cc_circle`).

The design chart, the recommended gains, the report and the plot are in
:mod:`contour_env.app.jee_chart`.

All quantities SI (m, s); errors in the reports in µm.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy import signal

from contour_env.plants import Plant

from .jee import (
    AxisModel,
    _check_circle,
    _check_linear_model,
    _circle_basis,
    _distance_to_circle,
    _linear_sim_plant,
    _make_plant,
)

__all__ = [
    "CD_RATIO",
    "CI_RATIO",
    "CONTOUR_GOAL_M",
    "M_VALUES",
    "TRACKING_GOAL_M",
    "cc_characteristic",
    "cc_stable",
    "cross_coupling_region",
    "design_models",
    "gc_response",
    "gc_transfer",
    "jury_stable_batch",
    "siso_margins_grid",
    "simulate_cc_circle",
    "steady_state_cc_circle",
    "steady_state_cc_matched",
]

#: The paper's example ratios (§3): C_I = 2.62 C_P (1/s), C_D = 0.02 C_P (s).
CI_RATIO = 2.62
CD_RATIO = 0.02
#: The paper's design goal (§3, Fig. 5).
CONTOUR_GOAL_M = 25e-6
TRACKING_GOAL_M = 250e-6
#: Tangent (Ω1) and normal directions (Ω2) of ε = (I − t tᵀ) E.
M_VALUES = (0.0, 1.0)
#: The project's loop-margin requirement (agents.margins) and its mass corners.
MIN_GAIN_MARGIN_DB = 6.0
MIN_PHASE_MARGIN_DEG = 30.0
MASS_CORNERS = (0.8, 1.0, 1.2)


# --------------------------------------------------------------------------- models


def _design_plant(plant, realistic: bool, plant_kw: dict) -> Plant:
    if isinstance(plant, Plant):
        if plant_kw:
            raise ValueError(
                f"plant_kw: a Plant instance takes no further arguments, got {sorted(plant_kw)}"
            )
        return plant
    return Plant(plant, ideal=not realistic, **plant_kw)


def design_models(plant="jee-triaxial", *, realistic: bool = False, **plant_kw):
    """(models, delay): eq. (9) of every axis from the *nominal* m, b, T (what the designer is
    given) and whether the simulated plant has the one-period computation delay (the
    realistic plant; the analysis then uses ``G_i(z) z⁻¹``). A plant whose simulated model has
    a current-loop lag or a two-mass mode (not eq. 9 plus a delay) is rejected."""
    base = _design_plant(plant, realistic, plant_kw)
    p = base.nominal.replace(computation_delay=False)
    _check_linear_model(p)
    _check_linear_model(base.params.replace(computation_delay=False))
    models = [
        AxisModel.from_mass_viscous(a, m, b, p.servo_period_s)
        for a, m, b in zip(p.axis_names, p.mass_kg, p.viscous_Ns_m, strict=True)
    ]
    return models, bool(base.params.computation_delay or base.nominal.computation_delay)


def _true_models(base: Plant) -> list[AxisModel]:
    """Eq. (9) of the simulated (true) plant's linear part (mismatched m, b)."""
    p = base.params
    return [
        AxisModel.from_mass_viscous(a, m, b, p.servo_period_s)
        for a, m, b in zip(p.axis_names, p.mass_kg, p.viscous_Ns_m, strict=True)
    ]


# --------------------------------------------------------------------------- G_C (eq. 8)


def gc_transfer(cp: float, ci: float, cd: float, servo_period_s: float):
    """G_C(z) of eq. (8) as (num, den), highest power first, with the minimal denominator:
    ``T z (z − 1)``; ``z − 1`` alone when C_D = 0; ``T z`` alone when C_I = 0; 1 when both are
    0 (so no pole–zero cancellation at z = 1 is left for Jury to read as marginal)."""
    T = float(servo_period_s)
    cp, ci, cd = float(cp), float(ci), float(cd)
    if ci == 0.0 and cd == 0.0:
        return np.array([cp]), np.array([1.0])
    if ci == 0.0:
        return np.array([cp * T + cd, -cd]), np.array([T, 0.0])
    if cd == 0.0:
        return np.array([cp + ci * T, -cp]), np.array([1.0, -1.0])
    return np.array([cp * T + ci * T * T + cd, -cp * T - 2.0 * cd, cd]), np.array([T, -T, 0.0])


def gc_response(cp, ci, cd, servo_period_s: float, z):
    """G_C(z) (eq. 8) at complex z; broadcasts over gains and z."""
    z = np.asarray(z, dtype=complex)
    T = float(servo_period_s)
    cp, ci, cd = (np.asarray(a, dtype=np.float64) for a in (cp, ci, cd))
    return cp + ci * T * z / (z - 1.0) + cd * (z - 1.0) / (T * z)


def _axis_response(model: AxisModel, z, delay: bool):
    z = np.asarray(z, dtype=complex)
    g = (model.H1 * z + model.H0) / ((z - 1.0) * (z - model.r))
    return g / z if delay else g


# --------------------------------------------------------------------------- Jury (eq. 16)


def cc_characteristic(model: AxisModel, kp, cp=0.0, ci=0.0, cd=0.0, M=1.0, delay=False):
    """Characteristic polynomial of one axis with the cross-coupling (eq. 16), highest first.

    ``M = 0``: Ω1 (the tangent; K_P alone). Otherwise Ω2 times G_C's minimal denominator:
    ``A(z) den(z) + (H1 z + H0) (K_P den(z) + M num(z))``, ``A = (z − 1)(z − r)``, times z
    with the computation delay."""
    A = np.polymul([1.0, -1.0], [1.0, -model.r])
    if delay:
        A = np.polymul(A, [1.0, 0.0])
    B = np.array([model.H1, model.H0])
    if float(M) == 0.0:
        return np.polyadd(A, float(kp) * B)
    num, den = gc_transfer(cp, ci, cd, model.servo_period_s)
    return np.polyadd(np.polymul(A, den), np.polymul(B, np.polyadd(float(kp) * den, M * num)))


def jury_stable_batch(coeffs) -> np.ndarray:
    """Jury's test (as :func:`~contour_env.analysis.jee.jury_stable`) of many real polynomials
    of one degree at once: ``coeffs`` (N, n + 1), highest power first, leading coefficient
    non-zero. Returns (N,) bool: every root strictly inside the unit circle."""
    a = np.array(coeffs, dtype=np.float64, ndmin=2)
    if not np.all(np.isfinite(a)):
        raise ValueError("coeffs: need finite coefficients")
    n = a.shape[1] - 1
    a = a * np.where(a[:, :1] < 0, -1.0, 1.0)
    ok = a[:, 0] > 0
    if n == 0:
        return ok
    ok &= a.sum(axis=1) > 0
    alt = (-1.0) ** (n - np.arange(n + 1))
    ok &= (-1.0) ** n * (a @ alt) > 0
    row = a[:, ::-1]  # a_0 .. a_n
    ok &= np.abs(row[:, 0]) < row[:, -1]
    while row.shape[1] > 3:
        m = row.shape[1] - 1
        b = row[:, :1] * row[:, :m] - row[:, -1:] * row[:, m:0:-1]
        ok &= np.abs(b[:, 0]) > np.abs(b[:, -1])
        # rescale each row (the roots are unchanged) so long tables cannot over/underflow
        scale = np.max(np.abs(b), axis=1, keepdims=True)
        row = b / np.where(scale > 0, scale, 1.0)
    return ok


def _gc_coeffs(cp, ci, cd, T, has_i: bool, has_d: bool):
    """(num (N, k), den (k',)) of G_C for gain arrays that share the same structure."""
    if has_i and has_d:
        num = np.stack([cp * T + ci * T * T + cd, -cp * T - 2.0 * cd, cd], axis=1)
        return num, np.array([T, -T, 0.0])
    if has_d:
        return np.stack([cp * T + cd, -cd], axis=1), np.array([T, 0.0])
    if has_i:
        return np.stack([cp + ci * T, -cp], axis=1), np.array([1.0, -1.0])
    return cp[:, None].copy(), np.array([1.0])


def _cc_polys(model: AxisModel, kp, cp, ci, cd, M, delay) -> np.ndarray:
    """Vectorised :func:`cc_characteristic` over broadcast gain arrays: (N, deg + 1), each row
    padded with trailing zeros to the widest (extra roots at z = 0 leave Jury's verdict as
    it is)."""
    kp, cp, ci, cd = (
        np.ascontiguousarray(a, dtype=np.float64)
        for a in np.broadcast_arrays(*(np.ravel(np.asarray(g, float)) for g in (kp, cp, ci, cd)))
    )
    T = model.servo_period_s
    A = np.polymul([1.0, -1.0], [1.0, -model.r])
    if delay:
        A = np.polymul(A, [1.0, 0.0])
    B0, B1 = model.H1, model.H0
    N = kp.size
    out = np.zeros((N, A.size + 2))
    if float(M) == 0.0:
        out[:, : A.size] = A
        out[:, A.size - 2] += kp * B0
        out[:, A.size - 1] += kp * B1
        return out
    has_i, has_d = ci != 0.0, cd != 0.0
    for hi in (False, True):
        for hd in (False, True):
            sel = (has_i == hi) & (has_d == hd)
            if not np.any(sel):
                continue
            num, den = _gc_coeffs(cp[sel], ci[sel], cd[sel], T, hi, hd)
            X = kp[sel, None] * den[None, :] + float(M) * num  # K_P den + M num
            p = np.zeros((X.shape[0], A.size + den.size - 1))
            p[:] = np.polymul(A, den)
            p[:, -X.shape[1] - 1 : -1] += B0 * X
            p[:, -X.shape[1] :] += B1 * X
            out[sel, : p.shape[1]] = p
    return out


def cc_stable(models: Sequence[AxisModel], kp, cp, ci, cd, *, delay=False, m_values=M_VALUES):
    """Jury verdict of eq. (16) for every axis and every M in ``m_values`` at broadcast gain
    arrays: returns ``(common, per_axis)`` with ``common`` (N,) bool (stable on every axis for
    every M: the paper's common range) and ``per_axis`` (n_axes, N)."""
    per_axis = []
    for mdl in models:
        ok = None
        for M in m_values:
            v = jury_stable_batch(_cc_polys(mdl, kp, cp, ci, cd, M, delay))
            ok = v if ok is None else ok & v
        per_axis.append(ok)
    per_axis = np.array(per_axis)
    return np.all(per_axis, axis=0), per_axis


# --------------------------------------------------------------------------- regions (Fig. 4)


def _row_intervals(grid, ok, verdict, iterations: int = 26) -> list[list[list[float]]]:
    """Per row of ``ok`` (rows, n_grid), the runs of stable grid points as [lo, hi] intervals,
    each edge refined by bisection with the vectorised ``verdict(rows, cp) -> bool``; an edge
    that reaches the end of the grid is None (not bounded inside the grid)."""
    out: list[list[list[float | None]]] = [[] for _ in range(ok.shape[0])]
    edges = []  # (row, run, side, inside value, outside value)
    for r in range(ok.shape[0]):
        idx = np.flatnonzero(ok[r])
        if idx.size == 0:
            continue
        for q, run in enumerate(np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1)):
            out[r].append(
                [
                    None if run[0] == 0 else float(grid[run[0]]),
                    None if run[-1] == grid.size - 1 else float(grid[run[-1]]),
                ]
            )
            for side, (a, b) in enumerate(((run[0], run[0] - 1), (run[-1], run[-1] + 1))):
                if 0 <= b < grid.size:
                    edges.append((r, q, side, float(grid[a]), float(grid[b])))
    if edges:
        rows = np.array([e[0] for e in edges])
        a = np.array([e[3] for e in edges])
        b = np.array([e[4] for e in edges])
        for _ in range(iterations):
            mid = 0.5 * (a + b)
            good = verdict(rows, mid)
            a = np.where(good, mid, a)
            b = np.where(good, b, mid)
        for (r, q, side, *_), x in zip(edges, 0.5 * (a + b), strict=True):
            out[r][q][side] = float(x)
    return out


def _auto_ranges(models, kp, second, fixed, delay, m_values):
    """Grid spans that hold the common region: C_P from −1.25 K_P, the second gain from 0, both
    to 1.15 × the largest stable value of a coarse scan, the scan widened (×2, up to 8 times)
    while the region reaches its edge."""
    cp_hi, s_hi = 20.0, (200.0 if second == "ci" else 0.2)
    for _ in range(8):
        cps = np.linspace(-1.25 * kp, cp_hi, 161)
        ss = np.linspace(0.0, s_hi, 101)
        CP, SS = np.meshgrid(cps, ss)
        ci = SS if second == "ci" else np.full_like(SS, fixed)
        cd = SS if second == "cd" else np.full_like(SS, fixed)
        ok = cc_stable(models, kp, CP, ci, cd, delay=delay, m_values=m_values)[0]
        ok = ok.reshape(CP.shape)
        if not ok.any():
            return (-1.25 * kp, cp_hi), (0.0, s_hi)
        cmax, smax = float(np.max(CP[ok])), float(np.max(SS[ok]))
        grow_c, grow_s = cmax >= cps[-2], smax >= ss[-2]
        if not (grow_c or grow_s):
            break
        cp_hi *= 2.0 if grow_c else 1.0
        s_hi *= 2.0 if grow_s else 1.0
    step_c, step_s = cps[1] - cps[0], ss[1] - ss[0]
    return (-1.25 * kp, 1.15 * (cmax + step_c)), (0.0, 1.15 * (smax + step_s))


def cross_coupling_region(
    models: Sequence[AxisModel],
    kp: float,
    *,
    second: str = "ci",
    second_values=None,
    fixed: float = 0.0,
    cp_values=None,
    delay: bool = False,
    m_values=M_VALUES,
    n_grid: tuple[int, int] = (161, 81),
) -> dict:
    """Stable region of the cross-coupling gains at a fixed K_P (Jee Figs. 4a/4b).

    ``second = "ci"``: the (C_P, C_I) plane with C_D = ``fixed`` (Fig. 4a); ``"cd"``: the
    (C_P, C_D) plane with C_I = ``fixed`` (Fig. 4b). Jury on eq. (16) for every axis and
    M ∈ ``m_values``; the common region is the intersection over the axes. Default grids span
    the region found on a coarse scan (``n_grid`` = (C_P points, second-gain points)).

    Returns a JSON-ready dict: ``kp``, ``second_gain``, ``fixed_gain``, ``delay``,
    ``m_values``, ``cp_values``, ``second_values``, ``cp_intervals`` (per second value, the
    stable C_P intervals [lo, hi] of the common region, edges refined by bisection, None where
    the region runs past the grid; [] where none) and ``cp_intervals_per_axis`` (the same per
    axis; per-axis regions may run past the common region's grid).
    """
    if second not in ("ci", "cd"):
        raise ValueError(f"second: 'ci' (Fig. 4a) or 'cd' (Fig. 4b), got {second!r}")
    kp = float(kp)
    if cp_values is None or second_values is None:
        (c0, c1), (s0, s1) = _auto_ranges(models, kp, second, fixed, delay, m_values)
        if cp_values is None:
            cp_values = np.linspace(c0, c1, n_grid[0])
        if second_values is None:
            second_values = np.linspace(s0, s1, n_grid[1])
    cpv = np.asarray(cp_values, dtype=np.float64)
    sv = np.asarray(second_values, dtype=np.float64)
    CP, S = np.meshgrid(cpv, sv)

    def gains(cp, s):
        if second == "ci":
            return cp, s, np.full_like(s, fixed)
        return cp, np.full_like(s, fixed), s

    common, per_axis = cc_stable(models, kp, *gains(CP, S), delay=delay, m_values=m_values)
    common = common.reshape(S.shape)
    per_axis = per_axis.reshape(len(models), *S.shape)

    def verdict_for(sel):
        ms = [models[i] for i in sel]
        return lambda rows, cp: cc_stable(
            ms, kp, *gains(cp, sv[rows]), delay=delay, m_values=m_values
        )[0]

    return {
        "kp": kp,
        "second_gain": "C_I" if second == "ci" else "C_D",
        "fixed_gain": {"C_D" if second == "ci" else "C_I": float(fixed)},
        "delay": bool(delay),
        "m_values": [float(m) for m in m_values],
        "cp_values": cpv.tolist(),
        "second_values": sv.tolist(),
        "cp_intervals": _row_intervals(cpv, common, verdict_for(range(len(models)))),
        "cp_intervals_per_axis": {
            models[a].name: _row_intervals(cpv, per_axis[a], verdict_for([a]))
            for a in range(len(models))
        },
    }


# --------------------------------------------------------------------------- steady state


def _omega(radius_m, feedrate_m_s) -> float:
    return float(_check_circle(radius_m, [feedrate_m_s])[0]) / float(radius_m)


def steady_state_cc_matched(
    model: AxisModel,
    kp,
    cp,
    ci,
    cd,
    radius_m: float,
    feedrate_m_s: float,
    *,
    delay: bool = False,
    d_iterations: int = 200,
) -> dict:
    """Steady state on a circle of the matched system built from ``model`` (all axes alike),
    vectorised over broadcast gain arrays. Plane-independent (the matched loop is invariant
    under rotations).

    Returns arrays (m): ``contour_error_m`` (|P| − R0, signed: > 0 outside) and
    ``tracking_error_m`` (‖E‖) of the controller law ε = Π E (exact), the same from the
    paper's eq. (21) with d from eq. (32) (``eq21_contour_error_m``, ``eq21_tracking_error_m``,
    ``eq21_lag_steps_d``), and ``lag_steps_d`` of the controller law's orbit."""
    T = model.servo_period_s
    R0 = float(radius_m)
    w = _omega(radius_m, feedrate_m_s)
    z = np.exp(1j * w * T)
    g = _axis_response(model, z, delay)
    kp, cp, ci, cd = np.broadcast_arrays(
        *(np.asarray(a, dtype=np.float64) for a in (kp, cp, ci, cd))
    )
    c = gc_response(cp, ci, cd, T, z)
    # controller law, frame of the reference point (radial = real, tangential = imaginary):
    # E (1 + g K_P) + g G_C Re{E} = R0
    alpha = 1.0 + g * kp + g * c
    beta = 1.0 + g * kp
    det = alpha.real * beta.real + alpha.imag * beta.imag
    E = R0 * (beta.real - 1j * alpha.imag) / det
    P = R0 - E
    # eq. (21) with eq. (32): d = −∠H / (ωT), fixed point from the P-loop lag
    H = g * kp / (1.0 + g * kp)
    d = -np.angle(H) / (w * T)
    for _ in range(int(d_iterations)):
        H = g * (kp + np.exp(-1j * w * T * d) * c) / (1.0 + g * (kp + c))
        d_new = -np.angle(H) / (w * T)
        done = np.all(np.abs(d_new - d) <= 1e-12 * np.maximum(1.0, np.abs(d)))
        d = d_new
        if done:
            break
    return {
        "omega_rad_s": w,
        "contour_error_m": np.abs(P) - R0,
        "tracking_error_m": np.abs(E),
        "lag_steps_d": -np.angle(P) / (w * T),
        "eq21_contour_error_m": R0 * (np.abs(H) - 1.0),
        "eq21_tracking_error_m": R0 * np.abs(1.0 - H),
        "eq21_lag_steps_d": d,
    }


def _odd_harmonics(harmonics: int) -> np.ndarray:
    h = np.arange(1, 2 * int(harmonics), 2)
    return np.concatenate([-h[::-1], h])


def _harmonic_balance(models, kp, cp, ci, cd, radius_m, omega, u, v, delay, harmonics):
    """Steady state of E = R − G (K_P E + G_C Π(k) E) on the circle, over the odd harmonics,
    vectorised over broadcast gain arrays (P points).

    Returns (S, Ehat (P, H, n), Uhat (P, H, n), epshat (P, H, n)): signals
    ``Σ_m X_m e^{jmωkT}``."""
    n = len(models)
    T = models[0].servo_period_s
    kp, cp, ci, cd = np.broadcast_arrays(
        *(np.ravel(np.asarray(a, float)) for a in (kp, cp, ci, cd))
    )
    npt = kp.size
    S = _odd_harmonics(harmonics)
    H = S.size
    zs = np.exp(1j * S * omega * T)
    G = np.array([[_axis_response(m, z, delay) for m in models] for z in zs])  # (H, n)
    C = gc_response(cp[:, None], ci[:, None], cd[:, None], T, zs[None, :])  # (P, H)
    w = v + 1j * u
    Pi = {0: np.eye(n) - 0.5 * (np.outer(u, u) + np.outer(v, v)), 2: -0.25 * np.outer(w, w)}
    Pi[-2] = np.conj(Pi[2])
    pos = {int(m): i for i, m in enumerate(S)}
    links = [
        (i, j, shift)
        for i, m in enumerate(S)
        for shift in (0, 2, -2)
        if (j := pos.get(int(m) - shift)) is not None
    ]  # ε_m = Π0 E_m + Π2 E_{m−2} + Π−2 E_{m+2}
    A = np.zeros((npt, H * n, H * n), dtype=complex)
    for i in range(H):
        r = slice(i * n, (i + 1) * n)
        A[:, r, r] += np.eye(n) + kp[:, None, None] * np.diag(G[i])
    for i, j, shift in links:
        blk = np.diag(G[i]) @ Pi[shift]
        A[:, i * n : (i + 1) * n, j * n : (j + 1) * n] += C[:, i, None, None] * blk
    R0 = float(radius_m)
    rhs = np.zeros((H * n,), dtype=complex)
    rhs[pos[1] * n : (pos[1] + 1) * n] = 0.5 * R0 * (u - 1j * v)
    rhs[pos[-1] * n : (pos[-1] + 1) * n] = 0.5 * R0 * (u + 1j * v)
    rhs = np.broadcast_to(rhs, (npt, H * n))[..., None]
    Ehat = np.linalg.solve(A, rhs)[..., 0].reshape(npt, H, n)
    eps = np.zeros_like(Ehat)
    for i, j, shift in links:
        eps[:, i] += Ehat[:, j] @ Pi[shift].T
    Uhat = kp[:, None, None] * Ehat + C[:, :, None] * eps
    return S, Ehat, Uhat, eps


def _orbit_errors(S, Ehat, radius_m, u, v, n_phase):
    """(contour (P,), tracking (P,)): max over the orbit of the distance of P = R − E to the
    circle and of ‖E‖."""
    npt, H, n = Ehat.shape
    theta = np.linspace(0.0, 2.0 * np.pi, int(n_phase), endpoint=False)
    ang = np.outer(theta, S)
    X = Ehat.transpose(1, 0, 2).reshape(H, npt * n)
    E = (np.cos(ang) @ X.real - np.sin(ang) @ X.imag).reshape(theta.size, npt, n)
    R0 = float(radius_m)
    Eu, Ev = E @ u, E @ v  # (n_phase, P): in-plane parts of E
    E2 = np.sum(E * E, axis=2)
    pu = R0 * np.cos(theta)[:, None] - Eu  # P = R − E in the plane's coordinates
    pv = R0 * np.sin(theta)[:, None] - Ev
    out2 = np.maximum(E2 - Eu**2 - Ev**2, 0.0)  # out of the plane (R has no such part)
    contour = np.sqrt((np.hypot(pu, pv) - R0) ** 2 + out2)
    return np.max(contour, axis=0), np.sqrt(np.max(E2, axis=0))


def steady_state_cc_circle(
    models: Sequence[AxisModel],
    kp: float,
    cp: float,
    ci: float,
    cd: float,
    radius_m: float,
    feedrate_m_s: float,
    plane="xy",
    *,
    delay: bool = False,
    harmonics: int = 4,
    n_phase: int = 4096,
) -> dict:
    """Steady state of the controller law (ε = Π(k) E, the projection turning with the path)
    on a circle in ``plane`` for the axes ``models`` (mismatched allowed), by harmonic balance
    over the odd harmonics ±1 … ±(2·harmonics − 1) of ω = F/R.

    Returns ``contour_error_m`` (max over the orbit of the true distance to the circle),
    ``tracking_error_m`` (max ‖R − P‖), ``omega_rad_s``, ``harmonic_residual`` (the share of
    the highest harmonic kept in E: the truncation error's size) and, per axis, the paper's
    matched eq. (21) prediction (``eq21``, worst over the axes in the plane)."""
    u, v = _circle_basis(plane, len(models))
    w = _omega(radius_m, feedrate_m_s)
    S, Ehat, _, _ = _harmonic_balance(
        models, kp, cp, ci, cd, radius_m, w, u, v, delay, max(1, int(harmonics))
    )
    contour, tracking = _orbit_errors(S, Ehat, radius_m, u, v, n_phase)
    Ehat = Ehat[0]
    top = np.abs(S) == np.max(np.abs(S))
    in_plane = [i for i in range(len(models)) if abs(u[i]) + abs(v[i]) > 1e-12]
    eq21 = [
        steady_state_cc_matched(models[i], kp, cp, ci, cd, radius_m, feedrate_m_s, delay=delay)
        for i in in_plane
    ]
    return {
        "omega_rad_s": w,
        "contour_error_m": float(contour[0]),
        "tracking_error_m": float(tracking[0]),
        "harmonic_residual": float(np.linalg.norm(Ehat[top]) / max(np.linalg.norm(Ehat), 1e-300)),
        "eq21_contour_error_m": float(max(abs(float(p["eq21_contour_error_m"])) for p in eq21)),
        "eq21_tracking_error_m": float(max(float(p["eq21_tracking_error_m"]) for p in eq21)),
        "eq21_lag_steps_d": {
            models[i].name: float(p["eq21_lag_steps_d"])
            for i, p in zip(in_plane, eq21, strict=True)
        },
    }


# --------------------------------------------------------------------------- simulation


def _zoh_axis(mass: float, viscous: float, T: float):
    A = np.array([[0.0, 1.0], [0.0, -viscous / mass]])
    Bm = np.array([[0.0], [1.0 / mass]])
    Phi, Gam, *_ = signal.cont2discrete((A, Bm, np.eye(2), np.zeros((2, 1))), T, method="zoh")
    return Phi, Gam[:, 0]


def simulate_cc_circle(
    plant,
    kp: float,
    cp: float,
    ci: float,
    cd: float,
    radius_m: float,
    feedrates_m_s: Sequence[float],
    plane="xy",
    *,
    settle_tol: float = 1e-4,
    max_settle_s: float = 8.0,
    warm_start: bool = True,
    **plant_kw,
) -> list[dict]:
    """Simulated steady-state contour and tracking error of the cross-coupling law on a circle.

    The law of ``agents.jee_ccc`` (``JeeCCCController.act``): ``E = r_k − x_k``,
    ``ε = E − (tᵀE) t`` with t the tangent of the reference point, the running sum
    ``s += ε T`` and ``u = K_P E + C_P ε + C_I s + C_D (ε − ε_prev)/T``, on ``plant``
    (``ideal=True`` unless told otherwise; saturation lifted, exact position fed back). One env
    per feedrate; each starts on the harmonic-balance orbit of the plant's true linear part
    (a warm start only), runs until the slowest frozen closed-loop root has decayed to
    ``settle_tol`` (at most ``max_settle_s``), and is scored over its last revolution (max true
    distance to the circle, max ‖r − x‖). An env whose error passes 100 R is stopped and
    marked ``diverged``. ``warm_start=False``: start at rest on the circle's first point with
    the controller's states at zero (a cold start, for checking the warm start biases nothing).
    """
    base = _make_plant(plant, plant_kw)
    sim = _linear_sim_plant(base)
    true = _true_models(base)
    delay = bool(base.params.computation_delay)
    n_ax = sim.n_axes
    u, v = _circle_basis(plane, n_ax)
    T = sim.servo_period_s
    F = _check_circle(radius_m, feedrates_m_s)
    R0 = float(radius_m)
    omegas = F / R0
    n_settle, rho = _settle_steps(true, kp, cp, ci, cd, delay, T, settle_tol, max_settle_s)
    n_rev = np.maximum(1, np.round(2.0 * np.pi / (omegas * T)).astype(np.int64))
    n = n_settle + int(np.max(n_rev))
    B = F.size
    state = sim.initial_state(np.zeros((B, n_ax)))
    s_sum = np.zeros((B, n_ax))
    prev = np.zeros((B, n_ax))
    if warm_start:
        _cc_warm_start(state, prev, s_sum, true, kp, cp, ci, cd, R0, omegas, u, v, delay, T)
    else:
        state = sim.initial_state(np.broadcast_to(R0 * u, (B, n_ax)))
    active, contour, tracking = _run_cc_circle(
        sim, state, s_sum, prev, kp, cp, ci, cd, R0, omegas, u, v, n, n_rev
    )
    out = []
    for b in range(B):
        ok = bool(active[b])
        out.append(
            {
                "feedrate_m_s": float(F[b]),
                "diverged": not ok,
                "contour_error_m": float(contour[b]) if ok else None,
                "tracking_error_m": float(tracking[b]) if ok else None,
                "settle_steps": n_settle,
                "revolution_steps": int(n_rev[b]),
                "max_frozen_root": rho,
            }
        )
    return out


def _settle_steps(true, kp, cp, ci, cd, delay, T, settle_tol, max_settle_s) -> tuple[int, float]:
    """(steps for the slowest frozen closed-loop root of the law on the axes ``true`` to
    decay to ``settle_tol``, at most ``max_settle_s`` and at least one; that root's modulus)."""
    rho = 0.0
    for mdl in true:
        for M in M_VALUES:
            rho = max(
                rho,
                float(np.max(np.abs(np.roots(cc_characteristic(mdl, kp, cp, ci, cd, M, delay))))),
            )
    if rho < 1.0:
        n_settle = int(
            min(math.ceil(math.log(settle_tol) / math.log(max(rho, 1e-12))), max_settle_s / T)
        )
    else:
        n_settle = int(max_settle_s / T)
    return max(n_settle, 1), rho


def _cc_warm_start(state, prev, s_sum, true, kp, cp, ci, cd, R0, omegas, u, v, delay, T) -> None:
    """Puts each env b of ``state`` (and the law's ``prev`` ε and running sum ``s_sum``) on
    the harmonic-balance orbit of the axes ``true`` at ω = omegas[b]."""
    zoh = [_zoh_axis(m.mass, m.viscous, T) for m in true]
    for b in range(omegas.size):
        S, Ehat, Uhat, eps = (
            x if i == 0 else x[0]
            for i, x in enumerate(
                _harmonic_balance(true, kp, cp, ci, cd, R0, omegas[b], u, v, delay, 4)
            )
        )
        zs = np.exp(1j * S * omegas[b] * T)
        back = 1.0 / zs  # one period earlier
        for a, (Phi, Gam) in enumerate(zoh):
            X = sum(
                np.linalg.solve(z * np.eye(2) - Phi, Gam * Uhat[i, a] * (1.0 / z if delay else 1.0))
                for i, z in enumerate(zs)
            )
            state.z[b, a, 0], state.z[b, a, 1] = X.real
            if state.z.shape[2] >= 4:  # two-mass layout: motor side moves with the load
                state.z[b, a, 2], state.z[b, a, 3] = X.real
        if delay:
            state.u_pending[b] = np.real(back @ Uhat)
        prev[b] = np.real(back @ eps)
        s_sum[b] = np.real((back * T * zs / (zs - 1.0)) @ eps)


def _run_cc_circle(sim, state, s_sum, prev, kp, cp, ci, cd, R0, omegas, u, v, n, n_rev) -> tuple:
    """Runs the law for ``n`` steps on the circle, one env per ω in ``omegas``: (whether each
    env stayed within 100 R, its max true distance to the circle and max ‖r − x‖ over its
    last ``n_rev`` steps)."""
    B = omegas.size
    T = sim.servo_period_s
    packed = sim.packed_batch(B)
    ks = np.arange(n)
    th = np.outer(ks * T, omegas)  # (n, B)
    bound = 100.0 * R0
    active = np.ones(B, dtype=bool)
    contour = np.zeros(B)
    tracking = np.zeros(B)
    for k in range(n):
        c, s = np.cos(th[k])[:, None], np.sin(th[k])[:, None]
        ref = R0 * (c * u + s * v)
        tan = -s * u + c * v
        E = ref - state.position
        active &= np.all(np.abs(E) <= bound, axis=1)
        if not np.any(active):
            break
        eps = E - np.sum(tan * E, axis=1, keepdims=True) * tan
        s_sum += eps * T
        cmd = kp * E + cp * eps + ci * s_sum + cd * (eps - prev) / T
        prev = eps
        cmd = np.where(active[:, None], cmd, 0.0)
        in_window = k >= n - n_rev
        if np.any(in_window):
            d = _distance_to_circle(state.position, R0, u, v)
            contour = np.where(in_window, np.maximum(contour, d), contour)
            tracking = np.where(
                in_window, np.maximum(tracking, np.linalg.norm(E, axis=1)), tracking
            )
        new, _ = sim.step(state, cmd, k * T, packed)
        new.z[~active] = state.z[~active]
        state = new
    return active, contour, tracking


# --------------------------------------------------------------------------- loop margins


def _margins_from_response(L: np.ndarray):
    """(gain margin dB, phase margin deg) of sampled loop responses L (P, W), the worst
    crossing of each (linear interpolation between samples); +inf where there is none. The
    gain margin is the factor the gain may rise by (crossings of the negative real axis where
    |L| < 1), as ``agents.margins``."""
    mag = np.abs(L)
    gm = np.full(L.shape[0], np.inf)
    pm = np.full(L.shape[0], np.inf)
    # gain crossovers |L| = 1
    f = np.log(np.maximum(mag, 1e-300))
    i_p, i_w = np.nonzero(np.sign(f[:, :-1]) * np.sign(f[:, 1:]) < 0)
    if i_p.size:
        a = f[i_p, i_w] / (f[i_p, i_w] - f[i_p, i_w + 1])
        ph0 = np.angle(L[i_p, i_w])
        dph = np.angle(L[i_p, i_w + 1] / L[i_p, i_w])
        ph = np.degrees(ph0 + a * dph)
        m = (ph + 180.0) % 360.0
        m = np.where(m > 180.0, m - 360.0, m)
        np.minimum.at(pm, i_p, m)
    # phase crossovers on the negative real axis
    im = L.imag
    i_p, i_w = np.nonzero(np.sign(im[:, :-1]) * np.sign(im[:, 1:]) < 0)
    if i_p.size:
        a = im[i_p, i_w] / (im[i_p, i_w] - im[i_p, i_w + 1])
        x = L[i_p, i_w] + a * (L[i_p, i_w + 1] - L[i_p, i_w])
        keep = (x.real < 0) & (np.abs(x) < 1.0)
        g = -20.0 * np.log10(np.maximum(np.abs(x[keep]), 1e-300))
        np.minimum.at(gm, i_p[keep], g)
    return gm, pm


def siso_margins_grid(
    plant="jee-triaxial",
    kp=1.0,
    cp=0.0,
    ci=None,
    cd=None,
    *,
    realistic: bool = True,
    mass_corners=MASS_CORNERS,
    n_omega: int = 800,
    **plant_kw,
) -> dict:
    """Per-axis SISO estimate of the loop margins over broadcast gain arrays (C_I, C_D default
    to the paper's ratios): on the simulated plant's linear part (true m, b; the delay if it
    has one) with every mass scaled by each of ``mass_corners``, the tangential loop
    ``K_P g(z)`` and the normal loop ``(K_P + G_C(z)) g(z)`` of each axis (a matched loop along
    and across the path). Returns arrays ``gain_margin_db``, ``phase_margin_deg`` (worst over
    axes, corners and both loops; +inf when a loop has no crossing) and ``stable`` (Jury on the
    same corners). ``agents.margins.loop_margins`` is the full MIMO check (loop-at-a-time,
    path directions)."""
    base = _design_plant(plant, realistic, plant_kw)
    kp, cp = np.broadcast_arrays(*(np.asarray(a, dtype=np.float64) for a in (kp, cp)))
    shape = kp.shape
    kp, cp = kp.ravel(), cp.ravel()
    ci = CI_RATIO * cp if ci is None else np.broadcast_to(np.asarray(ci, float), shape).ravel()
    cd = CD_RATIO * cp if cd is None else np.broadcast_to(np.asarray(cd, float), shape).ravel()
    delay = bool(base.params.computation_delay)
    T = base.servo_period_s
    omega = np.logspace(-1.0, math.log10(math.pi / T * (1 - 1e-4)), int(n_omega))
    z = np.exp(1j * omega * T)
    C = gc_response(cp[:, None], ci[:, None], cd[:, None], T, z[None, :])
    gm = np.full(kp.size, np.inf)
    pm = np.full(kp.size, np.inf)
    stable = np.ones(kp.size, dtype=bool)
    ku, k_inv = np.unique(kp, return_inverse=True)
    for scale in mass_corners:
        models = [
            AxisModel.from_mass_viscous(m.name, m.mass * scale, m.viscous, T)
            for m in _true_models(base)
        ]
        stable &= cc_stable(models, kp, cp, ci, cd, delay=delay)[0]
        for mdl in models:
            g = _axis_response(mdl, z, delay)
            a, b = _margins_from_response(ku[:, None] * g[None, :])  # tangential
            gm = np.minimum(gm, a[k_inv])
            pm = np.minimum(pm, b[k_inv])
            a, b = _margins_from_response((kp[:, None] + C) * g[None, :])  # normal
            gm = np.minimum(gm, a)
            pm = np.minimum(pm, b)
    return {
        "gain_margin_db": gm.reshape(shape),
        "phase_margin_deg": pm.reshape(shape),
        "stable": stable.reshape(shape),
        "delay": delay,
        "mass_corners": list(mass_corners),
    }
