"""Reproduce the default controller gains of agents/ under stability constraints.

Constraints (every plant, every default gain set; agents.margins on the realistic plant):

- R1: every loop the controller closes keeps gain margin ≥ 6 dB and phase margin ≥ 30° over
  the ±20 % mass corners and the path directions (``loop_margins(..., mass_variation=0.2)``);
- R2: with the plant's two-mass mode (``structural_mode=True``, where the plant has one) the
  closed loop stays stable over the same corners with gain margin ≥ 2 dB and phase margin
  ≥ 10°, so the episode is bounded with no limit cycle.

The search screens a grid with the fast margin estimate (read off the frequency grid; it is
let through within 0.5 dB / 3° of the limits, since its error on a sharp resonance is of
that order) and confirms every point it runs with the full computation.

Criteria:

- pd: Lee 2012 §4, balanced axes (one critically damped ω for every axis): the largest ω of
  ``PD_GRID`` (40–400 rad/s) that meets R1 and R2. Analytical; no path is run.
- ccc: the PD gains plus the cross-coupling PID (W_p, W_i, W_d) from ``CCC_GRID`` (coordinate
  search: W_i, then W_p, then W_d) that meets R1 and R2 with the lowest mean RMS contour error
  relative to PD over the plant's **tuning paths** (``TUNING_PATHS``), RMS effort per axis
  within +10 % of PD's and the max contour error within +5 % of PD's on each (Lee: PD first,
  then CCC; Lee's tables report max and RMS, and a cross-coupling that buys RMS with a higher
  peak at a corner is not one an engineer would take).
- adaptive-ccc: the same ω as PD (so the same P and D action); its coupling and adaptation
  follow the rules in agents/adaptive_ccc.py (no search here).
- jee-ccc: from Jee's design chart (``contour-env stability``; agents/jee_ccc.py).

The tuning paths are circles, arcs and corners of other radii, feeds, angles and planes than
the named cases (contour_env/cases.py) and the evaluation programs (contour_env/data,
tests/data): none of them is scored anywhere, and the named cases are never run here.

Usage: ``python scripts/tune_controllers.py [--plants hsm2,friction-table,...] [--json OUT]``.
"""

from __future__ import annotations

import argparse
import math
import sys

import gymnasium as gym
import numpy as np

import contour_env  # noqa: F401
from agents.ccc import CCCController
from agents.margins import loop_margins, requirement
from agents.pd import PDController
from contour_env import ENV_ID
from contour_env.evaluation import run_episode
from contour_env.io import atomic_write_json
from contour_env.metrics import score
from contour_env.paths import circle, polyline

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


def _rotated_square(side_m: float, angle_deg: float, dim: int = 2) -> np.ndarray:
    a = math.radians(angle_deg)
    R = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    corners = np.array([[0, 0], [side_m, 0], [side_m, side_m], [0, side_m], [0, 0]]) @ R.T
    return np.column_stack([corners, np.zeros(len(corners))])[:, : max(dim, 2)]


def _tilted_normal(tilt_deg: float, about: str) -> tuple[float, float, float]:
    t = math.radians(tilt_deg)
    return (math.sin(t), 0.0, math.cos(t)) if about == "y" else (0.0, -math.sin(t), math.cos(t))


# (label, path geometry, feedrate m/s, max acceleration m/s², max jerk m/s³) per plant
TUNING_PATHS = {
    "hsm2": [
        ("circle r=80 mm, 0.3 m/s", circle((0, 0, 0), 0.08, start_angle=0.5), 0.3, 2.0, 40.0),
        ("square 50 mm at 30°", polyline(_rotated_square(0.05, 30.0)), 0.15, 2.0, 40.0),
    ],
    "friction-table": [
        ("circle r=15 mm, 15 mm/s", circle((0, 0, 0), 0.015, start_angle=0.3), 0.015, 0.5, 10.0),
        (
            "120° corner at 20°",
            polyline(
                [
                    (0, 0, 0),
                    (0.025 * math.cos(0.35), 0.025 * math.sin(0.35), 0),
                    (
                        0.025 * math.cos(0.35) + 0.025 * math.cos(0.35 + 2.094),
                        0.025 * math.sin(0.35) + 0.025 * math.sin(0.35 + 2.094),
                        0,
                    ),
                ]
            ),
            0.015,
            0.5,
            10.0,
        ),  # fmt: skip
    ],
    "linear-motor": [
        (
            "arc r=0.3 m, 40°, plane tilted 45° about y, 0.04 m/s",
            circle(
                (0, 0, 0),
                0.3,
                normal=_tilted_normal(45.0, "y"),
                start_angle=-0.35,
                sweep=math.radians(40.0),
            ),
            0.04,
            0.5,
            10.0,
        ),  # fmt: skip
        (
            "3-D corner, 20 mm legs, 0.03 m/s",
            polyline([(0, 0, 0), (0.02, 0.005, 0.004), (0.024, 0.022, 0.01)]),
            0.03,
            0.5,
            10.0,
        ),  # fmt: skip
    ],
    "jee-triaxial": [
        (
            "circle r=40 mm ⟂ (1,−1,1), 8 m/min",
            circle((0, 0, 0), 0.04, normal=(1 / math.sqrt(3), -1 / math.sqrt(3), 1 / math.sqrt(3))),
            8.0 / 60.0,
            2.0,
            40.0,
        ),  # fmt: skip
    ],
}


def meets(rep: dict, limits: tuple[float, float], buffer=(0.0, 0.0)) -> bool:
    gm, pm = rep["min_gain_margin_db"], rep["min_phase_margin_deg"]
    return bool(
        rep["stable"]
        and gm is not None
        and pm is not None
        and gm >= limits[0] + buffer[0]
        and pm >= limits[1] + buffer[1]
    )


def has_mode(plant: str) -> bool:
    from contour_env.plants.catalog import nominal_params

    return bool(nominal_params(plant)[1].structural_mode_hz)


def constraints_hold(make, plant: str, screen: bool) -> tuple[bool, dict]:
    """R1 and R2 for the controller ``make()`` builds; returns (ok, the two reports)."""
    buf = SCREEN_BUFFER if screen else (0.0, 0.0)
    r1 = loop_margins(make(), plant, screen_only=screen)
    reports = {"realistic": r1}
    ok = meets(r1, R1, buf)
    if ok and has_mode(plant):
        r2 = loop_margins(make(), plant, structural_mode=True, screen_only=screen)
        reports["structural_mode"] = r2
        ok = meets(r2, R2, buf)
    return ok, reports


def tuning_path_env(plant: str, geometry, feed: float, acc: float, jerk: float):
    """The env of one of the plant's tuning paths (a row of ``TUNING_PATHS`` after its
    label)."""
    return gym.make(
        ENV_ID,
        plant=plant,
        path=geometry,
        feedrate_m_s=feed,
        max_accel_m_s2=acc,
        max_jerk_m_s3=jerk,
    )


def run_paths(plant: str, make) -> list[dict]:
    out = []
    for label, geometry, feed, acc, jerk in TUNING_PATHS[plant]:
        env = tuning_path_env(plant, geometry, feed, acc, jerk)
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


def tune_pd(plant: str) -> dict:
    best = None
    for w in PD_GRID:
        ok, _ = constraints_hold(lambda w=w: PDController(bandwidth_rad_s=w), plant, screen=True)
        if ok:
            best = w
    if best is None:
        return {"bandwidth_rad_s": None}
    # confirm with the full computation, stepping down the grid if the buffer was too thin
    for w in [g for g in PD_GRID if g <= best][::-1]:
        ok, reps = constraints_hold(lambda w=w: PDController(bandwidth_rad_s=w), plant, False)
        if ok:
            return {"bandwidth_rad_s": w, **_margin_summary(reps)}
    return {"bandwidth_rad_s": None}


def _margin_summary(reps: dict) -> dict:
    return {
        f"{k}_margins": {
            "gain_margin_db": round(v["min_gain_margin_db"], 2),
            "phase_margin_deg": round(v["min_phase_margin_deg"], 1),
        }
        for k, v in reps.items()
    }


def tune_ccc(plant: str, omega: float, progress=print) -> dict:
    """Coordinate search over ``CCC_GRID``: W_i with W_p = W_d = 0, then W_p at the best W_i,
    then W_d at the best pair; each point must meet R1 and R2 (screened, then confirmed) and
    keep RMS effort within +10 % and the max contour error within +5 % of PD's on every tuning
    path; the objective is the mean over the tuning paths of RMS contour error relative to
    PD."""
    base = run_paths(plant, lambda: PDController(bandwidth_rad_s=omega))
    best = {"W_p": 0.0, "W_i": 0.0, "W_d": 0.0}
    best_ratio, best_reps = 1.0, None
    for key in ("W_i", "W_p", "W_d"):
        for value in CCC_GRID[key]:
            gains = {**best, key: value}

            def make(g=gains):
                return CCCController(bandwidth_rad_s=omega, **g)

            if not constraints_hold(make, plant, screen=True)[0]:
                continue
            ok, reps = constraints_hold(make, plant, screen=False)
            if not ok:
                continue
            runs = run_paths(plant, make)
            if not all(r["completed"] for r in runs):
                continue
            within = all(
                np.all(np.asarray(r["effort"]) <= EFFORT_SLACK * np.asarray(b["effort"]))
                and r["max_um"] <= MAX_SLACK * b["max_um"]
                for r, b in zip(runs, base, strict=True)
            )
            ratio = float(
                np.mean([r["rms_um"] / b["rms_um"] for r, b in zip(runs, base, strict=True)])
            )
            text = ", ".join(f"{k}={v:g}" for k, v in gains.items())
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
    return {**best, "tuning_rms_ratio_to_pd": round(best_ratio, 4), **_margin_summary(best_reps)}


def tune_plant(plant: str, progress=print) -> dict:
    out = {"plant": plant, "tuning_paths": [p[0] for p in TUNING_PATHS[plant]]}
    out["pd"] = tune_pd(plant)
    progress(f"{plant}: pd {out['pd']}")
    omega = out["pd"]["bandwidth_rad_s"]
    if omega is not None:
        out["ccc"] = tune_ccc(plant, omega, progress)
        progress(f"{plant}: ccc {out['ccc']}")
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plants", default="hsm2,friction-table,linear-motor,jee-triaxial")
    parser.add_argument("--json", help="write the chosen gains and their margins as JSON")
    args = parser.parse_args(argv)
    results = [tune_plant(p.strip(), lambda s: print(s, flush=True)) for p in
               args.plants.split(",")]  # fmt: skip
    if args.json:
        atomic_write_json(args.json, results)
        print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
