"""Identification of the package's axis model from a measured trace (``contour-env identify``).

A trace is a CSV of the servo samples of a drive: ``time_s`` and, per axis a, ``command_a``
(the force command computed at that sample, N — or A with a force constant) and
``position_a`` (the encoder reading at that sample, m). Per axis it fits the parameters of
the package's model (``contour_env.plants.params``)

    m ẍ + b ẋ + (f_c + (f_s − f_c) e^{−(ẋ/v_s)²}) sgn ẋ + d(t) + r(x) = f,
    τ_c ḟ + f = u(t − d T)

— mass (inertia) m, viscous b, Coulomb f_c and static f_s friction with the Stribeck velocity
v_s, the computation delay d in whole servo periods and the current-loop lag τ_c, and, where
the trace shows them, a periodic disturbance d(t) (amplitude, frequency) and a position
ripple r(x) (amplitude, period); the force limit is the largest command of the trace (or
given) and the encoder resolution the trace's position quantum (or given).

Method, per axis (the fitted part: all but the last ``holdout`` share):

1. **Initial values** from linear regressions on the delayed command and Savitzky–Golay
   derivatives smoothed alike: the friction curve on the quasi-steady samples (plateaus), then
   the mass.
2. **Output error, simulated by the package's own compiled axis step**
   (:func:`contour_env.plants.kernel.plant_step_batch`: exact ZOH discretisation,
   stick–slip), in windows of ``window_s`` (0.4 s; at most 400 periods). A window starts from
   the measured position, either at rest (stuck) or clearly moving (from the smoothed
   velocity, whose error is then removed by a first-order fit per window: variable
   projection); windows that would start in between (a slow plateau at the encoder's noise,
   a reversal) are moved to the nearest clear sample or dropped. Residuals: simulated minus
   measured position and encoder-difference velocity, each scaled by its RMS. All windows and
   all finite-difference perturbations of the parameters run as one batch;
   :func:`scipy.optimize.least_squares` (trust region, bounds, Cauchy loss) minimises them.
3. **Delay** by a discrete search over d = 0 … ``max_delay``: a short fit for each on short
   windows (100 periods), the best two fitted in full (the runner-up again from the winner's
   optimum), the delay then chosen on the short windows, where a delay and a lag differ most.
4. **Friction curve**: before the full fits, a grid over static friction, its split into
   Coulomb and excess, and the Stribeck velocity (one batch) picks the start: the curve has
   valleys a local fit stops in. After the full fits the model is refitted without friction;
   friction is kept only where it lowers the cost by 20 % or more (else a warning, and 0).
   The loss is Cauchy (:data:`.fit.LOSS`): windows replayed open loop through the Stribeck
   curve's negative slope can run away by millimetres and would otherwise decide the fit.
5. **Periodic forces**: peaks of the regression residual's periodogram in time (disturbance)
   and in position (ripple), ranked by how much of the output error each explains; the best
   of each kind kept when it lowers the cost by 5 % or more.
6. **Confidence intervals** (95 %) from the Jacobian at the optimum, cov = s² (JᵀJ)⁻¹ with s²
   the residual variance (optimistic: the residuals of a window are correlated).
7. **Validation** on the held-out part: the same windows, the normalised errors
   RMS(sim − meas) / RMS(measured displacement in the window) for position and
   RMS(sim − meas) / RMS(measured velocity) for velocity.

What a trace cannot show is left out: a structural (two-mass) mode is not fitted, nor the
phase of a periodic force (the package's model fixes it; see the README, "Your machine").
"""

from __future__ import annotations

import math

import numpy as np
from threadpoolctl import threadpool_limits

from .axis import _fit_axis
from .result import PARAM_NAMES as PARAM_NAMES
from .result import UNITS as UNITS
from .result import AxisFit, Identification, plant_mapping, write_plant
from .simulate import simulate_windows
from .trace import (
    DEFAULT_HOLDOUT,
    MIN_ROWS,
    Trace,
    _check_trace_for_fit,
    _per_axis,
    _quantum,
    parse_columns,
    read_trace,
    trace_from_arrays,
    write_trace_csv,
)

__all__ = [
    "DEFAULT_HOLDOUT",
    "DEFAULT_MAX_DELAY",
    "DEFAULT_WINDOW_S",
    "MIN_ROWS",
    "POOR_POSITION_ERROR",
    "AxisFit",
    "Identification",
    "Trace",
    "identify",
    "parse_columns",
    "poor_fits",
    "plant_mapping",
    "read_trace",
    "simulate_windows",
    "trace_from_arrays",
    "write_plant",
    "write_trace_csv",
]

DEFAULT_MAX_DELAY = 4
# an axis whose model misses the measured position by more than this share of its RMS (the
# held-out windows', else the fitted ones') is a poor fit: its parameters are not reported as
# identified. Good fits of the package's own excitation and of open-loop force traces on the
# named plants stay below 0.25 % (the friction table's random-phase disturbance: 0.2 %); the
# open-loop hsm2 trace of issue 50 whose y axis lost its friction missed by 1.4 %.
POOR_POSITION_ERROR = 0.005
RECORD_INSTEAD = (
    "record the program contour-env excite plans (constant-speed strokes with slow reversals, "
    "a chirp) with the command the drive computed at each sample (not the force after its "
    "delay), or fit this trace with --no-friction to see the rest"
)
DEFAULT_WINDOW_S = 0.4  # simulation window, s
MAX_FIT_SAMPLES = 40_000  # samples simulated per evaluation (windows spread over the trace)


def poor_fits(fits) -> dict:
    """{axis: one-line reason} of the axes whose model misses the measured position by more
    than POOR_POSITION_ERROR of its RMS (held-out windows, else the fitted ones)."""

    def err(f):
        e = f.holdout_error.get("position")
        return f.fit_error.get("position") if e is None else e

    errs = {f.axis: err(f) for f in fits}
    out = {}
    for f in fits:
        e = errs[f.axis]
        if e is None or not e > POOR_POSITION_ERROR:
            continue
        others = ", ".join(
            f"{a}: {v:.2%}" for a, v in errs.items() if a != f.axis and v is not None
        )
        where = "held-out" if f.holdout_error.get("position") is not None else "fitted"
        out[f.axis] = (
            f"axis {f.axis}: poor fit: the model misses the {where} position by {e:.2%} of its "
            f"RMS{' (' + others + ')' if others else ''}, above {POOR_POSITION_ERROR:.1%}: its "
            f"parameters are not reliable; {RECORD_INSTEAD}"
        )
    return out


def identify(
    trace: Trace,
    *,
    friction: bool = True,
    holdout: float = DEFAULT_HOLDOUT,
    max_delay: int = DEFAULT_MAX_DELAY,
    window_s: float = DEFAULT_WINDOW_S,
    force_limit=None,
    encoder_resolution=None,
    max_fit_samples: int = MAX_FIT_SAMPLES,
    log=None,
) -> Identification:
    """Fit the package's axis model to every axis of ``trace`` (see the module docstring).
    ``friction``: fit Coulomb/static friction and the Stribeck velocity (False: none);
    ``holdout``: the share at the end kept for validation (0 … 0.5); ``max_delay``: the largest
    delay searched, servo periods; ``window_s``: simulation window, s; ``force_limit`` and
    ``encoder_resolution``: one value or one per axis (default: the trace's largest command,
    its position quantum); ``max_fit_samples``: samples simulated per evaluation (windows
    spread evenly over the fitted part; fewer: faster, less precise); ``log``: a callable
    taking progress lines."""
    log = log or (lambda s: None)
    if not (isinstance(holdout, (int, float)) and 0 <= holdout <= 0.5):
        raise ValueError(f"holdout: must be in [0, 0.5], got {holdout!r}")
    if isinstance(max_delay, bool) or not isinstance(max_delay, (int, np.integer)):
        raise ValueError(f"max_delay: must be an integer in [0, 20], got {max_delay!r}")
    if not 0 <= max_delay <= 20:
        raise ValueError(f"max_delay: must be an integer in [0, 20], got {max_delay!r}")
    if isinstance(max_fit_samples, bool) or not isinstance(max_fit_samples, (int, np.integer)):
        raise ValueError(f"max_fit_samples: must be an integer >= 1000, got {max_fit_samples!r}")
    if max_fit_samples < 1000:
        raise ValueError(f"max_fit_samples: must be an integer >= 1000, got {max_fit_samples!r}")
    if not (isinstance(window_s, (int, float)) and math.isfinite(window_s) and window_s > 0):
        raise ValueError(f"window: must be > 0 s, got {window_s!r}")
    _check_trace_for_fit(trace, friction, holdout)
    A = len(trace.axes)
    limits = _per_axis("--force-limit", force_limit, A)
    if limits is None:
        limits = np.max(np.abs(trace.command), axis=0)
    res = _per_axis("--encoder-resolution", encoder_resolution, A)
    if res is None:
        res = np.array([_quantum(trace.position[:, j]) for j in range(A)])
    # one BLAS thread: the fits' matrices are small (SVDs of ~10 columns), and OpenBLAS's
    # threads only contend for them: 27.6 s against 40.6 s on linear-motor, 2 cores, alone,
    # 28.3 s against 57.7 s beside a second identification (threadpoolctl: it limits every
    # BLAS loaded, whichever numpy and scipy were built with)
    with threadpool_limits(limits=1, user_api="blas"):
        fits = [_fit_one(trace, j, friction, holdout, max_delay, window_s, limits, res,
                         max_fit_samples, log) for j in range(A)]  # fmt: skip
    return _identification(trace, fits, friction, holdout, max_delay, window_s)


def _fit_one(trace, j, friction, holdout, max_delay, window_s, limits, res, max_fit_samples, log):
    log(f"axis {trace.axes[j]}:")
    return _fit_axis(
        trace,
        j,
        friction=friction,
        holdout=float(holdout),
        max_delay=int(max_delay),
        window_s=float(window_s),
        limit=limits[j],
        resolution=res[j],
        max_fit_samples=int(max_fit_samples),
        log=log,
    )


def _identification(trace, fits, friction, holdout, max_delay, window_s) -> Identification:
    warnings = []
    poor = poor_fits(fits)
    for f in fits:
        if f.axis in poor:
            warnings.append(poor[f.axis])
        if f.friction_cost_reduction is not None and "coulomb" not in f.fitted:
            if f.axis in poor:
                warnings.append(
                    f"axis {f.axis}: friction set to 0 on a poor fit: not evidence that the axis "
                    "has none"
                )
                continue
            warnings.append(
                f"axis {f.axis}: friction lowered the fit's cost by {f.friction_cost_reduction:.1%}"
                " only (kept from 20 %): not identified, set to 0 — friction the trace cannot "
                "tell from none"
            )
        if f.delay_periods > 1:
            warnings.append(
                f"axis {f.axis}: a delay of {f.delay_periods} servo periods; the package's model "
                "holds at most one (computation_delay), the plant file keeps one"
            )
    delays = {f.delay_periods >= 1 for f in fits}
    if len(delays) > 1:
        warnings.append(
            "the axes have different delays (0 and >= 1 periods); the package's model has one "
            "computation delay for the whole plant: the plant file takes the majority"
        )
    return Identification(
        poor_fit=poor,
        trace=trace,
        axes=fits,
        settings={
            "friction": bool(friction),
            "holdout": float(holdout),
            "max_delay": int(max_delay),
            "window_s": float(window_s),
            "columns": {a: list(c) for a, c in trace.columns.items()},
        },
        warnings=warnings,
    )
