"""Question: How fast does the vector env step on the plants with friction, by kind of action
(tracking, zero, small and large random actions)?

Answer: Small random actions cost 0.43 of the tracking rate after the Stribeck exponential went
to its Taylor series; the figures per plant are printed by this script.

Cited by: docs/speed.md (the friction stepping paragraph).

Vector-env stepping speed on the plants with friction, by kind of action (issue 20 item 2).

For each case (one per plant with friction) a ``gymnasium.make_vec(..., vectorization_mode=
"vector_entry_point")`` env of ``--num-envs`` envs is stepped with

- ``track``: the PD controller's actions (``agents.make_controller("pd")``, closed loop);
- ``track+1%``: the same plus uniform noise of ±0.01 (1 % of the force limit);
- ``uniform``: uniform random actions in [−1, 1];
- ``small``: uniform random actions in [−0.01, 0.01] (many velocity reversals);

and only ``venv.step`` is timed (the controller and the random draws are not). Prints
env-steps/s (best of the timing windows) and the ratio to ``track``. Everything is seeded;
numba's thread count is left at its default.

    python research/friction_speed.py [--num-envs 4096] [--windows 3] [--steps 100]
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym
import numpy as np

import contour_env  # noqa: F401  (registers the env)
from agents import make_controller

ENV_ID = "contour_env/Contouring-v0"
# one case per plant with friction in its true model
CASES = {
    "hsm2": "hsm2-circle-II",
    "friction-table": "sharp-corner",
    "linear-motor": "lm-circle3d",
    "jee-triaxial": "jee-circle3d",
}
KINDS = ("track", "track+1%", "uniform", "small")


def _rate(case: str, kind: str, num_envs: int, warmup: int, windows: int, steps: int, seed: int):
    venv = gym.make_vec(
        ENV_ID, num_envs=num_envs, vectorization_mode="vector_entry_point", case=case
    )
    rng = np.random.default_rng(seed)
    obs, _ = venv.reset(seed=seed)
    dim = venv.single_action_space.shape[0]
    ctrl = make_controller("pd").bind(venv) if kind.startswith("track") else None
    episode_start = np.zeros(num_envs, dtype=bool)

    def action():
        if kind == "uniform":
            return rng.uniform(-1.0, 1.0, (num_envs, dim))
        if kind == "small":
            return rng.uniform(-0.01, 0.01, (num_envs, dim))
        a, _ = ctrl.predict(obs, episode_start=episode_start)
        a = np.asarray(a, dtype=np.float64)
        if kind == "track+1%":
            a = np.clip(a + rng.uniform(-0.01, 0.01, a.shape), -1.0, 1.0)
        return a

    best = 0.0
    total = warmup + windows * steps
    elapsed = 0.0
    for j in range(total):
        a = action()
        t = time.perf_counter()
        obs, _, term, trunc, _ = venv.step(a)
        elapsed += time.perf_counter() - t
        episode_start = term | trunc
        if j >= warmup and (j - warmup + 1) % steps == 0:
            best = max(best, steps * num_envs / elapsed)
        if j == warmup - 1 or (j >= warmup and (j - warmup + 1) % steps == 0):
            elapsed = 0.0
    venv.close()
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--num-envs", type=int, default=4096)
    ap.add_argument("--warmup", type=int, default=30)
    ap.add_argument("--windows", type=int, default=3)
    ap.add_argument("--steps", type=int, default=100)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--plants", nargs="*", default=list(CASES))
    ap.add_argument("--kinds", nargs="*", default=list(KINDS))
    args = ap.parse_args()
    print(f"num_envs={args.num_envs}  windows={args.windows}×{args.steps} steps (best window)")
    print(f"{'plant':16s} {'case':16s} " + " ".join(f"{k:>18s}" for k in args.kinds))
    for plant in args.plants:
        case = CASES[plant]
        rates = {
            k: _rate(case, k, args.num_envs, args.warmup, args.windows, args.steps, args.seed)
            for k in args.kinds
        }
        ref = rates.get("track")
        cells = []
        for k in args.kinds:
            r = rates[k]
            ratio = f"({r / ref:4.2f})" if ref else ""
            cells.append(f"{r / 1e6:9.3f} M/s {ratio:>6s}")
        print(f"{plant:16s} {case:16s} " + " ".join(f"{c:>18s}" for c in cells), flush=True)


if __name__ == "__main__":
    main()
