"""The ISO 230-4 circular test (the "ballbar" test) of a feed-drive plant under a controller.

A circle of radius R (m) about a nominal centre in the plant's x–y plane (a 3-axis plant holds
z = 0), run at a constant feed F (m/s) **clockwise and counter-clockwise**. Each run is one
arc of the package's path machinery (:func:`contour_env.paths.arc`): a feed-in overshoot arc
of ``overshoot_deg`` degrees, the 360° data-capture arc from ``start_deg`` (default 0°, the
+x axis), and a feed-out overshoot arc of the same angle. The feed ramps up (cosine S-curve,
``max_accel_m_s2``, ``max_jerk_m_s3``) inside the feed-in arc and down inside the feed-out arc,
so the reference runs at the steady feed F over the whole capture arc; the rest of the feed-in
arc is time for the servo's start-up transient to die out. The overshoot defaults to
:data:`DEFAULT_OVERSHOOT_DEG` = 180° (half a revolution of settling before the capture: at
the usual ballbar feeds the feed ramp takes a small part of it); it must lie in
(0°, 360°] and hold the whole feed ramp (:func:`circular_test_errors`).

Every figure is computed on the data-capture arc only: the samples of the true tool position
(x, y, m; the plant's true position, as a ballbar measures it, not the encoder reading) whose
polar angle about the nominal centre, counted along the direction of travel from the start of
the path, lies in [overshoot, overshoot + 360°). The metrics (ISO 230-4 terms, each in µm in
the report):

- **circular deviation G** — the range max r − min r of the radius about the **least-squares
  circle centre** of the run (:func:`fit_lsq_circle`: the geometric least-squares circle,
  minimising Σ (|p_i − c| − ρ)², started from the linear Kåsa fit): the radial width of the
  smallest zone of two circles concentric with the LSQ circle that holds the path;
- **radial deviations F_max, F_min** — the largest and smallest r − R, with r about the
  **nominal centre** and R the nominal radius (ISO 230-4's radial deviation F with the
  instrument centred on the nominal centre, as a ballbar is): F_max > 0 is the path outside
  the nominal circle, F_min < 0 inside;
- **circular hysteresis H** — the largest radial difference |r_cw(θ) − r_ccw(θ)| between the
  two directions at the same angle θ, both radii about **one** centre: the least-squares
  centre of the CW and CCW capture data together (so a centre shift between the directions,
  lost motion, counts as hysteresis, while a common offset of the set-up does not); each run's
  r(θ) is interpolated linearly (periodic in θ) onto a common grid of
  :data:`HYSTERESIS_GRID_DEG` = 0.1°;
- **reversal spikes** — at each axis reversal of the circle (x reverses at 0° and 180°, y at
  90° and 270°, angles about the nominal centre), with d = r − ρ the radial deviation about
  the run's LSQ circle and φ the angle past the reversal in the direction of travel: the
  baseline is the median of d over the windows φ ∈ [−W, 0) (before the reversal) and
  φ ∈ (W, 2W] (after the spike), the spike window is φ ∈ [0, W], and the height is the d of
  largest |d − baseline| in the spike window minus the baseline (signed: > 0 outward, as a
  friction spike, < 0 inward). W = ``spike_window_deg``, default
  :data:`DEFAULT_SPIKE_WINDOW_DEG` = 10° (44 ms at 0.2 m/s on r = 50 mm: a friction spike of
  a servo of some tens of rad/s rises and decays within it).

The metric functions (:func:`fit_lsq_circle`, :func:`circular_deviation`,
:func:`radial_deviation`, :func:`circular_hysteresis`, :func:`reversal_spikes`,
:func:`capture_arc`) are pure numpy on x, y arrays (m) and return metres and degrees, so they
run on synthetic traces. :func:`run_circular_test` runs controllers on a plant with the
package's episode loop (:func:`contour_env.evaluation.run_episode`); it takes a factory per
controller (the library does not import ``agents``; ``contour_env.app.circular_test_run``
builds the factories from controller names).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping

import numpy as np

from .paths.feed import ramp_time
from .paths.gcode import MAX_FEED_M_S

__all__ = [
    "DEFAULT_FEED_M_S",
    "DEFAULT_OVERSHOOT_DEG",
    "DEFAULT_RADIUS_M",
    "DEFAULT_SPIKE_WINDOW_DEG",
    "DIRECTIONS",
    "HYSTERESIS_GRID_DEG",
    "REVERSALS",
    "capture_arc",
    "circle_metrics",
    "circular_deviation",
    "circular_hysteresis",
    "circular_path",
    "circular_test_errors",
    "fit_lsq_circle",
    "max_circle_feed_m_s",
    "polar",
    "radial_deviation",
    "reversal_spikes",
    "run_circular_test",
]

DEFAULT_RADIUS_M = 0.05
DEFAULT_FEED_M_S = 0.2
# feed-in and feed-out overshoot arcs, degrees each
DEFAULT_OVERSHOOT_DEG = 180.0
OVERSHOOT_MAX_DEG = 360.0
# reversal-spike window W, degrees (spike window [0, W], baselines [−W, 0) and (W, 2W])
DEFAULT_SPIKE_WINDOW_DEG = 10.0
# the common angle grid of the hysteresis, degrees
HYSTERESIS_GRID_DEG = 0.1
# the feed ramp of the runs (the named circle cases' limits), m/s², m/s³, and the settle time, s
DEFAULT_MAX_ACCEL_M_S2 = 2.0
DEFAULT_MAX_JERK_M_S3 = 40.0
DEFAULT_SETTLE_S = 0.1
# the axis reversals of a circle: (angle about the centre in degrees, the axis that reverses)
REVERSALS = ((0.0, "x"), (90.0, "y"), (180.0, "x"), (270.0, "y"))
# direction name → sign of travel about +z (ccw: counter-clockwise seen from +z)
DIRECTIONS = {"cw": -1, "ccw": 1}
UNITS = {
    "radius_m": "m",
    "feed_m_s": "m/s",
    "overshoot_deg": "degrees",
    "angles": "degrees, counter-clockwise from +x about the nominal centre",
    "deviations": "µm",
}

Factory = Callable[[object], object]


# ----------------------------------------------------------------------------------------
# the path
# ----------------------------------------------------------------------------------------


def circular_path(
    radius_m: float,
    direction: str,
    overshoot_deg: float = DEFAULT_OVERSHOOT_DEG,
    *,
    center_m=(0.0, 0.0),
    start_deg: float = 0.0,
):
    """The path of one run: a single arc of radius ``radius_m`` (m) about ``center_m`` (x, y
    in m, z = 0) that starts ``overshoot_deg`` degrees before ``start_deg`` (degrees from +x)
    and sweeps 360° + 2 × overshoot, clockwise (``direction="cw"``) or counter-clockwise
    (``"ccw"``) seen from +z: feed-in arc, data-capture arc from ``start_deg`` round to it,
    feed-out arc. A :class:`~contour_env.paths.PathGeometry` (2-D: the x–y plane)."""
    from .paths import arc

    sign = _direction_sign(direction)
    ov = math.radians(float(overshoot_deg))
    cx, cy = (float(v) for v in center_m)
    return arc(
        (cx, cy, 0.0),
        float(radius_m),
        start_angle=math.radians(float(start_deg)) - sign * ov,
        sweep=sign * (2 * math.pi + 2 * ov),
    )


def _direction_sign(direction: str) -> int:
    if direction not in DIRECTIONS:
        raise ValueError(f"direction: 'cw' or 'ccw', got {direction!r}")
    return DIRECTIONS[direction]


# ----------------------------------------------------------------------------------------
# metrics on a trace (pure numpy; metres and degrees)
# ----------------------------------------------------------------------------------------


def _xy(x, y) -> tuple[np.ndarray, np.ndarray]:
    x = np.asarray(x, dtype=np.float64).reshape(-1)
    y = np.asarray(y, dtype=np.float64).reshape(-1)
    if x.shape != y.shape:
        raise ValueError(f"x, y: same length needed, got {x.size} and {y.size}")
    if x.size < 3:
        raise ValueError(f"x, y: at least 3 points needed, got {x.size}")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        raise ValueError("x, y: values must be finite")
    return x, y


def polar(x, y, center_m) -> tuple[np.ndarray, np.ndarray]:
    """(angle in degrees in [0, 360), counter-clockwise from +x; radius in m) of the points
    ``x``, ``y`` (m) about ``center_m`` (x, y in m)."""
    x, y = _xy(x, y)
    dx, dy = x - float(center_m[0]), y - float(center_m[1])
    return np.degrees(np.arctan2(dy, dx)) % 360.0, np.hypot(dx, dy)


def fit_lsq_circle(x, y) -> tuple[float, float, float]:
    """The least-squares circle of the points ``x``, ``y`` (m): (centre x, centre y, radius),
    all in m. Geometric fit (minimises Σ (|p_i − c| − ρ)², ISO 230-4's least-squares circle)
    by Gauss–Newton from the linear Kåsa fit (which minimises Σ (|p_i − c|² − ρ²)²); the
    coordinates are taken about their mean, so µm deviations on a circle of centimetres keep
    their digits."""
    x, y = _xy(x, y)
    x0, y0 = float(np.mean(x)), float(np.mean(y))
    u, v = x - x0, y - y0
    a = np.column_stack([2 * u, 2 * v, np.ones_like(u)])
    (cu, cv, c), *_ = np.linalg.lstsq(a, u * u + v * v, rcond=None)
    rho = math.sqrt(max(c + cu * cu + cv * cv, 0.0))
    for _ in range(50):
        du, dv = u - cu, v - cv
        d = np.hypot(du, dv)
        if np.any(d == 0):
            break
        res = d - rho
        jac = np.column_stack([-du / d, -dv / d, -np.ones_like(d)])
        step, *_ = np.linalg.lstsq(jac, -res, rcond=None)
        cu, cv, rho = cu + step[0], cv + step[1], rho + step[2]
        if np.max(np.abs(step)) <= 1e-15 * max(1.0, rho):
            break
    return x0 + float(cu), y0 + float(cv), float(rho)


def circular_deviation(x, y) -> float:
    """ISO 230-4 circular deviation G (m): max r − min r of the points ``x``, ``y`` (m) about
    their least-squares circle centre (:func:`fit_lsq_circle`)."""
    cx, cy, _ = fit_lsq_circle(x, y)
    _, r = polar(x, y, (cx, cy))
    return float(np.max(r) - np.min(r))


def radial_deviation(x, y, center_m, radius_m) -> tuple[float, float]:
    """ISO 230-4 radial deviations (F_max, F_min) in m: the largest and smallest r − R of the
    points ``x``, ``y`` (m), r about the **nominal** centre ``center_m`` (x, y in m) and R the
    nominal radius ``radius_m`` (m). F_max > 0: outside the nominal circle; F_min < 0: inside."""
    _, r = polar(x, y, center_m)
    dev = r - float(radius_m)
    return float(np.max(dev)), float(np.min(dev))


def _profile_on_grid(angle_deg, radius_m, grid_deg) -> np.ndarray:
    # r(θ) interpolated linearly on the grid, periodic in θ (360°); np.interp sorts xp itself
    # when a period is given
    return np.interp(grid_deg, angle_deg, radius_m, period=360.0)


def circular_hysteresis(
    x_cw, y_cw, x_ccw, y_ccw, *, grid_deg: float = HYSTERESIS_GRID_DEG
) -> float:
    """ISO 230-4 circular hysteresis H (m): the largest |r_cw(θ) − r_ccw(θ)| over a common
    angle grid of ``grid_deg`` degrees, each run's radius r(θ) (m) about the least-squares
    centre of both runs' points together and interpolated linearly (periodic) onto the grid.
    ``x_cw`` … ``y_ccw``: the two runs' capture-arc points, m."""
    xc, yc = _xy(x_cw, y_cw)
    xa, ya = _xy(x_ccw, y_ccw)
    step = float(grid_deg)
    if not (math.isfinite(step) and 0 < step <= 10):
        raise ValueError(f"grid_deg: must be > 0 and <= 10 degrees, got {grid_deg!r}")
    cx, cy, _ = fit_lsq_circle(np.concatenate([xc, xa]), np.concatenate([yc, ya]))
    grid = np.arange(0.0, 360.0, step)
    r_cw = _profile_on_grid(*polar(xc, yc, (cx, cy)), grid)
    r_ccw = _profile_on_grid(*polar(xa, ya, (cx, cy)), grid)
    return float(np.max(np.abs(r_cw - r_ccw)))


def reversal_spikes(
    x,
    y,
    direction: str,
    *,
    window_deg: float = DEFAULT_SPIKE_WINDOW_DEG,
    center_m=None,
) -> list[dict]:
    """The reversal spikes of one run: one dict per axis reversal (:data:`REVERSALS`) with
    ``angle_deg`` (the reversal, degrees), ``axis`` ("x" or "y"), ``height_m`` (m, signed:
    > 0 outward) and ``peak_angle_deg`` (degrees, where the spike peaks); ``height_m`` and
    ``peak_angle_deg`` are None when a window holds no sample.

    ``x``, ``y`` (m): the capture-arc points; ``direction``: "cw" or "ccw" (the spike follows
    the reversal in the direction of travel). With W = ``window_deg`` (degrees, in (0, 30])
    and d = r − ρ about the least-squares circle (:func:`fit_lsq_circle`; ``center_m``, x, y in
    m, overrides its centre, ρ is then the mean radius about it), φ the angle past the
    reversal along the travel: baseline = median of d over φ ∈ [−W, 0) ∪ (W, 2W], height = the
    d of largest |d − baseline| over φ ∈ [0, W] minus the baseline."""
    sign = _direction_sign(direction)
    w = float(window_deg)
    if not (math.isfinite(w) and 0 < w <= 30):
        raise ValueError(f"window_deg: must be > 0 and <= 30 degrees, got {window_deg!r}")
    if center_m is None:
        cx, cy, rho = fit_lsq_circle(x, y)
        theta, r = polar(x, y, (cx, cy))
    else:
        theta, r = polar(x, y, center_m)
        rho = float(np.mean(r))
    d = r - rho
    out = []
    for rev_deg, axis in REVERSALS:
        phi = (sign * (theta - rev_deg) + 180.0) % 360.0 - 180.0  # in [−180, 180)
        spike = (phi >= 0) & (phi <= w)
        base = ((phi >= -w) & (phi < 0)) | ((phi > w) & (phi <= 2 * w))
        row = {"angle_deg": rev_deg, "axis": axis, "height_m": None, "peak_angle_deg": None}
        if spike.any() and base.any():
            baseline = float(np.median(d[base]))
            k = int(np.argmax(np.abs(d[spike] - baseline)))
            row["height_m"] = float(d[spike][k] - baseline)
            row["peak_angle_deg"] = float(theta[spike][k])
        out.append(row)
    return out


def capture_arc(
    x, y, center_m, direction: str, overshoot_deg: float, *, start_deg: float = 0.0
) -> np.ndarray:
    """Indices of the samples on the 360° data-capture arc of a run: the points ``x``, ``y``
    (m, in time order from the start of the path) whose polar angle about ``center_m`` (x, y in
    m), unwrapped along the run and counted in the direction of travel from the path's start
    angle (``start_deg`` − overshoot, degrees), lies in [overshoot, overshoot + 360°). Empty
    when the run never reached the end of the capture arc (a run stopped early)."""
    sign = _direction_sign(direction)
    x, y = _xy(x, y)
    psi = np.unwrap(np.arctan2(y - float(center_m[1]), x - float(center_m[0])))
    ov = math.radians(float(overshoot_deg))
    start = math.radians(float(start_deg)) - sign * ov
    # the start angle on the branch of the first sample (the tool starts at the path start)
    start += 2 * math.pi * round((psi[0] - start) / (2 * math.pi))
    travel = sign * (psi - start)
    if not np.max(travel) >= ov + 2 * math.pi:
        return np.zeros(0, dtype=np.int64)
    return np.flatnonzero((travel >= ov) & (travel < ov + 2 * math.pi))


def _um(value_m):
    return None if value_m is None else round(float(value_m) * 1e6, 4)


def circle_metrics(
    x,
    y,
    center_m,
    radius_m,
    direction: str,
    *,
    spike_window_deg: float = DEFAULT_SPIKE_WINDOW_DEG,
) -> dict:
    """One run's figures as the report gives them (µm, degrees): ``circular_deviation_um``
    (G), ``radial_deviation_max_um`` and ``radial_deviation_min_um`` (F_max, F_min about the
    nominal centre ``center_m`` (x, y in m) and radius ``radius_m`` (m)),
    ``reversal_spikes_um`` (a list per reversal: ``angle_deg``, ``axis``, ``height_um``,
    ``peak_angle_deg``), ``lsq_center_offset_um`` (the LSQ centre minus the nominal centre,
    x and y), ``lsq_radius_deviation_um`` (LSQ radius − R) and ``samples``. ``x``, ``y``: the
    capture-arc points, m."""
    cx, cy, rho = fit_lsq_circle(x, y)
    f_max, f_min = radial_deviation(x, y, center_m, radius_m)
    spikes = reversal_spikes(x, y, direction, window_deg=spike_window_deg)
    return {
        "circular_deviation_um": _um(circular_deviation(x, y)),
        "radial_deviation_max_um": _um(f_max),
        "radial_deviation_min_um": _um(f_min),
        "reversal_spikes_um": [
            {
                "angle_deg": s["angle_deg"],
                "axis": s["axis"],
                "height_um": _um(s["height_m"]),
                "peak_angle_deg": None
                if s["peak_angle_deg"] is None
                else round(s["peak_angle_deg"], 3),
            }
            for s in spikes
        ],
        "lsq_center_offset_um": [_um(cx - float(center_m[0])), _um(cy - float(center_m[1]))],
        "lsq_radius_deviation_um": _um(rho - float(radius_m)),
        "samples": int(np.size(x)),
    }


# ----------------------------------------------------------------------------------------
# checks of a test's settings
# ----------------------------------------------------------------------------------------


def max_circle_feed_m_s(params, radius_m: float) -> float:
    """The largest feed (m/s) at which every axis of ``params`` (a
    :class:`~contour_env.plants.PlantParams`) can hold a circle of ``radius_m`` (m) at steady
    state: the force amplitude F √((m F / R)² + b²) of the sinusoidal axis motion (inertia m,
    viscous b) plus the Coulomb friction must stay within the axis's force (or velocity-command)
    limit. Capped at the G-code reader's feed limit (:data:`MAX_FEED_M_S`)."""
    m = np.asarray(params.mass_kg, dtype=np.float64)
    b = np.asarray(params.viscous_Ns_m, dtype=np.float64)
    c = np.asarray(params.coulomb_N, dtype=np.float64)
    lim = np.asarray(params.force_limit_N, dtype=np.float64)
    r = float(radius_m)

    def ok(f):
        return bool(np.all(f * np.sqrt((m * f / r) ** 2 + b**2) + c <= lim))

    if ok(MAX_FEED_M_S):
        return float(MAX_FEED_M_S)
    if not ok(0.0):
        return 0.0
    lo, hi = 0.0, float(MAX_FEED_M_S)
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if ok(mid) else (lo, mid)
    return lo


def _plant_error(plant, ideal):
    """(the Plant, None) or (None, the error text without the option name)."""
    from .plants import FIVE_AXIS_PLANT_ALIASES, Plant
    from .plants.catalog import plant_names

    supported = ", ".join(plant_names())
    if isinstance(plant, str) and plant in FIVE_AXIS_PLANT_ALIASES:
        return None, (
            f"the five-axis plant {plant!r} is not supported by the circular test (its joints "
            f"are not a pair of x–y feed drives); use a 2- or 3-axis plant: {supported}, or a "
            "JSON file of plant parameters"
        )
    if isinstance(plant, Mapping):
        axes = plant.get("axes", plant.get("axis_names", ("x", "y")))
        if isinstance(axes, (list, tuple)) and len(axes) < 2:
            return None, (
                f"a plant with {len(axes)} axis is not supported by the circular test: it needs "
                "2 or 3 axes (x, y)"
            )
    try:
        obj = Plant(plant, ideal=bool(ideal))
    except ValueError as exc:
        text = str(exc)
        return None, text[len("plant: ") :] if text.startswith("plant: ") else text
    if obj.n_axes < 2:
        return None, (
            f"the plant {obj.name!r} has {obj.n_axes} axis; the circular test needs 2 or 3 axes "
            "(x, y)"
        )
    return obj, None


def circular_test_errors(
    plant,
    radius_m,
    feed_m_s,
    overshoot_deg=DEFAULT_OVERSHOOT_DEG,
    *,
    ideal: bool = False,
    max_accel_m_s2: float = DEFAULT_MAX_ACCEL_M_S2,
    max_jerk_m_s3: float = DEFAULT_MAX_JERK_M_S3,
    labels: Mapping[str, str] | None = None,
) -> list[str]:
    """Every bad setting of a circular test, one ``"name: rule, got value"`` text each ([] when
    all are good); ``labels`` renames the parameters in the texts (the CLI's options:
    ``{"radius_m": "--radius", ...}``). The rules: ``plant`` a 2- or 3-axis plant (a name or a
    mapping of parameters; not the five-axis machine); ``radius_m`` > 0 and ≤ 10 m;
    ``feed_m_s`` > 0 m/s and no more than the plant can hold on the circle
    (:func:`max_circle_feed_m_s`); ``overshoot_deg`` in (0°, 360°] and long enough for the
    feed ramp (cosine S-curve within ``max_accel_m_s2``, ``max_jerk_m_s3``) to end inside the
    feed-in arc."""
    name = dict(
        plant="plant", radius_m="radius_m", feed_m_s="feed_m_s", overshoot_deg="overshoot_deg"
    )
    name.update(labels or {})
    errors = []
    plant_obj, text = _plant_error(plant, ideal)
    if text is not None:
        errors.append(f"{name['plant']}: {text}")

    def number(value):
        if isinstance(value, (bool, np.bool_)):
            return None
        try:
            v = float(value)
        except (TypeError, ValueError):
            return None
        return v if math.isfinite(v) else None

    r = number(radius_m)
    if r is None or not 0 < r <= 10.0:
        errors.append(f"{name['radius_m']}: must be > 0 and <= 10 m, got {radius_m!r}")
        r = None
    f = number(feed_m_s)
    if f is None or not 0 < f <= MAX_FEED_M_S:
        errors.append(
            f"{name['feed_m_s']}: must be > 0 and <= {MAX_FEED_M_S:g} m/s, got {feed_m_s!r}"
        )
        f = None
    elif plant_obj is not None and r is not None:
        f_max = max_circle_feed_m_s(plant_obj.params, r)
        if f > f_max:
            errors.append(
                f"{name['feed_m_s']}: must be > 0 and <= {f_max:.4g} m/s on plant "
                f"{plant_obj.name!r} at radius {r:g} m (faster, an axis needs more than its "
                f"force limit to hold the circle), got {f:g}"
            )
            f = None
    ov = number(overshoot_deg)
    if ov is None or not 0 < ov <= OVERSHOOT_MAX_DEG:
        errors.append(
            f"{name['overshoot_deg']}: must be > 0 and <= {OVERSHOOT_MAX_DEG:g} degrees, "
            f"got {overshoot_deg!r}"
        )
    elif r is not None and f is not None:
        ramp_m = 0.5 * f * ramp_time(f, float(max_accel_m_s2), float(max_jerk_m_s3))
        ramp_deg = math.degrees(ramp_m / r)
        if ramp_deg > ov:
            need = math.ceil(ramp_deg)
            hint = (
                f"use at least {need} degrees"
                if need <= OVERSHOOT_MAX_DEG
                else "lower the feed or enlarge the radius"
            )
            arc_mm = math.radians(ov) * r * 1e3
            errors.append(
                f"{name['overshoot_deg']}: {ov:g} degrees of feed-in arc ({arc_mm:.3g} mm)"
                f" is shorter than the feed ramp to {f:g} m/s ({ramp_m * 1e3:.3g} mm, "
                f"{ramp_deg:.1f} degrees at <= {max_accel_m_s2:g} m/s², <= {max_jerk_m_s3:g} "
                f"m/s³); {hint}"
            )
    return errors


# ----------------------------------------------------------------------------------------
# running the test
# ----------------------------------------------------------------------------------------


def run_circular_test(
    plant,
    controllers: Mapping[str, Factory | None],
    radius_m: float = DEFAULT_RADIUS_M,
    feed_m_s: float = DEFAULT_FEED_M_S,
    *,
    overshoot_deg: float = DEFAULT_OVERSHOOT_DEG,
    center_m=(0.0, 0.0),
    start_deg: float = 0.0,
    ideal: bool = False,
    seed: int = 0,
    spike_window_deg: float = DEFAULT_SPIKE_WINDOW_DEG,
    max_accel_m_s2: float = DEFAULT_MAX_ACCEL_M_S2,
    max_jerk_m_s3: float = DEFAULT_MAX_JERK_M_S3,
    settle_time_s: float = DEFAULT_SETTLE_S,
    progress: Callable[[str, str, dict], None] | None = None,
) -> dict:
    """Run the circular test of ``plant`` (a plant name or a mapping of parameters; 2 or 3
    axes) for every controller, CW and CCW, and return the report.

    ``controllers``: label → factory, ``factory(env)`` returning the policy bound to that env
    (SB3's ``predict``; the app layer builds them from names,
    :mod:`contour_env.app.circular_test_run`), or None for the zero command. Each run gets its
    own env (``gym.make(ENV_ID, plant=..., path=circular_path(...), feedrate_m_s=...)``) and
    runs from ``reset(seed=seed)`` with :func:`contour_env.evaluation.run_episode`.
    ``radius_m`` (m), ``feed_m_s`` (m/s), ``overshoot_deg``, ``start_deg`` (degrees),
    ``center_m`` (x, y in m) as :func:`circular_path`; ``spike_window_deg`` (degrees) as
    :func:`reversal_spikes`; the feed ramp within ``max_accel_m_s2`` (m/s²) and
    ``max_jerk_m_s3`` (m/s³), ``settle_time_s`` (s) at the end. ``progress(label, direction,
    row)`` after each run. ValueError (every bad setting, :func:`circular_test_errors`)
    before anything runs.

    Returns a JSON-ready dict (µm, degrees) — ``test``, ``plant``, ``ideal``, ``radius_m``,
    ``feed_m_s``, ``overshoot_deg``, ``start_deg``, ``center_m``, ``plane`` ("xy"),
    ``spike_window_deg``, ``hysteresis_grid_deg``, ``seed``, ``units``, ``results``:
    {label: {"cw": row, "ccw": row, "hysteresis_um": H}} with each row
    :func:`circle_metrics` plus ``completed`` (and ``incomplete_reason`` when a run did not
    follow the circle: its figures are then None) — plus ``traces`` (for plots, numpy arrays,
    not JSON): {label: {direction: {"angle_deg", "radial_deviation_um"}}}, the capture arc's
    angles about the nominal centre and r − R (µm)."""
    import gymnasium as gym

    from . import ENV_ID
    from .evaluation import run_episode

    errors = circular_test_errors(
        plant,
        radius_m,
        feed_m_s,
        overshoot_deg,
        ideal=ideal,
        max_accel_m_s2=max_accel_m_s2,
        max_jerk_m_s3=max_jerk_m_s3,
    )
    if not controllers:
        errors.append("controllers: none given")
    if errors:
        raise ValueError("; ".join(errors))
    r, f, ov = float(radius_m), float(feed_m_s), float(overshoot_deg)
    center = (float(center_m[0]), float(center_m[1]))
    paths = {d: circular_path(r, d, ov, center_m=center, start_deg=start_deg) for d in DIRECTIONS}
    # every controller bound to its envs first: one that cannot work with the plant (jee-ccc
    # on a force drive) is an error before any run
    bound = {}
    for label, factory in controllers.items():
        for direction in ("cw", "ccw"):
            env = gym.make(
                ENV_ID,
                plant=plant,
                path=paths[direction],
                feedrate_m_s=f,
                ideal=bool(ideal),
                max_accel_m_s2=float(max_accel_m_s2),
                max_jerk_m_s3=float(max_jerk_m_s3),
                settle_time_s=float(settle_time_s),
            )
            bound[label, direction] = (env, None if factory is None else factory(env))
    results, traces = {}, {}
    plant_name = None
    for label in controllers:
        runs, xy = {}, {}
        for direction in ("cw", "ccw"):
            env, policy = bound[label, direction]
            plant_name = env.unwrapped.plant.name
            record = run_episode(env, policy, seed=seed)
            row, arc = _score_run(record, center, r, direction, ov, start_deg, spike_window_deg)
            if arc is not None:
                xy[direction] = arc[:2]
                traces.setdefault(label, {})[direction] = arc[2]
            runs[direction] = row
            if progress:
                progress(label, direction, row)
        hyst = None
        if len(xy) == 2:
            hyst = _um(circular_hysteresis(*xy["cw"], *xy["ccw"]))
        results[label] = {"cw": runs["cw"], "ccw": runs["ccw"], "hysteresis_um": hyst}
    return {
        "test": "ISO 230-4 circular test",
        "plant": plant_name,
        "ideal": bool(ideal),
        "radius_m": r,
        "feed_m_s": f,
        "overshoot_deg": ov,
        "start_deg": float(start_deg),
        "center_m": list(center),
        "plane": "xy",
        "spike_window_deg": float(spike_window_deg),
        "hysteresis_grid_deg": HYSTERESIS_GRID_DEG,
        "seed": int(seed),
        "units": dict(UNITS),
        "results": results,
        "traces": traces,
    }


def _score_run(record, center, r, direction, ov, start_deg, spike_window_deg):
    """The row of one run (:func:`circle_metrics` and ``completed``, or ``completed`` False
    with the reason and None figures) and, when complete, (x, y, trace) of its capture arc
    (m; the trace as :func:`run_circular_test` returns it)."""
    pos = np.asarray(record.position, dtype=np.float64)
    ok = np.all(np.isfinite(pos[:, :2]), axis=1)
    reason = record.incomplete_reason
    idx = np.zeros(0, dtype=np.int64)
    if reason is None and ok.all():
        idx = capture_arc(pos[:, 0], pos[:, 1], center, direction, ov, start_deg=start_deg)
        if idx.size < 3:
            reason = "the tool did not run round the capture arc"
    elif reason is None:
        reason = "non-finite positions"
    if reason is not None:
        row = {
            "completed": False,
            "incomplete_reason": reason,
            "circular_deviation_um": None,
            "radial_deviation_max_um": None,
            "radial_deviation_min_um": None,
            "reversal_spikes_um": None,
        }
        return row, None
    x, y = pos[idx, 0], pos[idx, 1]
    row = {
        "completed": True,
        **circle_metrics(x, y, center, r, direction, spike_window_deg=spike_window_deg),
    }
    theta, rad = polar(x, y, center)
    return row, (x, y, {"angle_deg": theta, "radial_deviation_um": (rad - r) * 1e6})
