"""Zero-phase low-pass Q-filter of iterative learning control.

ILC runs between trials, on the whole record, so the filter may be non-causal: a Butterworth
low-pass run forward and backward (``scipy.signal.filtfilt``) has zero phase and a squared
magnitude. Q bounds the learning to the band where the learning law converges (robustness
against the unmodelled high-frequency dynamics, delay and noise).

The linear model of the loop the learning acts on (:func:`axis_plant_model`,
:func:`servo_loop_model`, :func:`closed_loop`) is here too: the default cutoffs come from it
(:func:`agents.ilc.learning_rate_bound`), as do ``vilcfd``'s observer bandwidths
(:func:`agents.vilcfd.observer_loop_margins`). Plain numpy, no control-systems package.
"""

from __future__ import annotations

import numpy as np

# scipy.signal is imported where a filter is designed or run, not with the module: it costs
# about a second at start-up, and every command imports this module through the controller
# registry (agents.ilc) whether it runs ILC or not (e.g. ``contour-env compare`` of pd, ccc)


class ZeroPhaseLowPass:
    """Q(z): Butterworth low-pass of ``order`` with cutoff ``cutoff_hz``, applied forward and
    backward along ``axis`` (the sample axis). ``cutoff_hz`` ≥ Nyquist disables it."""

    def __init__(self, cutoff_hz: float, servo_period_s: float, order: int = 2):
        if not (np.isfinite(cutoff_hz) and cutoff_hz > 0):
            raise ValueError(f"q_cutoff_hz: must be > 0 (Hz), got {cutoff_hz!r}")
        if isinstance(order, bool) or not isinstance(order, (int, np.integer)) or order < 1:
            raise ValueError(f"q_order: must be an integer >= 1, got {order!r}")
        self.cutoff_hz = float(cutoff_hz)
        self.order = int(order)
        nyquist = 0.5 / servo_period_s
        self.passthrough = self.cutoff_hz >= 0.999 * nyquist
        if not self.passthrough:
            from scipy import signal

            self.b, self.a = signal.butter(self.order, self.cutoff_hz / nyquist)

    def __call__(self, x: np.ndarray, axis: int = 1) -> np.ndarray:
        if self.passthrough:
            return np.array(x, dtype=np.float64)
        n = x.shape[axis]
        padlen = min(3 * max(len(self.a), len(self.b)) * 10, n - 1)
        if padlen < 1:
            return np.array(x, dtype=np.float64)
        # constant extension: the trial starts at rest and ends in the settle time (held
        # values), so neither edge is a jump the filter should ring on
        from scipy import signal

        return signal.filtfilt(self.b, self.a, x, axis=axis, padtype="constant", padlen=padlen)


# --- the linear loop the learning acts on (for the choice of the cutoff) -------------------
def axis_plant_model(params, axis: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(A, B, C) of one axis's linear part (:func:`contour_env.plants.discretize.
    continuous_model`: mass, viscous friction, current lag, two-mass mode) sampled with a
    zero-order hold at the servo period, the one-period computation delay as an extra state;
    input the command, output the position the encoder reads (the drive side with the
    two-mass mode, as the env does)."""
    from contour_env.plants.discretize import continuous_model, discretize

    Ac, Bu, Bw = continuous_model(params)
    Phi, Gu, _, _ = discretize(Ac[axis], Bu[axis], Bw[axis], params.servo_period_s)
    ns = Phi.shape[0]
    C = np.zeros(ns)
    C[2 if params.has_structural_mode else 0] = 1.0
    if not params.computation_delay:
        return Phi, Gu, C
    A = np.zeros((ns + 1, ns + 1))
    A[:ns, :ns], A[:ns, ns] = Phi, Gu
    B = np.zeros(ns + 1)
    B[ns] = 1.0
    return A, B, np.append(C, 0.0)


def frequency_response(A, B, C, D, z: np.ndarray) -> np.ndarray:
    """C (zI − A)⁻¹ B + D of a single-input single-output discrete system at the points z."""
    eye = np.eye(A.shape[0])
    return np.array([C @ np.linalg.solve(zz * eye - A, B) + D for zz in z])


def servo_loop_model(P, D, m, b, g, order, T, delay):
    """(A, B, C, D) of one axis's servo law, inputs (y, u_ff), output u: the PD
    u = −P y − D v + u_ff (reference 0), v = (y_k − y_{k−1})/T, plus — for g > 0 — the
    disturbance observer of ``vilcfd`` as it runs while the axis slides (binomial Q-filter of
    ``order`` sections e^{−gT} on the velocity and on the applied force, nominal mass m and
    viscous friction b, the command acting over the last period; its friction model, stick
    logic and bound left out: not linear). Built by probing that linear step."""
    a = 1.0 - np.exp(-g * T) if g > 0 else 0.0
    n = order if g > 0 else 0
    ns = 1 + 2 * n + delay + 1

    def step(s, y, u_ff):
        v = (y - s[0]) / T
        xv, xf, q = s[1 : 1 + n].copy(), s[1 + n : 1 + 2 * n].copy(), s[1 + 2 * n :]
        prev_v, prev_f = v, q[-1] - b * v  # q[-1]: the command acting over the last period
        for i in range(n):
            xv[i] += a * (prev_v - xv[i])
            xf[i] += a * (prev_f - xf[i])
            prev_v, prev_f = xv[i], xf[i]
        d_hat = xf[-1] - m * g * ((xv[-2] if n > 1 else v) - xv[-1]) if n else 0.0
        u = -P * y - D * v + u_ff + d_hat
        return np.concatenate([[y], xv, xf, [u], q[:-1]]), u

    A = np.zeros((ns, ns))
    C = np.zeros(ns)
    for j in range(ns):
        A[:, j], C[j] = step(np.eye(ns)[j], 0.0, 0.0)
    B = np.zeros((ns, 2))
    Dk = np.zeros(2)
    B[:, 0], Dk[0] = step(np.zeros(ns), 1.0, 0.0)
    B[:, 1], Dk[1] = step(np.zeros(ns), 0.0, 1.0)
    return A, B, C, Dk


def closed_loop(Ap, Bp, Cp, K) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(A, B, C) of the plant (Ap, Bp, Cp) under the servo law K (:func:`servo_loop_model`):
    input the learned feedforward u_ff, output the measured position."""
    Ak, Bk, Ck, Dk = K
    A = np.block(
        [
            [Ap + Dk[0] * np.outer(Bp, Cp), np.outer(Bp, Ck)],
            [np.outer(Bk[:, 0], Cp), Ak],
        ]
    )
    B = np.concatenate([Bp * Dk[1], Bk[:, 1]])
    C = np.concatenate([Cp, np.zeros(Ak.shape[0])])
    return A, B, C
