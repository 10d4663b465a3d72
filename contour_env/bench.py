"""Throughput benchmark: single-env steps/s and vectorised env-steps/s, with Gymnasium's
CartPole-v1 measured in the same run as the yardstick."""

from __future__ import annotations

import os
import platform
import time

import numpy as np

import gymnasium as gym

from . import ENV_ID

VECTOR_SIZES = (1, 64, 1024, 4096)


def _time_single(env, actions: np.ndarray, min_seconds: float) -> float:
    env.reset(seed=0)
    n_done = 0
    t0 = time.perf_counter()
    while True:
        for a in actions:
            _, _, term, trunc, _ = env.step(a)
            if term or trunc:
                env.reset()
        n_done += len(actions)
        elapsed = time.perf_counter() - t0
        if elapsed >= min_seconds:
            return n_done / elapsed


def _time_vector(venv, actions: np.ndarray, min_seconds: float) -> float:
    venv.reset(seed=0)
    n_done = 0
    t0 = time.perf_counter()
    while True:
        for a in actions:
            venv.step(a)
        n_done += len(actions)
        elapsed = time.perf_counter() - t0
        if elapsed >= min_seconds:
            return n_done * venv.num_envs / elapsed


def run_bench(case: str = "hsm2-circle-II", *, seconds: float = 2.0, action_scale: float = 0.02,
              sizes=VECTOR_SIZES, progress=None) -> dict:
    """Measure throughput. Actions: a seeded uniform random sequence in ±``action_scale`` of the
    force limit (a realistic command level: full-scale random forces hit the crash guard in a
    few steps, which would measure resets instead of steps)."""
    import contour_env  # noqa: F401  (registers the env)

    rng = np.random.default_rng(0)
    out: dict = {
        "case": case,
        "action": f"uniform random in ±{action_scale} of the force limit, seeded",
        "python": platform.python_version(),
        "cpu_count": os.cpu_count(),
    }
    env = gym.make(ENV_ID, case=case)
    dim = env.action_space.shape[0]
    actions = (rng.uniform(-1, 1, (2000, dim)) * action_scale).astype(np.float32)
    _time_single(env, actions[:200], 0.0)  # compile / warm up
    out["single_env_steps_per_s"] = _time_single(env, actions, seconds)
    if progress:
        progress(f"single env: {out['single_env_steps_per_s']:,.0f} steps/s")
    cp = gym.make("CartPole-v1")
    cp_actions = rng.integers(0, 2, 2000)
    out["cartpole_single_steps_per_s"] = _time_single(cp, cp_actions, seconds)
    out["vector"] = []
    for n in sizes:
        venv = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point",
                            case=case)
        steps = max(20, min(2000, 200_000 // n))
        acts = (rng.uniform(-1, 1, (steps, n, dim)) * action_scale).astype(np.float32)
        _time_vector(venv, acts[:5], 0.0)
        rate = _time_vector(venv, acts, seconds)
        cvenv = gym.make_vec("CartPole-v1", num_envs=n, vectorization_mode="vector_entry_point")
        cacts = rng.integers(0, 2, (steps, n))
        crate = _time_vector(cvenv, cacts, seconds)
        out["vector"].append({"num_envs": n, "env_steps_per_s": rate,
                              "cartpole_env_steps_per_s": crate})
        if progress:
            progress(f"vector {n:5d} envs: {rate:,.0f} env-steps/s (CartPole {crate:,.0f})")
    return out


def format_bench(res: dict) -> str:
    lines = [
        f"case {res['case']}; actions: {res['action']}",
        f"{'':28s}{'contour_env':>16s}{'CartPole-v1':>16s}",
        f"{'single env, steps/s':28s}{res['single_env_steps_per_s']:16,.0f}"
        f"{res['cartpole_single_steps_per_s']:16,.0f}",
    ]
    for row in res["vector"]:
        lines.append(f"{'vector ' + str(row['num_envs']) + ' envs, env-steps/s':28s}"
                     f"{row['env_steps_per_s']:16,.0f}{row['cartpole_env_steps_per_s']:16,.0f}")
    return "\n".join(lines)
