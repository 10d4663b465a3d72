"""Tune the rfnn defaults on tuning paths only — never tune on what you score.

Default mode: the network's structure (rules, θ0, learning rates), rfnn and fnn side by side,
on agents.rfnn.TUNING_PATH (a linear-motor arc that is not a named case or a test program).
``--plants``: the per-plant rule-weight rate ``agents.rfnn.DEFAULT_LR_W`` — among the lr_w of
``LR_W_GRID`` up to ω T / 4 (an eighth of the Routh limit of PD + integral with one rule
firing alone, see agents.rfnn) whose RMS effort stays within +10 % of PD's on every axis of
every tuning path of the plant (scripts/tune_controllers.py's TUNING_PATHS, plus TUNING_PATH
on the linear motor), every run completing, the one with the lowest mean RMS contour error::

    python scripts/rfnn_tune.py [--quick]
    python scripts/rfnn_tune.py --plants
"""

from __future__ import annotations

import argparse
import itertools
import math
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np

import contour_env  # noqa: F401  (registers the env)
from agents import make_controller
from agents.rfnn import TUNING_PATH
from contour_env import ENV_ID
from contour_env.evaluation import run_episode
from contour_env.metrics import score
from contour_env.paths import circle


def tuning_env():
    """The linear-motor env on :data:`agents.rfnn.TUNING_PATH`."""
    tp = TUNING_PATH
    tilt = math.radians(tp["tilt_deg"])
    geometry = circle(
        (0.0, 0.0, 0.0),
        tp["radius_m"],
        normal=(math.sin(tilt), 0.0, math.cos(tilt)),
        start_angle=-math.radians(tp["sweep_deg"]) / 2,
        sweep=math.radians(tp["sweep_deg"]),
    )
    return gym.make(
        ENV_ID,
        plant="linear-motor",
        path=geometry,
        feedrate_m_s=tp["feedrate_m_s"],
        max_accel_m_s2=0.5,
        max_jerk_m_s3=10.0,
    )


LR_W_GRID = (0.001, 0.002, 0.004, 0.008, 0.01, 0.016, 0.02, 0.032, 0.064)
# lr_w ≤ CAP_PER_OMEGA_T · ω T: an eighth of the Routh limit 2 ω T of PD + integral with one
# rule firing alone (at ω T and ω T / 2 the friction table's fnn wound its rule weights up to
# the force limit on G-code programs with pauses: tests/data/gcode/helix_entry.ngc,
# inch_flange.tap — which are then no longer programs it was not tuned on)
CAP_PER_OMEGA_T = 0.25
EFFORT_SLACK = 1.10


def plant_paths(plant: str) -> list[tuple]:
    """(label, env) of the plant's tuning paths."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from tune_controllers import TUNING_PATHS, tuning_path_env

    out = [(label, tuning_path_env(plant, *row)) for label, *row in TUNING_PATHS[plant]]
    if plant == "linear-motor":
        out.append(("agents.rfnn.TUNING_PATH", tuning_env()))
    return out


def tune_plants(plants: list[str]) -> None:
    for plant in plants:
        paths = plant_paths(plant)
        pd = [score(run_episode(env, make_controller("pd").bind(env))) for _, env in paths]
        best = None
        probe = make_controller("pd").bind(paths[0][1])
        cap = CAP_PER_OMEGA_T * probe.omega * probe.servo_period_s
        print(f"{plant}: tuning paths {', '.join(label for label, _ in paths)}; cap {cap:.4g}")
        for lr in (lr for lr in LR_W_GRID if lr <= cap):
            ratios, ok = [], True
            for (_, env), ref in zip(paths, pd, strict=True):
                m = score(run_episode(env, make_controller(f"rfnn:lr_w={lr:g}").bind(env)))
                effort = np.asarray(m["rms_effort"]) / np.asarray(ref["rms_effort"])
                ok &= bool(m["completed"]) and bool(np.all(effort <= EFFORT_SLACK))
                ratios.append(m["rms_contour_error_um"] / ref["rms_contour_error_um"])
            mean = float(np.mean(ratios))
            print(f"  lr_w={lr:<6g} RMS/PD {mean:.3f}  {'ok' if ok else 'effort > +10 % or fail'}")
            if ok and (best is None or mean < best[1]):
                best = (lr, mean)
        print(f"  -> {plant}: lr_w = {best[0] if best else 'none'}", flush=True)


def row(env, spec: str) -> dict:
    m = score(run_episode(env, make_controller(spec).bind(env)))
    return {
        "spec": spec,
        "completed": m["completed"],
        "rms": m["rms_contour_error_um"],
        "max": m["max_contour_error_um"],
        "effort": float(np.mean(m["rms_effort"])),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a small grid")
    ap.add_argument(
        "--plants",
        nargs="?",
        const="linear-motor,hsm2,friction-table,jee-triaxial",
        help="tune the per-plant lr_w (comma-separated plants; default all four)",
    )
    ap.add_argument("--lr-w", help="comma-separated lr_w values (overrides the grid's)")
    ap.add_argument("--theta0", help="comma-separated theta0 values (overrides the grid's)")
    ap.add_argument("--rules", help="comma-separated rule counts (overrides the grid's)")
    ap.add_argument("--lr-theta", help="comma-separated lr_theta values (overrides the grid's)")
    args = ap.parse_args()
    if args.plants:
        tune_plants(args.plants.split(","))
        return
    env = tuning_env()
    pd = row(env, "pd")
    print(f"pd: RMS {pd['rms']:.3f} µm, max {pd['max']:.2f} µm, effort {pd['effort']:.3f} N")
    lr_ws = (2e-3,) if args.quick else (1e-3, 2e-3, 5e-3, 1e-2)
    lr_thetas = (0.0, 1e-3) if args.quick else (0.0, 2e-4, 1e-3, 2e-3)
    theta0s = (0.0,) if args.quick else (-0.5, 0.0, 0.5)
    rules = (9,) if args.quick else (4, 9, 25)

    def values(text, default, kind=float):
        return default if text is None else tuple(kind(v) for v in text.split(","))

    lr_ws = values(args.lr_w, lr_ws)
    lr_thetas = values(args.lr_theta, lr_thetas)
    theta0s = values(args.theta0, theta0s)
    rules = values(args.rules, rules, int)
    print(f"{'spec':55s} {'RMS µm':>8s} {'max µm':>8s} {'RMS/PD':>7s} {'effort/PD':>9s}")
    for lw, lt, t0, r in itertools.product(lr_ws, lr_thetas, theta0s, rules):
        name = "fnn" if lt == 0.0 and t0 == 0.0 else "rfnn"
        spec = f"{name}:rules={r}:lr_w={lw:g}"
        if name == "rfnn":
            spec += f":lr_theta={lt:g}:theta0={t0:g}"
        try:
            res = row(env, spec)
        except ValueError:
            print(f"{spec:55s} refused (outside the eq. 23 bound)")
            continue
        print(
            f"{spec:55s} {res['rms']:8.3f} {res['max']:8.2f} {res['rms'] / pd['rms']:7.3f} "
            f"{res['effort'] / pd['effort']:9.4f}{'' if res['completed'] else '  INCOMPLETE'}",
            flush=True,
        )


if __name__ == "__main__":
    main()
