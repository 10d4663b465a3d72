"""Default gains under stability constraints: PD's ω and CCC's coupling for a plant.

The procedure that found the named plants' defaults (``scripts/tune_controllers.py``) and that
``contour-env tune`` runs on a plant of your own (the file ``contour-env identify`` writes):

- R1: every loop the controller closes keeps gain margin ≥ 6 dB and phase margin ≥ 30° over
  the ±20 % mass corners and the path directions (:func:`agents.margins.loop_margins`);
- R2: where the plant has a two-mass mode, the closed loop with it stays stable over the same
  corners with gain margin ≥ 2 dB and phase margin ≥ 10° (R1 then applies to the plant
  without the mode: a named plant's realistic plant, a plant file's with its stiffness 0).

A grid is screened with the fast margin estimate (let through within 0.5 dB / 3° of the
limits) and every point run is confirmed with the full computation.

- pd (Lee, Dixon & Ziegert 2012 §4: balanced, critically damped axes): the largest ω of
  ``PD_GRID`` (40–400 rad/s) meeting R1 and R2. Analytical; no path is run.
- ccc: the PD ω plus the cross-coupling PID (W_p, W_i, W_d) from ``CCC_GRID`` (coordinate
  search: W_i, then W_p, then W_d) meeting R1 and R2 with the lowest mean RMS contour error
  relative to PD over the **tuning paths**, keeping RMS effort per axis within +10 % and the
  max contour error within +5 % of PD's on each (a coupling that buys RMS with a higher peak
  at a corner is not one an engineer would take).

The tuning paths are never what is scored: the named plants' are in the script; a plant
file's are :func:`plant_tuning_paths` (a circle of 30 mm and a square of 40 mm turned by 30°,
or their 3-D forms), which are none of the named cases, the evaluation programs, the circular
test's default (R 50 mm) or the identification's held-out circle (R 20 mm).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import gymnasium as gym
import numpy as np

from contour_env import ENV_ID
from contour_env.circular_test import max_circle_feed_m_s
from contour_env.evaluation import run_episode
from contour_env.metrics import score
from contour_env.paths import circle, polyline
from contour_env.plants import Plant
from contour_env.plants.catalog import nominal_params

from .ccc import CCCController
from .margins import loop_margins, requirement
from .pd import PDController

__all__ = [
    "CCC_GRID",
    "PD_GRID",
    "TuningPath",
    "plant_tuning_paths",
    "run_paths",
    "tune_ccc",
    "tune_pd",
    "tune_plant_file",
]

PD_GRID = (40.0, 50.0, 60.0, 70.0, 75.0, 80.0, 85.0, 90.0, 100.0, 110.0, 120.0, 130.0, 140.0,
           150.0, 175.0, 200.0, 250.0, 300.0, 350.0, 400.0)  # fmt: skip
CCC_GRID = {
    "W_p": (0.0, 1e3, 3e3, 1e4, 3e4),
    "W_i": (0.0, 1e4, 3e4, 1e5, 3e5, 1e6, 3e6),
    "W_d": (0.0, 10.0, 30.0),
}
R1 = requirement(structural_mode=False)
R2 = requirement(structural_mode=True)
SCREEN_BUFFER = (-0.5, -3.0)
EFFORT_SLACK = 1.10
# the max contour error may not exceed PD's by more than this on any tuning path (a peak at a
# friction reversal, which cross-coupling cannot remove, moves by a few per cent either way)
MAX_SLACK = 1.05

#: (label, path geometry, feedrate m/s, max acceleration m/s², max jerk m/s³)
TuningPath = tuple


def meets(rep: dict, limits: tuple[float, float], buffer=(0.0, 0.0)) -> bool:
    """The margin report ``rep`` is stable and meets (gain margin dB, phase margin °)."""
    gm, pm = rep["min_gain_margin_db"], rep["min_phase_margin_deg"]
    return bool(
        rep["stable"]
        and gm is not None
        and pm is not None
        and gm >= limits[0] + buffer[0]
        and pm >= limits[1] + buffer[1]
    )


def _margin_cases(plant) -> list[tuple[str, object, bool, tuple[float, float]]]:
    """(report key, plant argument, structural_mode, limits) of the constraints on ``plant``
    (a named plant or a :class:`~contour_env.plants.Plant` of custom parameters)."""
    if isinstance(plant, str):
        cases = [("realistic", plant, False, R1)]
        if nominal_params(plant)[1].structural_mode_hz:
            cases.append(("structural_mode", plant, True, R2))
        return cases
    params = plant.params
    if not params.has_structural_mode:
        return [("realistic", plant, False, R1)]
    rigid = Plant(params.replace(structural_stiffness_N_m=np.zeros(params.n_axes)))
    return [("without_mode", rigid, False, R1), ("structural_mode", plant, False, R2)]


def constraints_hold(make: Callable, plant, screen: bool) -> tuple[bool, dict]:
    """R1 and R2 for the controller ``make()`` builds on ``plant``; (ok, the reports)."""
    buf = SCREEN_BUFFER if screen else (0.0, 0.0)
    reports = {}
    for key, arg, mode, limits in _margin_cases(plant):
        rep = loop_margins(make(), arg, structural_mode=mode, screen_only=screen)
        reports[key] = rep
        if not meets(rep, limits, buf):
            return False, reports
    return True, reports


def margin_summary(reps: dict) -> dict:
    """``{<case>_margins: {gain_margin_db, phase_margin_deg}}`` of the reports."""
    return {
        f"{k}_margins": {
            "gain_margin_db": round(v["min_gain_margin_db"], 2),
            "phase_margin_deg": round(v["min_phase_margin_deg"], 1),
        }
        for k, v in reps.items()
    }


def _env_plant(plant):
    return plant if isinstance(plant, str) else plant.params


def run_paths(plant, paths: list[TuningPath], make: Callable) -> list[dict]:
    """Run the controller ``make()`` builds on each tuning path; per path its completion, RMS
    and max contour error (µm) and RMS effort per axis."""
    out = []
    for label, geometry, feed, acc, jerk in paths:
        env = gym.make(
            ENV_ID,
            plant=_env_plant(plant),
            path=geometry,
            feedrate_m_s=feed,
            max_accel_m_s2=acc,
            max_jerk_m_s3=jerk,
        )
        m = score(run_episode(env, make().bind(env)))
        out.append(
            {
                "path": label,
                "completed": bool(m["completed"]),
                "rms_um": m["rms_contour_error_um"],
                "max_um": m["max_contour_error_um"],
                "effort": list(m["rms_effort"]),
            }
        )
    return out


def _quiet(progress):
    return progress if progress is not None else (lambda _s: None)


def tune_pd(plant, progress=None, grid=PD_GRID) -> dict:
    """The largest ω of ``grid`` (default ``PD_GRID``) whose PD loops meet R1 and R2 on
    ``plant`` (a named plant or a :class:`~contour_env.plants.Plant`):
    ``{"bandwidth_rad_s": ω or None, margins}``."""
    progress = _quiet(progress)
    best = None
    for w in grid:
        ok, _ = constraints_hold(lambda w=w: PDController(bandwidth_rad_s=w), plant, screen=True)
        progress(f"    pd ω = {w:g} rad/s: {'meets' if ok else 'fails'} the margins (screened)")
        if ok:
            best = w
    if best is None:
        return {"bandwidth_rad_s": None}
    # confirm with the full computation, stepping down the grid if the buffer was too thin
    for w in [g for g in grid if g <= best][::-1]:
        ok, reps = constraints_hold(lambda w=w: PDController(bandwidth_rad_s=w), plant, False)
        if ok:
            return {"bandwidth_rad_s": w, **margin_summary(reps)}
    return {"bandwidth_rad_s": None}


def _within_pd(runs: list[dict], base: list[dict]) -> bool:
    return all(
        np.all(np.asarray(r["effort"]) <= EFFORT_SLACK * np.asarray(b["effort"]))
        and r["max_um"] <= MAX_SLACK * b["max_um"]
        for r, b in zip(runs, base, strict=True)
    )


def tune_ccc(plant, omega: float, paths: list[TuningPath], progress=None) -> dict:
    """Coordinate search over ``CCC_GRID`` (see the module docstring) at PD's ``omega``:
    ``{"W_p", "W_i", "W_d", "tuning_rms_ratio_to_pd", margins}`` (the gains None when no point
    meets the constraints; all 0 when none beats PD)."""
    progress = _quiet(progress)
    base = run_paths(plant, paths, lambda: PDController(bandwidth_rad_s=omega))
    best = {"W_p": 0.0, "W_i": 0.0, "W_d": 0.0}
    best_ratio, best_reps = 1.0, None
    for key in ("W_i", "W_p", "W_d"):
        for value in CCC_GRID[key]:
            gains = {**best, key: value}

            def make(g=gains):
                return CCCController(bandwidth_rad_s=omega, **g)

            text = ", ".join(f"{k}={v:g}" for k, v in gains.items())
            if not constraints_hold(make, plant, screen=True)[0]:
                progress(f"    {text}: fails the margins (screened)")
                continue
            ok, reps = constraints_hold(make, plant, screen=False)
            if not ok:
                progress(f"    {text}: fails the margins")
                continue
            runs = run_paths(plant, paths, make)
            if not all(r["completed"] for r in runs):
                progress(f"    {text}: a tuning path did not complete")
                continue
            within = _within_pd(runs, base)
            ratio = float(
                np.mean([r["rms_um"] / b["rms_um"] for r, b in zip(runs, base, strict=True)])
            )
            progress(
                f"    {text}: RMS/PD {ratio:.3f}"
                + ("" if within else " (effort > +10 % or max > +5 % of PD's on a path)")
            )
            if within and (ratio < best_ratio or best_reps is None):
                best_ratio, best_reps, chosen = ratio, reps, dict(gains)
        if best_reps is not None:
            best = chosen
    if best_reps is None:
        return {"W_p": None, "W_i": None, "W_d": None}
    return {**best, "tuning_rms_ratio_to_pd": round(best_ratio, 4), **margin_summary(best_reps)}


# the tuning paths of a plant file (plant_tuning_paths): sizes in m, the circle's start angle
TUNING_CIRCLE_RADIUS_M = 0.03
TUNING_CIRCLE_START_RAD = 0.5
TUNING_SQUARE_SIDE_M = 0.04
TUNING_SQUARE_ANGLE_DEG = 30.0
# the circle's feed: this share of the plant's highest steady circle feed at that radius,
# within TUNING_FEED_CAP_M_S; the square at half of it
TUNING_FEED_SHARE = 0.4
TUNING_FEED_CAP_M_S = 0.25
# acceleration: this share of the smallest (force limit − static friction) / mass, within the
# circular test's 2 m/s²; jerk 20 × the acceleration per second
TUNING_ACCEL_SHARE = 0.25
TUNING_ACCEL_CAP_M_S2 = 2.0


def _turned_square(side_m: float, angle_deg: float) -> np.ndarray:
    a = math.radians(angle_deg)
    R = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    corners = np.array([[0, 0], [side_m, 0], [side_m, side_m], [0, side_m], [0, 0]]) @ R.T
    return corners


def plant_tuning_paths(params) -> list[TuningPath]:
    """The tuning paths of a plant of your own (:class:`~contour_env.plants.PlantParams`):

    - 2 axes: a circle of 30 mm from 0.5 rad, and a square of 40 mm turned by 30° (corners
      not axis-aligned: exact stops where CCC's coupling must hold);
    - 3 axes: the circle in the plane normal to (0.5, 0.3, 0.81), and a 3-D polyline of three
      legs of 20–25 mm turning by 60–100°.

    Feed: 40 % of the plant's highest steady feed on that circle (force limit against inertia,
    viscous and Coulomb friction; :func:`contour_env.circular_test.max_circle_feed_m_s`),
    at most 0.25 m/s; the corner path at half of it. Acceleration: a quarter of the smallest
    (force limit − static friction) / mass, at most 2 m/s²; jerk 20 × that per second.
    """
    n = params.n_axes
    r = TUNING_CIRCLE_RADIUS_M
    feed = min(TUNING_FEED_CAP_M_S, TUNING_FEED_SHARE * max_circle_feed_m_s(params, r))
    if not feed > 0:
        raise ValueError(
            f"plant {params.name!r}: its force limit does not hold a circle of {r * 1e3:g} mm "
            "at any feed (force_limit at or below the friction): nothing to tune on"
        )
    headroom = np.min((params.force_limit_N - params.static_N) / params.mass_kg)
    acc = float(min(TUNING_ACCEL_CAP_M_S2, TUNING_ACCEL_SHARE * headroom))
    jerk = 20.0 * acc
    mm = f"{feed * 1e3:.4g} mm/s"
    if n == 2:
        ring = circle((0, 0, 0), r, start_angle=TUNING_CIRCLE_START_RAD)
        corner = polyline(_turned_square(TUNING_SQUARE_SIDE_M, TUNING_SQUARE_ANGLE_DEG))
        corner_label = f"square {TUNING_SQUARE_SIDE_M * 1e3:g} mm at {TUNING_SQUARE_ANGLE_DEG:g}°"
    else:
        normal = np.array([0.5, 0.3, 0.81])
        ring = circle(
            (0, 0, 0), r, normal=tuple(normal / np.linalg.norm(normal)),
            start_angle=TUNING_CIRCLE_START_RAD,
        )  # fmt: skip
        corner = polyline([(0, 0, 0), (0.02, 0.006, 0.003), (0.008, 0.024, 0.011),
                           (0.022, 0.03, 0.028)])  # fmt: skip
        corner_label = "3-D polyline, three legs of 20–25 mm"
    return [
        (f"circle r={r * 1e3:g} mm, {mm}", ring, feed, acc, jerk),
        (f"{corner_label}, {0.5 * feed * 1e3:.4g} mm/s", corner, 0.5 * feed, acc, jerk),
    ]


def tune_plant_file(
    plant: Plant, controllers=("pd", "ccc"), progress=None, max_bandwidth_rad_s=None
) -> dict:
    """Tune PD's ω (and CCC's coupling at that ω, when ``"ccc"`` is asked) on a plant of your
    own, ω at most ``max_bandwidth_rad_s`` (a bound the model cannot show, e.g. a structural
    resonance); the result's ``controller_gains`` is what a plant file carries
    (:mod:`contour_env.plants.gains`). ValueError when no ω meets the margins."""
    progress = _quiet(progress)
    grid = PD_GRID
    if max_bandwidth_rad_s is not None:
        grid = tuple(w for w in PD_GRID if w <= max_bandwidth_rad_s)
        if not grid:
            raise ValueError(
                f"max_bandwidth_rad_s: at least {PD_GRID[0]:g} rad/s (the grid is "
                f"{PD_GRID[0]:g}–{PD_GRID[-1]:g}), got {max_bandwidth_rad_s!r}"
            )
    paths = plant_tuning_paths(plant.params) if "ccc" in controllers else []
    out: dict = {"plant": plant.params.name, "tuning_paths": [p[0] for p in paths]}
    out["pd"] = tune_pd(plant, progress, grid)
    omega = out["pd"]["bandwidth_rad_s"]
    if omega is None:
        raise ValueError(
            f"plant {plant.params.name!r}: no PD bandwidth of {grid[0]:g}–{grid[-1]:g} "
            f"rad/s keeps gain margin >= {R1[0]:g} dB and phase margin >= {R1[1]:g} deg over "
            "±20 % mass (check the servo period, delay and current-loop lag in the file)"
        )
    out["pd"]["grid_rad_s"] = [grid[0], grid[-1]]
    progress(f"  pd: ω = {omega:g} rad/s")
    gains = {"pd": {"bandwidth_rad_s": omega}}
    if "ccc" in controllers:
        out["ccc"] = tune_ccc(plant, omega, paths, progress)
        if out["ccc"]["W_i"] is not None:
            gains["ccc"] = {k: out["ccc"][k] for k in ("W_p", "W_i", "W_d")}
    out["controller_gains"] = gains
    return out
