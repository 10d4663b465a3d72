"""Zero-phase low-pass Q-filter of iterative learning control.

ILC runs between trials, on the whole record, so the filter may be non-causal: a Butterworth
low-pass run forward and backward (``scipy.signal.filtfilt``) has zero phase and a squared
magnitude. Q bounds the learning to the band where the learning law converges (robustness
against the unmodelled high-frequency dynamics, delay and noise).
"""

from __future__ import annotations

import numpy as np
from scipy import signal


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
        return signal.filtfilt(self.b, self.a, x, axis=axis, padtype="constant", padlen=padlen)
