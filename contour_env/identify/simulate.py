"""The output-error model of :mod:`contour_env.identify`: simulation windows of one axis, the
derivatives and start states they need, the delayed command and the current loop's lag, and
:func:`simulate_windows` (the package's compiled axis step, all windows and parameter sets in
one batch) with the scaled residuals."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..plants.model import PackedPlant
from .kernel import simulate_steps, start_velocity_response
from .pack import _pack, _params_of
from .trace import _quantum

N_THETA = 12


@dataclass(frozen=True)
class _Windows:
    """Simulation windows of one axis: start samples, length, the measured data around."""

    starts: np.ndarray
    H: int
    y0: np.ndarray  # position at the start
    v0: np.ndarray  # velocity at the start (0: at rest)
    still: np.ndarray  # bool: the encoder stood still around the start
    y: np.ndarray  # (W, H) measured position at start+1 .. start+H
    v: np.ndarray  # (W, H) measured velocity (central differences)
    sp: float  # scale of the position residuals, m
    sv: float  # scale of the velocity residuals, m/s


def _derivatives(y: np.ndarray, T: float, smooth_s=None) -> tuple[np.ndarray, np.ndarray, int]:
    """Savitzky–Golay (cubic) velocity and acceleration of the positions, window ``smooth_s``
    (default about 8 ms, at least 7 samples); returns (v, a, window samples)."""
    from scipy.signal import savgol_filter  # loaded where used (CLI start-up)

    half = 0.004 if smooth_s is None else 0.5 * smooth_s
    win = 2 * max(3, int(round(half / T))) + 1
    win = min(win, (len(y) // 2) * 2 - 1)
    v = savgol_filter(y, win, 3, deriv=1, delta=T)
    a = savgol_filter(y, win, 3, deriv=2, delta=T)
    return v, a, win


def _start_states(y: np.ndarray, v_sg: np.ndarray, T: float) -> tuple[np.ndarray, np.ndarray]:
    """Per sample, (at rest, clearly moving): at rest where the smoothed velocity is within
    four times its noise (the encoder's counts and noise, estimated from its difference to a
    three times longer smoothing on the quietest samples) and the longer smoothing's within four
    times its own
    (the noise scaled by the window length^1.5); clearly moving where the smoothed velocity is
    beyond eight times its noise.
    A simulation window starts at one or the other, never in between (a slow plateau, a
    reversal: whether the axis sticks there is what the fit must not be told wrongly)."""
    _, _, w_short = _derivatives(y, T)
    v_long, _, w_long = _derivatives(y, T, 3 * (w_short - 1) * T)
    # the quietest quarter of the samples (rest, plateaus) carries the noise alone: the lower
    # quartile of |dev| is 0.3186 σ for Gaussian noise; not below the encoder count's own
    dev = np.abs(v_sg - v_long)
    q = _quantum(y)
    sigma = max(float(np.quantile(dev, 0.25)) / 0.3186, q / (T * w_short**1.5))
    sigma_long = sigma * (w_short / w_long) ** 1.5
    rest = (np.abs(v_sg) <= 4.0 * sigma) & (np.abs(v_long) <= 4.0 * sigma_long)
    moving = np.abs(v_sg) > 8.0 * sigma
    return rest, moving


def _windows(y, v_sg, T, lo, hi, H, max_windows, pad, states=None) -> _Windows:
    """Windows of H samples in [lo, hi) (starting at lo + pad at the earliest), at most
    ``max_windows``, spread evenly; with ``states`` (:func:`_start_states`) each start moved
    (by up to H / 2) to the nearest sample at rest or clearly moving, or the window dropped;
    a window at rest starts stuck, one moving with the smoothed velocity."""
    first = lo + pad
    count = (hi - first - 1) // H
    if count < 1:
        raise ValueError("too short")
    starts = first + np.arange(count) * H
    if count > max_windows:
        pick = np.round(np.linspace(0, count - 1, max_windows)).astype(int)
        starts = starts[pick]
    rest = None
    if states is not None:
        rest, moving = states
        clear = rest | moving
        kept = []
        for s0 in starts:
            # the nearest clear sample within ± H / 2 (the window stays inside [first, hi))
            lo_s, hi_s = max(first, s0 - H // 2), min(s0 + H // 2 + 1, hi - H - 1)
            ok = np.flatnonzero(clear[lo_s:hi_s]) + lo_s
            if ok.size:
                kept.append(int(ok[np.argmin(np.abs(ok - s0))]))
        if not kept:
            raise ValueError("too short")
        starts = np.array(kept)
    idx = starts[:, None] + 1 + np.arange(H)[None, :]
    ym = y[idx]
    vm = (ym - y[idx - 1]) / T  # backward differences, as the env's velocity
    y0 = y[starts]
    still = rest[starts] if rest is not None else np.zeros(len(starts), dtype=bool)
    v0 = np.where(still, 0.0, v_sg[starts])
    sp = float(np.sqrt(np.mean((ym - y0[:, None]) ** 2)))
    sv = float(np.sqrt(np.mean(vm**2)))
    return _Windows(starts, H, y0, v0, still, ym, vm, max(sp, 1e-12), max(sv, 1e-12))


def _delayed(u: np.ndarray, d: int) -> np.ndarray:
    """The command applied over each period with a delay of d periods (before the trace: its
    first command)."""
    if d == 0:
        return u.copy()
    return np.concatenate([np.full(d, u[0]), u[:-d]])


def _lag_state(ua: np.ndarray, tau: float, T: float, at: np.ndarray | None = None) -> np.ndarray:
    """The current loop's force (the state before that period's step) at the samples ``at``
    (default every sample), for the applied command ``ua``: exact ZOH of τ ḟ + f = u, starting
    settled at ua[0]. At given samples, the sum over the last 40 τ of history (the rest weighs
    below e⁻⁴⁰)."""
    alpha = math.exp(-T / tau)
    if at is None:
        from scipy.signal import lfilter  # scipy.signal: loaded where used (CLI start-up)

        f_next, _ = lfilter([1 - alpha], [1, -alpha], ua, zi=[alpha * ua[0]])
        return np.concatenate([[ua[0]], f_next[:-1]])
    K = int(min(len(ua), math.ceil(40.0 * tau / T) + 1))
    idx = np.asarray(at)[..., None] - 1 - np.arange(K)
    hist = ua[np.maximum(idx, 0)]  # before the trace: settled at ua[0]
    w = (1 - alpha) * alpha ** np.arange(K)
    return hist @ w + alpha**K * ua[0]


def _windows_subset(w: _Windows, pick) -> _Windows:
    return _Windows(
        w.starts[pick], w.H, w.y0[pick], w.v0[pick], w.still[pick], w.y[pick], w.v[pick], w.sp, w.sv
    )


def simulate_windows(thetas, ua: np.ndarray, win: _Windows, T: float):
    """Simulate every window for every parameter vector of ``thetas`` (S, 12) — mass, viscous,
    Coulomb, static − Coulomb, Stribeck velocity, current-loop lag, then the periodic forces
    against the drive: disturbance d_s sin ω t + d_c cos ω t (its sine and cosine amplitudes,
    N, and frequency ω / 2π, Hz) and ripple r_s sin k x + r_c cos k x (amplitudes, N, and
    wavenumber k, rad/m; 6 values: none) — with the applied command
    ``ua`` (n,) (already delayed) by the package's compiled plant step, all in one batch (two
    windows per env, one on each axis slot). A moving window starts from the measured position
    and the estimated velocity, corrected by the least-squares fit of the window's residual to
    the model's response to a start velocity. Returns positions and velocities (S, W, H)."""
    thetas = np.atleast_2d(np.asarray(thetas, dtype=np.float64))
    if thetas.shape[1] < N_THETA:
        thetas = np.pad(thetas, ((0, 0), (0, N_THETA - thetas.shape[1])))
    S = thetas.shape[0]
    W, H = len(win.starts), win.H
    limit = float(np.max(np.abs(ua))) * 2.0 + 1e-9
    plist = [_params_of(th, T, limit) for th in thetas]
    envs_per_set = (W + 1) // 2
    B = S * envs_per_set
    base = _pack(plist)
    pidx = np.repeat(np.arange(S, dtype=np.int64), envs_per_set)
    packed = PackedPlant(base.mat_T, base.mat_h, base.cont, base.nl, pidx)
    # window w of set s → env s * envs_per_set + w // 2, slot w % 2 (a padded slot repeats w=0)
    wi = np.arange(2 * envs_per_set)
    wi[wi >= W] = 0
    win_of = np.broadcast_to(wi.reshape(envs_per_set, 2), (S, envs_per_set, 2)).reshape(B, 2)
    starts = win.starts[win_of]
    z = np.zeros((B, 2, 3))
    z[:, :, 0] = win.y0[win_of]
    z[:, :, 1] = win.v0[win_of]
    for s in range(S):
        rows = slice(s * envs_per_set, (s + 1) * envs_per_set)
        z[rows, :, 2] = _lag_state(ua, thetas[s, 5], T, starts[rows])
    stuck = np.where(win.still[win_of], 1.0, 0.0)
    pending = np.zeros((B, 2))
    applied = np.zeros((B, 2))
    xs = np.empty((H, B, 2))
    vs = np.empty((H, B, 2))
    n_sub = plist[0].friction_substeps
    # periodic forces against the drive (disturbance in time, ripple in position), held over
    # each period at its mid-point, through the step's extra force
    per_env = thetas[pidx]  # (B, N_THETA)
    steps = np.arange(H)
    U = np.ascontiguousarray(ua[starts[None, :, :] + steps[:, None, None]])  # (H, B, 2)
    dist = np.zeros((0, 0, 0))
    if np.any(per_env[:, 6:8] != 0):
        d_s, d_c, w_d = per_env[:, 6:7], per_env[:, 7:8], 2 * np.pi * per_env[:, 8:9]
        ph = w_d[None] * ((starts[None] + steps[:, None, None] + 0.5) * T)
        dist = np.ascontiguousarray(d_s[None] * np.sin(ph) + d_c[None] * np.cos(ph))
    ripple = np.zeros((0, 3))
    if np.any(per_env[:, 9:11] != 0):
        ripple = np.ascontiguousarray(per_env[:, 9:12])
    simulate_steps(
        z,
        stuck,
        pending,
        U,
        T,
        n_sub,
        *packed,
        applied,
        dist,
        ripple,
        xs,
        vs,
    )
    xs = xs.transpose(1, 2, 0).reshape(S, 2 * envs_per_set, H)[:, :W]
    vs = vs.transpose(1, 2, 0).reshape(S, 2 * envs_per_set, H)[:, :W]
    # the start velocity of a moving window is an estimate (a smoothed derivative of the
    # encoder); its error, to first order the linear part's response to an initial velocity,
    # is fitted per window and removed (variable projection), so that it does not leak into
    # the parameters (a lag, above all)
    phi = base.mat_T[:, 0, :, :3]  # (S, 3, 3)
    gx = np.empty((S, H))
    gv = np.empty((S, H))
    start_velocity_response(np.ascontiguousarray(phi), gx, gv)
    g_bd = np.diff(gx, axis=1, prepend=0.0) / T
    g = np.concatenate([gx / win.sp, g_bd / win.sv], axis=1)  # (S, 2H)
    r = np.concatenate(
        [(xs - win.y[None]) / win.sp, (_velocity(xs, win, T) - win.v[None]) / win.sv], axis=2
    )
    dv = -np.einsum("swk,sk->sw", r, g) / np.einsum("sk,sk->s", g, g)[:, None]
    dv[:, win.still] = 0.0
    xs = xs + dv[:, :, None] * gx[:, None, :]
    vs = vs + dv[:, :, None] * gv[:, None, :]
    return xs, vs


def _velocity(xs, win: _Windows, T: float) -> np.ndarray:
    """Backward-difference velocity of simulated positions (..., W, H), the window's start
    being the measured position: the same estimate as the measured velocity's (an encoder
    difference; comparing it with the model's instantaneous velocity would bias the fit toward
    a lag)."""
    prev = np.concatenate(
        [np.broadcast_to(win.y0[:, None], xs.shape[:-1] + (1,)), xs[..., :-1]], -1
    )
    return (xs - prev) / T


def _residuals(xs, win: _Windows, T: float) -> np.ndarray:
    """(S, 2 W H) scaled residuals: position, then velocity (encoder differences)."""
    S = xs.shape[0]
    rp = (xs - win.y[None]) / win.sp
    rv = (_velocity(xs, win, T) - win.v[None]) / win.sv
    return np.concatenate([rp.reshape(S, -1), rv.reshape(S, -1)], axis=1)
