"""Controller-in-the-loop rates for the benchmark (``contour_env.app.speed`` prints the rows).

A classical controller runs compiled with the env kernel (:mod:`contour_env.env.rollout`):
``run_episode(env, make_controller("pd"))`` on one env, and the fused batch loop over 4096
plant variants (each env's episode on its own thread, as ``compare --randomize`` runs it).
"""

from __future__ import annotations

import time


def _single_rate(quick: bool) -> float:
    import gymnasium as gym

    from agents import make_controller

    from .. import ENV_ID
    from ..evaluation import run_episode

    env = gym.make(ENV_ID, case="hsm2-circle-II" if quick else "lm-circle3d")
    run_episode(env, make_controller("pd"))  # compile / load the cached loop
    best = 0.0
    for _ in range(2 if quick else 3):
        t0 = time.perf_counter()
        rec = run_episode(env, make_controller("pd"))
        dt = time.perf_counter() - t0
        best = max(best, rec.time.size / dt)
    return best


def _batch_rate(quick: bool, n_envs: int = 4096) -> float:
    from agents.compare import robustness_compiled_steps

    steps, dt = robustness_compiled_steps(
        "pd", n_envs, case="hsm2-circle-III" if quick else "hsm2-circle-II"
    )
    return steps / dt


def controller_rates(quick: bool) -> list[tuple[str, float]]:
    """Rows (label, rate): pd in the loop on one env (steps/s) and, except with ``quick``, on
    4096 envs (env-steps/s), compiled. ``quick`` leaves the batch row out: its parallel loop
    takes minutes to compile on a fresh checkout, and ``bench --quick`` stays short."""
    rows = [("controller in the loop, single env (pd), steps/s", _single_rate(quick))]
    if not quick:
        rows.append(("controller in the loop, 4096 envs (pd), env-steps/s", _batch_rate(quick)))
    return rows
