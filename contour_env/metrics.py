"""The one scoring function every controller and agent is judged by.

Scoring window (the same for everyone): every step of the episode after reset, from the first
servo period to the last (the whole feed profile, start-up and stop included, plus the settle
time). The reference starts from rest with a jerk-bounded S-curve, so there is no step
transient to exclude. If the episode ended early (crash guard), the steps that were run are
scored and ``completed`` is False.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class EpisodeRecord:
    """Per-step arrays of one episode (SI units), as read from ``info``.

    time (n,) s; contour_error (n,) m (true); tracking_error (n, d) m; force (n, d) N applied;
    saturated (n, d) bool; position, reference (n, d) m; force_limit (d,) N;
    encoder_resolution_m (d,) m, the true plant's encoder count per axis (None: unknown).
    """

    time: np.ndarray
    contour_error: np.ndarray
    tracking_error: np.ndarray
    force: np.ndarray
    saturated: np.ndarray
    position: np.ndarray
    reference: np.ndarray
    force_limit: np.ndarray
    termination_reason: str | None = None
    n_steps_planned: int | None = None
    encoder_resolution_m: np.ndarray | None = None

    @property
    def completed(self) -> bool:
        return self.termination_reason is None


def _rms(x: np.ndarray, axis=0) -> np.ndarray:
    return np.sqrt(np.mean(np.square(x), axis=axis))


def encoder_resolution_um(resolution_m) -> float | None:
    """The coarsest encoder count over the axes, µm (None if unknown; 0 for ideal encoders).
    A contour error below it is below what the controller can resolve on every axis."""
    if resolution_m is None:
        return None
    res = np.asarray(resolution_m, dtype=np.float64)
    return round(float(np.max(res)) * 1e6, 9) if res.size else None


def below_count(value_um, resolution_um) -> bool:
    """True when an error (µm) is below one encoder count (False if either is unknown, or the
    encoder is ideal)."""
    return bool(value_um is not None and resolution_um is not None and value_um < resolution_um)


def resolution_fields(metrics: dict, resolution_m) -> dict:
    """``encoder_resolution_um``, ``below_resolution`` (RMS contour error below one count) and
    ``max_below_resolution`` (max contour error below one count) for ``metrics`` (a dict with
    ``rms_contour_error_um`` and ``max_contour_error_um``); the flags are None when the
    resolution is unknown."""
    res = encoder_resolution_um(resolution_m)
    if res is None:
        return {
            "encoder_resolution_um": None,
            "below_resolution": None,
            "max_below_resolution": None,
        }
    return {
        "encoder_resolution_um": res,
        "below_resolution": below_count(metrics.get("rms_contour_error_um"), res),
        "max_below_resolution": below_count(metrics.get("max_contour_error_um"), res),
    }


def format_um(value_um, resolution_um=None, spec: str = ".2f") -> str:
    """An error (µm) for a table: the number, or ``≤R (enc)`` when it is below one encoder
    count R (µm); ``n/a`` for None."""
    if value_um is None:
        return "n/a"
    if below_count(value_um, resolution_um):
        return f"≤{resolution_um:g} (enc)"
    return format(value_um, spec)


def score(record: EpisodeRecord) -> dict:
    """Metrics of one episode (µm for errors, N — or the plant's command unit — for effort).

    Keys: ``max_contour_error_um``, ``rms_contour_error_um``, ``mean_abs_contour_error_um``,
    ``max_tracking_error_um`` [per axis], ``rms_tracking_error_um`` [per axis], ``rms_effort``
    [per axis], ``peak_effort`` [per axis], ``saturation_fraction`` (share of steps with any
    axis saturated), ``n_steps``, ``duration_s``, ``completed``, ``termination_reason``,
    ``encoder_resolution_um`` (the coarsest axis's encoder count, µm), ``below_resolution``
    (RMS contour error below one count) and ``max_below_resolution`` (max contour error below
    one count) — see :func:`resolution_fields`. Non-finite samples (a diverged run) are
    reported as ``None`` rather than NaN.
    """
    eps = np.asarray(record.contour_error, dtype=np.float64)
    n = eps.shape[0]
    if n == 0:
        raise ValueError("record: the episode has no steps to score")
    te = np.asarray(record.tracking_error, dtype=np.float64).reshape(n, -1)
    f = np.asarray(record.force, dtype=np.float64).reshape(n, -1)
    sat = np.asarray(record.saturated, dtype=bool).reshape(n, -1)

    def clean(x):
        x = np.asarray(x, dtype=np.float64)
        if x.ndim == 0:
            return float(x) if np.isfinite(x) else None
        return [float(v) if np.isfinite(v) else None for v in x]

    m = {
        "max_contour_error_um": clean(np.max(np.abs(eps)) * 1e6),
        "rms_contour_error_um": clean(_rms(eps) * 1e6),
        "mean_abs_contour_error_um": clean(np.mean(np.abs(eps)) * 1e6),
        "max_tracking_error_um": clean(np.max(np.abs(te), axis=0) * 1e6),
        "rms_tracking_error_um": clean(_rms(te) * 1e6),
        "rms_effort": clean(_rms(f)),
        "peak_effort": clean(np.max(np.abs(f), axis=0)),
        "saturation_fraction": float(np.mean(np.any(sat, axis=1))),
        "n_steps": int(n),
        "duration_s": float(record.time[-1]) if n else 0.0,
        "completed": record.completed,
        "termination_reason": record.termination_reason,
    }
    m.update(resolution_fields(m, record.encoder_resolution_m))
    return m
