"""The one scoring function every controller and agent is judged by.

Scoring window (the same for everyone): every step of the episode after reset, from the first
servo period to the last (the whole feed profile, start-up and stop included, plus the settle
time). The reference starts from rest with a jerk-bounded S-curve, so there is no step
transient to exclude. If the episode ended early (crash guard), the steps that were run are
scored and ``completed`` is False. A program with rapid (G00) moves is scored over its cutting
moves (scope ``"cut"``, see :func:`score`).

The contour error ε is the distance to the *whole* path, so a tool that never leaves the start
point of a path has ε = 0: ``completed`` (:attr:`EpisodeRecord.completed`) is what tells a run
that followed the program from one that did not.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .tool_errors import ARCSEC_PER_RAD

# A run "followed the program" (``completed``) only if its tracking error ‖x_d − x‖ never
# exceeded FOLLOW_LIMIT_M and ended within END_TOLERANCE_M of the reference (the end point,
# held during the settle time). FOLLOW_LIMIT_M is also the env's default tracking-error guard
# (EnvConfig.abort_tracking_error_m). The largest tracking errors of the classical controllers
# on the named cases are 0.6 mm (PD) and 3.1 mm (jee-ccc, jee-circle3d), the largest final
# ones 0.12 mm (PD, sharp-corner, stuck by friction near the end point).
FOLLOW_LIMIT_M = 10e-3
END_TOLERANCE_M = 1e-3


@dataclass
class EpisodeRecord:
    """Per-step arrays of one episode (SI units), as read from ``info``.

    time (n,) s; contour_error (n,) m (true); tracking_error (n, d) m; force (n, d) N applied;
    saturated (n, d) bool; position, reference (n, d) m; force_limit (d,) N;
    encoder_resolution_m (d,) m, the true plant's encoder count per axis (None: unknown);
    n_steps_planned: the episode's full length in steps (None: unknown); rapid (n,) bool, True
    where the step's reference is on a rapid (G00) move (``Setup.step_is_rapid``; None: the
    path has no rapids); orientation_error (n,) rad, the five-axis tool's orientation error
    (None: not a five-axis run).
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
    rapid: np.ndarray | None = None
    orientation_error: np.ndarray | None = None

    @property
    def incomplete_reason(self) -> str | None:
        """Why the run did not follow the program (None: it did). The first that applies:
        the env terminated it (its ``termination_reason``); it stopped before the planned
        number of steps; its tracking error ‖x_d − x‖ exceeded :data:`FOLLOW_LIMIT_M`
        (10 mm, or was not finite); it ended more than :data:`END_TOLERANCE_M` (1 mm) from the
        reference's last point."""
        if self.termination_reason is not None:
            return f"terminated: {self.termination_reason}"
        n = len(self.contour_error)
        if self.n_steps_planned is not None and n < self.n_steps_planned:
            return f"stopped after {n} of {self.n_steps_planned} steps"
        if n == 0:
            return "no steps"
        te = np.asarray(self.tracking_error, dtype=np.float64).reshape(n, -1)
        te = np.linalg.norm(te, axis=1)
        worst = float(np.max(te))
        if not worst <= FOLLOW_LIMIT_M:  # also NaN
            return (
                f"did not follow the reference: tracking error {worst * 1e3:.3g} mm > "
                f"{FOLLOW_LIMIT_M * 1e3:g} mm"
            )
        if not te[-1] <= END_TOLERANCE_M:
            return (
                f"did not reach the end: {te[-1] * 1e3:.3g} mm from the reference's last point "
                f"> {END_TOLERANCE_M * 1e3:g} mm"
            )
        return None

    @property
    def completed(self) -> bool:
        """True only for a run that followed the program (see :attr:`incomplete_reason`)."""
        return self.incomplete_reason is None


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


#: Metrics a run may ask for beside the headline ones (``score(record, metrics=...)``,
#: ``contour-env compare --metrics``): ``total`` — Chen & Lee 2020's total contour error.
EXTRA_METRICS = ("total",)


def total_contour_error_um(contour_error) -> float | None:
    """Chen & Lee 2020's "total contour error" (§4.2, Tables 1 and 2), µm: the sum over the
    samples of the contour error magnitude, Σ_k |ε_k| (None where a sample is not finite).

    The paper names it without a formula. The sum of |ε| over the samples is the reading its
    tables support: total / RMSE is 1.17–1.32·10⁴ in all four adaptive columns (Table 1
    cases 2, 3; Table 2 FNN, RFNN; e.g. 60 349.14 mm / 4.8477 mm), a fixed sample count times
    mean |ε| / RMS ≤ 1, while a sum of squares would give 1.3·10³ and 2.6·10³ for cases 2 and
    3. (Table 1 case 1, max 0.0118 mm below its RMSE 0.166 mm, is inconsistent in itself.) It
    grows with the number of samples: compare it only between runs of the same case and
    servo period."""
    eps = np.asarray(contour_error, dtype=np.float64).reshape(-1)
    total = float(np.sum(np.abs(eps)) * 1e6)
    return total if np.isfinite(total) else None


def check_metrics(metrics) -> tuple[str, ...]:
    """The names of ``metrics`` as a tuple; ``ValueError`` naming an unknown one and the
    known ones (:data:`EXTRA_METRICS`)."""
    if isinstance(metrics, str):
        metrics = (metrics,)
    names = tuple(metrics)
    unknown = [m for m in names if m not in EXTRA_METRICS]
    if unknown:
        raise ValueError(
            f"metrics: unknown metric {', '.join(map(repr, unknown))}; known: "
            f"{', '.join(EXTRA_METRICS)}"
        )
    return names


def score(record: EpisodeRecord, *, metrics=()) -> dict:
    """Metrics of one episode (µm for errors, N — or the plant's command unit — for effort).

    Keys: ``max_contour_error_um``, ``rms_contour_error_um``, ``mean_abs_contour_error_um``
    (the headline figures, over the steps of ``scope``), ``max_tracking_error_um`` [per axis],
    ``rms_tracking_error_um`` [per axis], ``rms_effort`` [per axis], ``peak_effort`` [per axis],
    ``saturation_fraction`` (share of steps with any axis saturated), ``n_steps``,
    ``duration_s``, ``completed``, ``incomplete_reason``, ``termination_reason``, ``scope``,
    ``rapid_max_contour_error_um``, ``rapid_rms_contour_error_um``, ``encoder_resolution_um``
    (the coarsest axis's encoder count, µm), ``below_resolution`` (RMS contour error below one
    count) and ``max_below_resolution`` (max contour error below one count) — see
    :func:`resolution_fields`. Non-finite samples (a diverged run) are reported as ``None``
    rather than NaN.

    ``completed`` is True only for a run that followed the program: not terminated by the
    env, every planned step run, the tracking error ‖x_d − x‖ never above
    :data:`FOLLOW_LIMIT_M` (10 mm) and at the end within :data:`END_TOLERANCE_M` (1 mm) of the
    reference's last point. Otherwise ``incomplete_reason`` says why
    (:attr:`EpisodeRecord.incomplete_reason`). A tool that stands still has ε = 0 (the start
    point is on the path) but is not ``completed``.

    ``scope``: ``"cut"`` when the record has a rapid mask (``record.rapid``, set for a G-code
    program with G00 moves; a step is rapid when its reference lies on a rapid move, a
    junction with a cutting move counting as cutting): the headline contour-error figures are
    then over the cutting steps only, and ``rapid_max_contour_error_um`` /
    ``rapid_rms_contour_error_um`` over the rapid steps (each None where no such step ran).
    ``"all"`` otherwise: headline over every step, rapid figures None. Tracking error, effort,
    saturation and ``completed`` are always over every step.

    ``metrics``: extra metrics to add (:data:`EXTRA_METRICS`): ``"total"`` adds
    ``total_contour_error_um`` (:func:`total_contour_error_um`, over the headline steps).

    A five-axis run (``record.orientation_error`` set) adds ``max_orientation_error_arcsec``
    and ``rms_orientation_error_arcsec`` (the tool's orientation error over every step,
    arc-seconds; None where not finite); its contour error is the tool-tip contour error.
    """
    extra = check_metrics(metrics)
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

    rapid = None
    if record.rapid is not None:
        rapid = np.asarray(record.rapid, dtype=bool).reshape(-1)
        if rapid.shape != (n,):
            raise ValueError(f"record.rapid: one flag per step ({n}), got {rapid.shape[0]}")
    head = eps if rapid is None else eps[~rapid]
    fast = eps[rapid] if rapid is not None else eps[:0]

    def stats(x):
        if x.size == 0:
            return None, None, None
        return (
            clean(np.max(np.abs(x)) * 1e6),
            clean(_rms(x) * 1e6),
            clean(np.mean(np.abs(x)) * 1e6),
        )

    head_max, head_rms, head_mean = stats(head)
    rapid_max, rapid_rms, _ = stats(fast)
    m = {
        "max_contour_error_um": head_max,
        "rms_contour_error_um": head_rms,
        "mean_abs_contour_error_um": head_mean,
        "max_tracking_error_um": clean(np.max(np.abs(te), axis=0) * 1e6),
        "rms_tracking_error_um": clean(_rms(te) * 1e6),
        "rms_effort": clean(_rms(f)),
        "peak_effort": clean(np.max(np.abs(f), axis=0)),
        "saturation_fraction": float(np.mean(np.any(sat, axis=1))),
        "n_steps": int(n),
        "duration_s": float(record.time[-1]) if n else 0.0,
        "completed": record.completed,
        "incomplete_reason": record.incomplete_reason,
        "termination_reason": record.termination_reason,
        "scope": "all" if rapid is None else "cut",
        "rapid_max_contour_error_um": rapid_max,
        "rapid_rms_contour_error_um": rapid_rms,
    }
    m.update(resolution_fields(m, record.encoder_resolution_m))
    if record.orientation_error is not None:
        theta = np.asarray(record.orientation_error, dtype=np.float64).reshape(-1)
        if theta.shape != (n,):
            raise ValueError(
                f"record.orientation_error: one angle per step ({n}), got {theta.shape[0]}"
            )
        m["max_orientation_error_arcsec"] = clean(np.max(np.abs(theta)) * ARCSEC_PER_RAD)
        m["rms_orientation_error_arcsec"] = clean(_rms(theta) * ARCSEC_PER_RAD)
    if "total" in extra:
        m["total_contour_error_um"] = total_contour_error_um(head) if head.size else None
    return m
