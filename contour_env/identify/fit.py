"""The output-error fit of :mod:`contour_env.identify`: the parameter vector's start, bounds and
scales, the least-squares problem (:func:`_fit`, the Cauchy loss), the ranking of periodic
force candidates, the grid over the friction curve, and the covariance, confidence intervals
and normalised errors at the optimum."""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import least_squares

from .simulate import N_THETA, _residuals, _velocity, simulate_windows

# The loss: Cauchy, ρ(r) = c² log(1 + (r/c)²), c = LOSS_SCALE in the scaled residuals' units
# (position / RMS displacement of its window, velocity / RMS velocity): squares for residuals
# below c, a logarithm above. A window replayed open loop through the negative slope of the
# Stribeck curve (an axis the drive's loop held creeping) can run away from the record by
# millimetres on a small error of the friction curve; squared, those few windows outweigh all
# others and the fit prefers a friction curve that never breaks away (static friction too
# high, measured: +28 % on one seed of the friction table); the Cauchy loss bounds their weight.
LOSS = "cauchy"
LOSS_SCALE = 1e-3
BASE_FREE = (0, 1, 5)
FRICTION_FREE = (2, 3, 4)
DISTURBANCE_FREE = (6, 7, 8)
RIPPLE_FREE = (9, 10, 11)
FREQUENCY_INDEX = (8, 11)
GRID_WINDOWS = 100
GRID_STATIC = (0.7, 0.85, 1.0, 1.2, 1.45)  # × the current static friction
GRID_EXCESS = (0.0, 0.15, 0.3, 0.45, 0.6)  # (static − Coulomb) / static
GRID_STRIBECK_POINTS = 10  # Stribeck velocities, log-spaced over the trace's speeds


def _rank_periodic(ua, win, T, theta, cands: dict) -> dict:
    """The best candidate of each kind by the output error: for each, the residual's
    least-squares reduction by a small sine and cosine amplitude at its frequency (the
    simulated response to each, one batch); {kind: (c_s, c_c, frequency)} of those that reduce
    the cost, with the fitted amplitudes."""
    eps = 1e-3 * float(np.max(np.abs(ua))) + 1e-12
    sets, owners = [theta.copy()], []
    slots = {"disturbance": (6, 7, 8), "ripple": (9, 10, 11)}
    for kind, found in cands.items():
        i_s, i_c, i_f = slots[kind]
        for cand in found:
            for col in (i_s, i_c):
                th = theta.copy()
                th[[i_s, i_c]] = 0.0
                th[i_f] = cand[2]
                th[col] = eps
                sets.append(th)
            owners.append((kind, cand))
    if not owners:
        return {}
    base = theta.copy()
    for kind in cands:
        i_s, i_c, _ = slots[kind]
        base[[i_s, i_c]] = 0.0
    sets[0] = base
    xs, _ = simulate_windows(np.array(sets), ua, win, T)
    r = _residuals(xs, win, T)
    r0 = r[0]
    best: dict = {}
    for n_, (kind, cand) in enumerate(owners):
        J = np.stack([(r[1 + 2 * n_] - r0) / eps, (r[2 + 2 * n_] - r0) / eps], axis=1)
        c, *_ = np.linalg.lstsq(J, -r0, rcond=None)
        gain = float(r0 @ r0 - np.sum((r0 + J @ c) ** 2))
        if gain > 0 and (kind not in best or gain > best[kind][0]):
            best[kind] = (gain, (float(c[0]), float(c[1]), cand[2]))
    return {kind: v for kind, (_, v) in best.items()}


def _start_of(theta5, T) -> np.ndarray:
    """A full parameter vector from the regression's five (lag 0.3 T, no periodic force)."""
    th0 = np.zeros(N_THETA)
    th0[:5] = theta5
    th0[1:4] = np.maximum(th0[1:4], 0.0)
    th0[5] = 0.3 * T
    return th0


def _bounds_scale(theta0, T, umax, vmax):
    m0 = max(theta0[0], 1e-6)
    lo = np.full(N_THETA, -np.inf)
    hi = np.full(N_THETA, np.inf)
    lo[:6] = [m0 * 1e-2, 0.0, 0.0, 0.0, 1e-6, 1e-3 * T]
    hi[:6] = [m0 * 1e2, np.inf, umax, umax, min(10.0, 10 * vmax + 1e-6), 20 * T]
    lo[[6, 7, 9, 10]] = -umax
    hi[[6, 7, 9, 10]] = umax
    # the disturbance's frequency is well resolved by the scan (a trace lasts many periods),
    # the ripple's wavenumber less so (a stroke spans a few periods)
    lo[8], hi[8] = 0.9 * theta0[8], 1.1 * theta0[8] + 1e-300
    lo[11], hi[11] = 0.6 * theta0[11], 1.6 * theta0[11] + 1e-300
    amp = max(1e-3 * umax, 1e-12)
    scale = np.array(
        [
            max(theta0[0], 1e-9),
            max(theta0[1], 1e-3 * umax / max(vmax, 1e-9), 1e-12),
            max(theta0[2], 1e-3 * umax),
            max(theta0[3], 1e-3 * umax),
            max(theta0[4], 1e-9),
            T,
            max(abs(theta0[6]), amp),
            max(abs(theta0[7]), amp),
            max(theta0[8], 1e-9),
            max(abs(theta0[9]), amp),
            max(abs(theta0[10]), amp),
            max(theta0[11], 1e-9),
        ]
    )
    return lo, hi, scale


class _Problem:
    """Least squares in scaled parameters p = θ / scale over the free ones."""

    def __init__(self, ua, win, T, theta0, free, scale):
        self.ua, self.win, self.T = ua, win, T
        self.theta0 = theta0.copy()
        self.free = np.asarray(free)
        self.scale = scale
        self._cache: dict = {}

    def theta(self, p):
        th = self.theta0.copy()
        th[self.free] = p * self.scale[self.free]
        return th

    def _eval(self, thetas):
        xs, _ = simulate_windows(thetas, self.ua, self.win, self.T)
        return _residuals(xs, self.win, self.T)

    def fun(self, p):
        key = p.tobytes()
        if key not in self._cache:
            self._cache = {key: self._eval(self.theta(p)[None])[0]}
        return self._cache[key]

    def jac(self, p):
        rel = np.where(np.isin(self.free, FREQUENCY_INDEX), 1e-6, 1e-3)
        steps = rel * np.maximum(np.abs(p), 1e-2)
        sets = [self.theta(p)]
        for j in range(len(p)):
            q = p.copy()
            q[j] += steps[j]
            sets.append(self.theta(q))
        r = self._eval(np.array(sets))
        self._cache = {p.tobytes(): r[0]}
        return ((r[1:] - r[0]) / steps[:, None]).T


def _fit(ua, win, T, theta0, free, max_nfev):
    """least_squares from theta0 (N_THETA,) over the ``free`` indices on the windows;
    returns (θ, result, problem)."""
    free = sorted(free)
    umax = float(np.max(np.abs(ua)))
    vmax = float(np.max(np.abs(win.v)))
    lo, hi, scale = _bounds_scale(theta0, T, umax, vmax)
    th = theta0.copy()
    th[free] = np.clip(theta0[free], lo[free], hi[free])
    prob = _Problem(ua, win, T, th, free, scale)
    res = least_squares(
        prob.fun,
        th[free] / scale[free],
        jac=prob.jac,
        bounds=(lo[free] / scale[free], hi[free] / scale[free]),
        method="trf",
        x_scale=1.0,
        max_nfev=max_nfev,
        xtol=1e-8,
        ftol=1e-10,
        loss=LOSS,
        f_scale=LOSS_SCALE,
    )
    return prob.theta(res.x), res, prob


def _robust_cost(r: np.ndarray) -> np.ndarray:
    """The cost least_squares minimises (``LOSS``, ``LOSS_SCALE``) of residual rows (S, N)."""
    c = LOSS_SCALE
    return 0.5 * c**2 * np.sum(np.log1p((r / c) ** 2), axis=-1)


def _covariance(res, prob) -> np.ndarray:
    """cov(θ_free) = s² (JᵀJ)⁻¹ from the Jacobian at the optimum (inf where singular)."""
    J = res.jac / prob.scale[prob.free][None, :]
    n, k = J.shape
    s2 = 2.0 * res.cost / max(n - k, 1)
    try:
        return np.linalg.inv(J.T @ J) * s2
    except np.linalg.LinAlgError:
        return np.full((k, k), np.inf)


def _ci95(theta, cov, free) -> dict:
    """95 % half-widths of the reported parameters (None where not determined)."""
    free = list(free)

    def var_of(grad: dict) -> float:
        # grad: {theta index: d(quantity)/d(theta)}
        v = 0.0
        for i, gi in grad.items():
            for j, gj in grad.items():
                v += gi * gj * cov[free.index(i), free.index(j)]
        return v

    out: dict = {}
    simple = {0: "mass", 1: "viscous", 2: "coulomb", 4: "stribeck_velocity", 5: "current_loop_lag"}
    for i, name in simple.items():
        if i in free:
            out[name] = var_of({i: 1.0})
    if 3 in free:
        out["static"] = var_of({2: 1.0, 3: 1.0} if 2 in free else {3: 1.0})
    for key, (ic, js, jf) in {"disturbance": (6, 7, 8), "ripple": (9, 10, 11)}.items():
        if ic in free:
            amp = math.hypot(theta[ic], theta[js]) or 1e-300
            out[f"{key}_amplitude"] = var_of({ic: theta[ic] / amp, js: theta[js] / amp})
            out[f"{key}_frequency" if key == "disturbance" else "ripple_period"] = (
                var_of({jf: 1.0})
                if key == "disturbance"
                else var_of({jf: -2 * math.pi / theta[jf] ** 2})
            )
    return {
        k: (float(1.96 * math.sqrt(v)) if np.isfinite(v) and v >= 0 else None)
        for k, v in out.items()
    }


def _errors(xs, win, T) -> dict:
    """Normalised errors of simulated vs measured over the windows: position error RMS over
    the RMS displacement from the window's start, velocity (encoder differences) error RMS
    over the RMS velocity."""
    ep = float(np.sqrt(np.mean((xs - win.y) ** 2)) / win.sp)
    ev = float(np.sqrt(np.mean((_velocity(xs, win, T) - win.v) ** 2)) / win.sv)
    return {"position": ep, "velocity": ev}


def _stribeck_grid(ua, win, T, theta, log, axis, d) -> np.ndarray:
    """``theta`` with its friction curve (Coulomb, static, Stribeck velocity) replaced by the
    best point of a grid — the static friction scaled by GRID_STATIC, split into Coulomb and
    excess by GRID_EXCESS, the Stribeck velocity log-spaced over the windows' speeds — where
    that beats it; every other parameter kept, all points simulated in one batch."""
    fc, dfs, vs = theta[2], theta[3], theta[4]
    fs = fc + dfs
    speeds = np.abs(win.v[win.v != 0])
    v_lo = max(float(np.quantile(speeds, 0.02)) if speeds.size else 1e-5, 1e-6)
    v_hi = max(0.5 * float(np.max(np.abs(win.v))), 2 * v_lo)
    sets = [theta.copy()]
    for g in GRID_STATIC:
        for rho in GRID_EXCESS:
            for v in np.geomspace(v_lo, min(v_hi, 10.0), GRID_STRIBECK_POINTS):
                th = theta.copy()
                th[2], th[3], th[4] = g * fs * (1 - rho), g * fs * rho, v
                sets.append(th)
    xs, _ = simulate_windows(np.array(sets), ua, win, T)
    cost = _robust_cost(_residuals(xs, win, T))
    best = int(np.argmin(cost))
    if best == 0:
        return theta
    b = sets[best]
    log(
        f"  axis {axis}: delay {d}: friction grid: Coulomb {fc:.4g} → {b[2]:.4g}, static "
        f"{fs:.4g} → {b[2] + b[3]:.4g}, Stribeck velocity {vs:.4g} → {b[4]:.4g} (cost "
        f"{cost[0]:.4g} → {cost[best]:.4g})"
    )
    return b
