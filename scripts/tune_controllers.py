"""Reproduce the default controller gains of agents/ (printed as a table).

Criteria (the same for every plant, on its named cases, realistic plant):

- pd: Lee 2012 §4 — per axis the lowest following error without overshoot, then balanced:
  with pole placement on the nominal model both axes share one ω; we take the largest ω on
  the grid whose 1 mm step response overshoots by less than 2 % on every axis (delay, lag,
  friction and mismatch included).
- ccc: the PD gains plus the proportional cross-coupling gain W_p on the grid with the lowest
  mean RMS contour error over the plant's cases, every episode completed and RMS effort per
  axis within +10 % of PD's (Lee: PD first, then CCC).
- adaptive-ccc: ω as PD (same P and D action); the adaptation gains (γ_m, γ_b) on the grid
  with the lowest mean RMS contour error, effort within ±10 % of PD's.
- jee-ccc: (K_P, C_P) on the grid with the lowest RMS contour error on jee-circle3d, completed.

Usage: ``python scripts/tune_controllers.py [--plants hsm2,jee-triaxial,...]``.
"""

from __future__ import annotations

import argparse

import gymnasium as gym
import numpy as np

import contour_env  # noqa: F401
from agents import make_controller
from contour_env import ENV_ID
from contour_env.cases import CASES
from contour_env.evaluation import run_episode
from contour_env.metrics import score
from contour_env.plants import Plant

PD_GRID = (40.0, 60.0, 80.0, 100.0, 150.0, 200.0, 250.0, 300.0, 400.0)
WP_GRID = (3e3, 1e4, 3e4, 6e4, 9e4, 1.5e5, 3e5)
GAMMA_GRID = ((0.3, 1.0), (1.0, 5.0), (3.0, 15.0), (10.0, 50.0), (50.0, 200.0))
JEE_GRID = [(kp, cp) for kp in (3.0, 4.0, 5.0, 6.0, 8.0) for cp in (0.0, 2.0, 3.0, 4.0, 6.0)]


def cases_of(plant: str) -> list[str]:
    return [name for name, spec in CASES.items() if spec.plant == plant]


def step_overshoot(plant_name: str, omega: float, step_m: float = 1e-3) -> float:
    """Largest relative overshoot over the axes of the PD step response (realistic plant)."""
    plant = Plant(plant_name)
    m, b = plant.nominal.mass_kg, plant.nominal.viscous_Ns_m
    P, D = m * omega**2, np.maximum(2 * m * omega - b, 0.0)
    state = plant.initial_state(np.zeros((1, plant.n_axes)))
    T = plant.servo_period_s
    res = plant.params.encoder_resolution_m
    prev = np.zeros(plant.n_axes)
    peak = np.zeros(plant.n_axes)
    for k in range(int(0.5 / T)):
        x = state.position[0]
        xm = np.where(res > 0, np.round(x / np.where(res > 0, res, 1)) * res, x)
        u = P * (step_m - xm) - D * (xm - prev) / T
        prev = xm
        state, _ = plant.step(
            state,
            np.clip(u, -plant.params.force_limit_N, plant.params.force_limit_N)[None, :],
            k * T,
        )
        peak = np.maximum(peak, state.position[0])
        if not np.all(np.isfinite(state.position)):
            return np.inf
    return float(np.max(peak / step_m - 1.0))


def evaluate(name: str, cases: list[str], **kw) -> tuple[float, list, bool]:
    rms, efforts, ok = [], [], True
    for case in cases:
        env = gym.make(ENV_ID, case=case)
        m = score(run_episode(env, make_controller(name, **kw)))
        ok &= m["completed"]
        rms.append(m["rms_contour_error_um"] if m["completed"] else np.inf)
        efforts.append(np.asarray(m["rms_effort"], dtype=float))
    return float(np.mean(rms)), efforts, ok


def tune_plant(plant: str) -> dict:
    cases = cases_of(plant)
    out = {"plant": plant, "cases": cases}
    if plant == "jee-triaxial":
        best = min(JEE_GRID, key=lambda g: evaluate("jee-ccc", cases, K_P=g[0], C_P=g[1])[0])
        out["jee-ccc"] = {"K_P": best[0], "C_P": best[1]}
    ok_omegas = [w for w in PD_GRID if step_overshoot(plant, w) < 0.02]
    omega = max(ok_omegas) if ok_omegas else min(PD_GRID)
    out["pd"] = {"bandwidth_rad_s": omega}
    pd_rms, pd_eff, _ = evaluate("pd", cases, bandwidth_rad_s=omega)
    out["pd"]["rms_um"] = pd_rms
    scored = []
    for wp in WP_GRID:
        rms, eff, ok = evaluate("ccc", cases, bandwidth_rad_s=omega, W_p=wp)
        within = all(np.all(e <= 1.1 * p) for e, p in zip(eff, pd_eff, strict=True))
        if ok and within:
            scored.append((rms, wp))
    out["ccc"] = {
        "W_p": min(scored)[1] if scored else None,
        "rms_um": min(scored)[0] if scored else None,
    }
    scored = []
    for gamma in GAMMA_GRID:
        rms, eff, ok = evaluate("adaptive-ccc", cases, bandwidth_rad_s=omega, gamma=gamma)
        within = all(np.all(np.abs(e / p - 1) <= 0.1) for e, p in zip(eff, pd_eff, strict=True))
        if ok and within:
            scored.append((rms, gamma))
    out["adaptive-ccc"] = {
        "gamma": min(scored)[1] if scored else None,
        "rms_um": min(scored)[0] if scored else None,
    }
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plants", default="hsm2,friction-table,jee-triaxial,linear-motor")
    args = parser.parse_args()
    for plant in args.plants.split(","):
        print(tune_plant(plant.strip()), flush=True)


if __name__ == "__main__":
    main()
