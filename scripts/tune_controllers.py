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

The search itself is :mod:`agents.tuning` (``contour-env tune`` runs the same on a plant file).

Usage: ``python scripts/tune_controllers.py [--plants hsm2,friction-table,...] [--json OUT]``.
"""

from __future__ import annotations

import argparse
import math
import sys

import gymnasium as gym
import numpy as np

import contour_env  # noqa: F401
from agents.tuning import tune_ccc, tune_pd
from contour_env import ENV_ID
from contour_env.io import atomic_write_json
from contour_env.paths import circle, polyline

# the search (grids, constraints R1/R2, screening buffer, effort and peak slack) is
# agents.tuning's, shared with contour-env tune (which runs it on a plant file)


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


def tune_plant(plant: str, progress=print) -> dict:
    out = {"plant": plant, "tuning_paths": [p[0] for p in TUNING_PATHS[plant]]}
    out["pd"] = tune_pd(plant)
    progress(f"{plant}: pd {out['pd']}")
    omega = out["pd"]["bandwidth_rad_s"]
    if omega is not None:
        out["ccc"] = tune_ccc(plant, omega, TUNING_PATHS[plant], progress)
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
