"""The fit of one axis (:func:`_fit_axis`), in the steps of :mod:`contour_env.identify`'s method:
the windows, the regression's start per delay, the periodic forces, the delay screening, the
friction grid, the full fits and the delay's choice, then the errors and the result."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .fit import (
    BASE_FREE,
    DISTURBANCE_FREE,
    FRICTION_FREE,
    GRID_WINDOWS,
    RIPPLE_FREE,
    _ci95,
    _covariance,
    _errors,
    _fit,
    _rank_periodic,
    _start_of,
    _stribeck_grid,
)
from .regression import _periodic_candidates, _regression_start
from .result import PARAM_NAMES, AxisFit
from .simulate import (
    _delayed,
    _derivatives,
    _residuals,
    _start_states,
    _velocity,
    _Windows,
    _windows,
    _windows_subset,
    simulate_windows,
)

MAX_WINDOW_STEPS = 400
MIN_WINDOW_STEPS = 20
SCREEN_WINDOWS = 60  # windows of the short fits of the delay search
SHORT_WINDOW_STEPS = 100  # the delay's windows, servo periods
CLOSE_DELAY = 2.0  # a delay whose cost is within this factor of the best is fitted in full
KEEP_PERIODIC = 0.95  # a periodic force is kept when it lowers the fit's cost by 5 % or more
# friction is kept when it lowers the fit's cost by 20 % or more: on the frictionless textbook
# hsm2 a friction curve lowers it by 5–6 % (a static spike below 0.5 mm/s holding dwell windows
# still that the encoder cannot tell from none), on the realistic hsm2 by 56–71 %
KEEP_FRICTION = 0.8
EXTRA = {"disturbance": DISTURBANCE_FREE, "ripple": RIPPLE_FREE}  # a periodic force's entries


@dataclass(frozen=True)
class _Axis:
    """One axis of the trace set up for the fit: its command ``u`` and position ``y``, the
    fitted part's length ``n_fit``, the window length ``H``, the smoothed velocity and start
    states, and the windows: ``wfit`` (the full fits), ``wshort`` (short, for the delay) and
    ``screen`` (a sample of the short ones, for the screening fits)."""

    source: str
    axis: str
    T: float
    time_s: np.ndarray
    u: np.ndarray
    y: np.ndarray
    n: int
    n_fit: int
    H: int
    v_sg: np.ndarray
    states: tuple
    wfit: _Windows
    wshort: _Windows
    screen: _Windows


def _fit_axis(
    trace, j, *, friction, holdout, max_delay, window_s, limit, resolution, max_fit_samples, log
):
    ax = _setup_axis(trace, j, max_delay, holdout, window_s, max_fit_samples)
    free = list(BASE_FREE) + (list(FRICTION_FREE) if friction else [])
    # initial values per delay from the regression; periodic forces the model leaves out
    # (disturbance, ripple) looked for in the residual of the best regression
    regs, d_reg = _regression_starts(ax, friction, max_delay)
    cands = _periodic_start(ax, regs, d_reg, free, log)
    free_c = free + [i for key in cands for i in EXTRA[key]]
    costs, screened, finite = _screen_delays(ax, regs, cands, free_c, max_delay, log)
    free_c = _select_periodic(ax, cands, screened, finite, free_c, log)
    if friction:
        _friction_starts(ax, screened, finite, log)
    full = _full_fits(ax, screened, finite, free_c, log)
    full_costs = {d_: float(fit_[1].cost) for d_, fit_ in full.items()}
    d = _choose_delay(ax, full, log)
    th, res, prob = full[d]
    ua = _delayed(ax.u, d)
    gain = None
    if friction:
        gain, without = _friction_gain(ax, ua, th, res, prob, log)
        if gain < 1 - KEEP_FRICTION:
            th, res, prob = without
            friction = False
    cov = _covariance(res, prob)
    ci = _ci95(th, cov, prob.free.tolist())
    fit_err, hold_err, plot = _errors_and_plot(ax, th, ua, holdout)
    fitted = ("mass", "viscous", "current_loop_lag") + (
        ("coulomb", "static", "stribeck_velocity") if friction else ()
    )
    return AxisFit(
        axis=ax.axis,
        values=_values(th),
        ci95={k: ci.get(k) for k in PARAM_NAMES if k in fitted},
        fitted=fitted,
        delay_periods=int(d),
        delay_costs={d_: (None if not math.isfinite(c) else c) for d_, c in costs.items()},
        delay_full_costs=full_costs,
        force_limit_N=float(limit),
        encoder_resolution_m=float(resolution),
        fit_error=fit_err,
        holdout_error=hold_err,
        n_windows=len(ax.wfit.starts),
        window_steps=ax.H,
        periodic=_periodic_found(th, prob, ci),
        plot=plot,
        friction_cost_reduction=gain,
    )


def _friction_gain(ax: _Axis, ua, th, res, prob, log):
    """(share of the fit's cost the friction curve removes, the fit without friction): the
    model refitted from ``th`` with Coulomb and static friction at zero and not free."""
    th0 = th.copy()
    th0[list(FRICTION_FREE[:2])] = 0.0  # Coulomb, static excess; the Stribeck velocity unused
    free_wo = [i for i in prob.free.tolist() if i not in FRICTION_FREE]
    without = _fit(ua, ax.wfit, ax.T, th0, free_wo, max_nfev=30)
    gain = 1.0 - float(res.cost) / max(float(without[1].cost), 1e-300)
    log(
        f"  axis {ax.axis}: friction: cost {res.cost:.6g} with, {without[1].cost:.6g} without "
        f"({gain:.1%} lower with; kept from {1 - KEEP_FRICTION:.0%})"
    )
    return gain, without


def _setup_axis(trace, j, max_delay, holdout, window_s, max_fit_samples) -> _Axis:
    """Axis ``j`` of the trace and its windows over the fitted part (see :class:`_Axis`)."""
    axis = trace.axes[j]
    T = trace.servo_period_s
    u = trace.command[:, j]
    y = trace.position[:, j]
    n = len(u)
    n_fit = int(round((1 - holdout) * n))
    H = int(min(MAX_WINDOW_STEPS, max(MIN_WINDOW_STEPS, round(window_s / T))))
    v_sg, _, win_sg = _derivatives(y, T)
    states = _start_states(y, v_sg, T)
    pad = max(max_delay, win_sg) + 1
    try:
        wfit = _windows(y, v_sg, T, 0, n_fit, H, max(1, max_fit_samples // H), pad, states)
    except ValueError:
        raise ValueError(
            f"{trace.source}: {n_fit} rows to fit on axis {axis}, too short for windows of {H} "
            "samples; record a longer trace"
        ) from None
    # short windows (at most SHORT_WINDOW_STEPS) for the delay: a delay and a lag differ at
    # the highest frequencies, which long windows' slow drifts drown; a sample of them screens
    H_s = min(H, SHORT_WINDOW_STEPS)
    wshort = _windows(y, v_sg, T, 0, n_fit, H_s, max(1, max_fit_samples // H_s), pad, states)
    screen = wshort
    if len(wshort.starts) > SCREEN_WINDOWS:
        pick = np.round(np.linspace(0, len(wshort.starts) - 1, SCREEN_WINDOWS)).astype(int)
        screen = _windows_subset(wshort, pick)
    return _Axis(
        trace.source, axis, T, trace.time_s, u, y, n, n_fit, H, v_sg, states, wfit, wshort, screen
    )


def _no_mass(ax: _Axis) -> ValueError:
    return ValueError(
        f"{ax.source}, axis {ax.axis}: the trace does not determine the mass (the command "
        "does not accelerate the axis); record a trace with more motion (contour-env excite)"
    )


def _regression_starts(ax: _Axis, friction, max_delay) -> tuple[dict, int]:
    """The regression's start for every delay 0 … ``max_delay`` and the delay whose residual is
    the smallest among those with a positive mass."""
    regs, reg_res = {}, {}
    for d in range(max_delay + 1):
        regs[d], reg_res[d] = _regression_start(ax.u, ax.y, ax.T, 0, ax.n_fit, d, friction)
    positive = {d: r for d, r in reg_res.items() if regs[d][0] > 0}
    if not positive:
        raise _no_mass(ax)
    d_reg = min(positive, key=positive.get)
    return regs, d_reg


def _periodic_start(ax: _Axis, regs, d_reg, free, log) -> dict:
    """The periodic-force candidates, {kind: (c_s, c_c, frequency)}: the residual force of a
    first output-error fit (at the regression's best delay) is searched for them."""
    T = ax.T
    th_pre, _, _ = _fit(_delayed(ax.u, d_reg), ax.screen, T, _start_of(regs[d_reg], T), free, 8)
    found = _periodic_candidates(ax.u, ax.y, T, 0, ax.n_fit, d_reg, th_pre[:5], ax.n)
    cands = _rank_periodic(_delayed(ax.u, d_reg), ax.screen, T, th_pre, found)
    for key, (c_s, c_c, f) in cands.items():
        what = f"{f:.4g} Hz" if key == "disturbance" else f"period {2e3 * math.pi / f:.4g} mm"
        log(f"  axis {ax.axis}: {key} candidate at {what}, amplitude {math.hypot(c_s, c_c):.4g}")
    return cands


def _screen_delays(ax: _Axis, regs, cands, free_c, max_delay, log):
    """A short fit for every delay on the screening windows (from the regression's start with
    the periodic candidates): (cost by delay, θ by delay, sorted [(cost, delay)] of the finite
    ones)."""

    def start(d):
        th0 = _start_of(regs[d], ax.T)
        for key, vals in cands.items():
            th0[list(EXTRA[key])] = vals
        return th0

    costs, screened = {}, {}
    for d in range(max_delay + 1):
        if regs[d][0] <= 0:
            costs[d] = math.inf
            continue
        screened[d], res, _ = _fit(_delayed(ax.u, d), ax.screen, ax.T, start(d), free_c, max_nfev=8)
        costs[d] = float(res.cost)
        log(f"  axis {ax.axis}: delay {d} period(s): screening cost {res.cost:.6g}")
    finite = sorted((c, d) for d, c in costs.items() if math.isfinite(c))
    if not finite:
        raise _no_mass(ax)
    return costs, screened, finite


def _select_periodic(ax: _Axis, cands, screened, finite, free_c, log) -> list:
    """Each periodic force kept only where it lowers the cost by 5 % or more (on the screening
    windows, at the best screened delay); a dropped one is removed from ``cands`` and zeroed in
    ``screened`` (both changed in place). Returns the free indices left."""
    d_s = finite[0][1]
    ua = _delayed(ax.u, d_s)
    _, res_with, _ = _fit(ua, ax.screen, ax.T, screened[d_s], free_c, max_nfev=15)
    for key in list(cands):
        idx = list(EXTRA[key])
        th_wo = screened[d_s].copy()
        th_wo[idx] = 0.0
        free_wo = [i for i in free_c if i not in idx]
        _, res_wo, _ = _fit(ua, ax.screen, ax.T, th_wo, free_wo, max_nfev=15)
        kept = res_with.cost < KEEP_PERIODIC * res_wo.cost
        log(
            f"  axis {ax.axis}: {key}: cost {res_with.cost:.6g} with, {res_wo.cost:.6g} without "
            f"({'kept' if kept else 'dropped'})"
        )
        if not kept:
            del cands[key]
            free_c = free_wo
            for th_d in screened.values():
                th_d[idx] = 0.0
    return free_c


def _friction_starts(ax: _Axis, screened, finite, log) -> None:
    """The Stribeck curve's shape (static excess, Stribeck velocity) has valleys a local fit
    stops in: a grid around the screened values of the two best delays, evaluated in one batch,
    picks the start (``screened`` changed in place)."""
    grid_win = ax.wfit
    if len(ax.wfit.starts) > GRID_WINDOWS:
        pick = np.round(np.linspace(0, len(ax.wfit.starts) - 1, GRID_WINDOWS)).astype(int)
        grid_win = _windows_subset(ax.wfit, pick)
    for _, d in finite[:2]:
        screened[d] = _stribeck_grid(
            _delayed(ax.u, d), grid_win, ax.T, screened[d], log, ax.axis, d
        )


def _full_fits(ax: _Axis, screened, finite, free_c, log) -> dict:
    """The two best delays fitted in full, then the loser again from the winner's optimum (its
    lag shifted by the delay difference): a delay and a lag differ little, and a fit can stop
    in the other's valley; the lower cost wins. {delay: (θ, result, problem)}."""
    u, wfit, T = ax.u, ax.wfit, ax.T
    full = {}
    # the runner-up only where its screening cost is within a factor CLOSE_DELAY of the best
    close = [d for c, d in finite[:2] if c <= CLOSE_DELAY * finite[0][0]]
    for d in close:
        full[d] = _fit(_delayed(u, d), wfit, T, screened[d], free_c, max_nfev=60)
        log(f"  axis {ax.axis}: delay {d} period(s): cost {full[d][1].cost:.6g}")
    ranked = sorted(full, key=lambda k: full[k][1].cost)
    if len(full) == 2 and full[ranked[1]][1].cost <= CLOSE_DELAY * full[ranked[0]][1].cost:
        (d_win, d_lose) = ranked
        th_x = full[d_win][0].copy()
        th_x[5] = max(th_x[5] + (d_win - d_lose) * T, 0.01 * T)
        again = _fit(_delayed(u, d_lose), wfit, T, th_x, free_c, max_nfev=60)
        log(
            f"  axis {ax.axis}: delay {d_lose} period(s) from delay {d_win}: cost "
            f"{again[1].cost:.6g}"
        )
        if again[1].cost < full[d_lose][1].cost:
            full[d_lose] = again
    return full


def _choose_delay(ax: _Axis, full: dict, log) -> int:
    """The delay: the lower full cost; of two, the two fitted models on the short windows,
    where a delay and a lag differ most."""
    d = min(full, key=lambda k: full[k][1].cost)
    if len(full) == 2:
        ds = list(full)
        short = {}
        for k in ds:
            xk, _ = simulate_windows(full[k][0][None], _delayed(ax.u, k), ax.wshort, ax.T)
            short[k] = float(0.5 * np.sum(_residuals(xk, ax.wshort, ax.T) ** 2))
        log(
            f"  axis {ax.axis}: delays on short windows: "
            + ", ".join(f"{k}: {c:.6g}" for k, c in short.items())
        )
        d = min(short, key=short.get)
    return d


def _errors_and_plot(ax: _Axis, th, ua, holdout):
    """The normalised errors on the fitted windows and on the held-out part (windows over the
    rest of the trace; None without), and the plot's signals (held-out, else fitted)."""
    T, H, wfit = ax.T, ax.H, ax.wfit
    xs, _ = simulate_windows(th[None], ua, wfit, T)
    fit_err = _errors(xs[0], wfit, T)
    hold_err: dict = {"position": None, "velocity": None}
    wshow, part = wfit, "fitted"
    if holdout > 0:
        try:
            wval = _windows(ax.y, ax.v_sg, T, ax.n_fit, ax.n, H, 10**9, 0, ax.states)
        except ValueError:
            wval = None
        if wval is not None:
            xs, _ = simulate_windows(th[None], ua, wval, T)
            hold_err = _errors(xs[0], wval, T)
            wshow, part = wval, "held-out"
    if part == "fitted":
        xs, _ = simulate_windows(th[None], ua, wfit, T)
    t_idx = wshow.starts[:, None] + 1 + np.arange(H)[None, :]
    plot = {
        "part": part,
        "time_s": ax.time_s[t_idx].ravel(),
        "measured_position": wshow.y.ravel(),
        "simulated_position": xs[0].ravel(),
        "measured_velocity": wshow.v.ravel(),
        "simulated_velocity": _velocity(xs[0], wshow, T).ravel(),
        "window_starts_s": ax.time_s[wshow.starts],
    }
    return fit_err, hold_err, plot


def _values(th) -> dict:
    """The reported parameters {name: value} of a parameter vector."""
    m, b, fc, dfs, vs_, tau = (float(x) for x in th[:6])
    return {
        "mass": m,
        "viscous": b,
        "coulomb": fc,
        "static": fc + dfs,
        "stribeck_velocity": vs_,
        "current_loop_lag": tau,
    }


def _periodic_found(th, prob, ci) -> dict:
    """The periodic forces fitted: {"disturbance", "ripple"}: None or amplitude, frequency or
    period, phase and the amplitude's 95 % half-width."""
    periodic: dict = {"disturbance": None, "ripple": None}
    if 6 in prob.free:
        periodic["disturbance"] = {
            "amplitude_N": math.hypot(th[6], th[7]),
            "frequency_hz": float(th[8]),
            "phase_deg": math.degrees(math.atan2(th[7], th[6])),
            "ci95_amplitude_N": ci.get("disturbance_amplitude"),
        }
    if 9 in prob.free:
        periodic["ripple"] = {
            "amplitude_N": math.hypot(th[9], th[10]),
            "period_m": 2 * math.pi / float(th[11]),
            "phase_deg": math.degrees(math.atan2(th[10], th[9])),
            "ci95_amplitude_N": ci.get("ripple_amplitude"),
        }
    return periodic
