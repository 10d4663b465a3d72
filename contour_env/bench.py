"""Throughput benchmark: single-env steps/s and vectorised env-steps/s, with Gymnasium's
CartPole-v1 measured in the same run as the yardstick.

A shared machine's speed drifts by tens of per cent from second to second. So each figure is
the median of ``repeats`` timing windows, and the windows of contour_env and of CartPole
alternate: both see the same machine. Every window of contour_env covers whole episodes
(start-up, cruise, reversals, stop), so no phase of the motion is over- or under-sampled. The
JSON report keeps every window's rate.

A window lasts ``seconds / repeats`` or one whole episode, whichever is longer: at 4096 envs
one episode of the default case is 8 M env-steps, so the full benchmark takes a minute or
more whatever ``seconds`` says. ``quick=True`` (``contour-env bench --quick``) is a first
look in well under 30 s: one window per figure, 0.3 s, 1, 64 and 1024 envs.
"""

from __future__ import annotations

import os
import platform
import statistics
import time

import gymnasium as gym
import numpy as np

from . import DEFAULT_CASE, ENV_ID

VECTOR_SIZES = (1, 64, 1024, 4096)
DEFAULT_REPEATS = 5
DEFAULT_SECONDS = 2.0
# --quick: one short window per figure, no 4096-env figure (its one episode alone is 8 M steps)
QUICK_SIZES = (1, 64, 1024)
QUICK_REPEATS = 1
QUICK_SECONDS = 0.3


def _time_single(env, actions: np.ndarray, min_seconds: float) -> float:
    # whole passes over ``actions`` (an episode for contour_env) until min_seconds have passed
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


def _alternate(ours, yardstick, repeats: int) -> tuple[list[float], list[float]]:
    # the two timings in turns, so that a slow spell of the machine hits both
    a, b = [], []
    for _ in range(repeats):
        a.append(ours())
        b.append(yardstick())
    return a, b


def tracking_actions(case: str, n_steps: int, bandwidth_rad_s: float = 60.0) -> np.ndarray:
    """Actions of a simple tracking servo (nominal-model feedforward + PD on the measured
    position, critically damped at ``bandwidth_rad_s``) recorded on one episode of ``case``:
    the command sequence a controller actually sends, so the benchmark exercises the plant as
    it runs in use (moving along the path, reversals at the quadrants), not a random walk
    around standstill."""
    env = gym.make(ENV_ID, case=case).unwrapped
    env.reset(seed=0)
    nominal = env.plant.nominal
    m, b = nominal.mass_kg, nominal.viscous_Ns_m
    limit = env.plant.params.force_limit_N
    kp, kd = bandwidth_rad_s**2, 2.0 * bandwidth_rad_s
    out = np.zeros((n_steps, env.core.dim), dtype=np.float32)
    for k in range(n_steps):
        s = env.signals()
        e = s["reference_position"] - s["measured_position"]
        de = s["reference_velocity"] - s["measured_velocity"]
        u = m * (s["reference_acceleration"] + kp * e + kd * de) + b * s["reference_velocity"]
        out[k] = np.clip(u / limit, -1.0, 1.0)
        _, _, term, trunc, _ = env.step(out[k])
        if term or trunc:
            env.reset(seed=0)
    return out


def run_bench(
    case: str = DEFAULT_CASE,
    *,
    seconds: float | None = None,
    sizes=None,
    repeats: int | None = None,
    quick: bool = False,
    progress=None,
) -> dict:
    """Measure throughput with the actions of :func:`tracking_actions` replayed (the policy's
    own cost is not part of the measurement, as for CartPole's random actions).

    ``seconds``: measuring time per figure, split into ``repeats`` alternating windows (each
    at least one whole episode); the figure is the median window rate. ``sizes``: the vector
    env sizes. Defaults: 2 s, 5 windows, 1/64/1024/4096 envs; with ``quick`` 0.3 s, one
    window, 1/64/1024 envs (an explicit argument still wins).
    """
    import contour_env  # noqa: F401  (registers the env)

    if seconds is None:
        seconds = QUICK_SECONDS if quick else DEFAULT_SECONDS
    if repeats is None:
        repeats = QUICK_REPEATS if quick else DEFAULT_REPEATS
    if sizes is None:
        sizes = QUICK_SIZES if quick else VECTOR_SIZES

    if not (isinstance(repeats, int) and repeats >= 1):
        raise ValueError(f"repeats: must be an integer >= 1, got {repeats!r}")
    if not seconds > 0:
        raise ValueError(f"seconds: must be > 0, got {seconds!r}")
    window = seconds / repeats
    rng = np.random.default_rng(0)
    out: dict = {
        "case": case,
        "action": "recorded commands of a feedforward + PD tracking servo, replayed",
        "statistic": f"median of {repeats} windows alternating with CartPole-v1's",
        "repeats": repeats,
        "seconds": seconds,
        "quick": bool(quick),
        "python": platform.python_version(),
        "cpu_count": os.cpu_count(),
    }
    env = gym.make(ENV_ID, case=case)
    dim = env.action_space.shape[0]
    actions = tracking_actions(case, env.unwrapped.core.n_steps - 1)
    _time_single(env, actions[:200], 0.0)  # compile / warm up
    cp = gym.make("CartPole-v1")
    cp_actions = rng.integers(0, 2, 2000)
    ours, theirs = _alternate(
        lambda: _time_single(env, actions, window),
        lambda: _time_single(cp, cp_actions, window),
        repeats,
    )
    out["single_env_steps_per_s"] = statistics.median(ours)
    out["cartpole_single_steps_per_s"] = statistics.median(theirs)
    out["single_env_steps_per_s_runs"] = ours
    out["cartpole_single_steps_per_s_runs"] = theirs
    if progress:
        progress(
            f"single env: {out['single_env_steps_per_s']:,.0f} steps/s "
            f"(CartPole {out['cartpole_single_steps_per_s']:,.0f})"
        )
    out["vector"] = []
    for n in sizes:
        venv = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point", case=case)
        steps = len(actions)  # whole episodes: start-up, cruise, reversals, stop
        # every env replays the servo's commands with its own small seeded perturbation
        acts = (
            actions[:steps, None, :] * (1.0 + 0.01 * rng.standard_normal((steps, n, dim)))
        ).astype(np.float32)
        _time_vector(venv, acts[:5], 0.0)
        cvenv = gym.make_vec("CartPole-v1", num_envs=n, vectorization_mode="vector_entry_point")
        cacts = rng.integers(0, 2, (min(steps, 500), n))
        ours, theirs = _alternate(
            lambda venv=venv, acts=acts: _time_vector(venv, acts, window),
            lambda cvenv=cvenv, cacts=cacts: _time_vector(cvenv, cacts, window),
            repeats,
        )
        row = {
            "num_envs": n,
            "env_steps_per_s": statistics.median(ours),
            "cartpole_env_steps_per_s": statistics.median(theirs),
            "env_steps_per_s_runs": ours,
            "cartpole_env_steps_per_s_runs": theirs,
        }
        out["vector"].append(row)
        venv.close()
        cvenv.close()
        if progress:
            progress(
                f"vector {n:5d} envs: {row['env_steps_per_s']:,.0f} env-steps/s "
                f"(windows {min(ours):,.0f}–{max(ours):,.0f}; "
                f"CartPole {row['cartpole_env_steps_per_s']:,.0f})"
            )
    return out


def format_bench(res: dict) -> str:
    def spread(runs):
        return f"{min(runs) / 1e6:.2f}–{max(runs) / 1e6:.2f} M" if runs else ""

    lines = [
        f"case {res['case']}; actions: {res['action']}",
        f"figures: {res.get('statistic', 'one window')} (window range in brackets)",
        f"{'':28s}{'contour_env':>16s}{'':>16s}{'CartPole-v1':>16s}",
        f"{'single env, steps/s':28s}{res['single_env_steps_per_s']:16,.0f}"
        f"{'(' + spread(res.get('single_env_steps_per_s_runs', [])) + ')':>16s}"
        f"{res['cartpole_single_steps_per_s']:16,.0f}",
    ]
    for row in res["vector"]:
        lines.append(
            f"{'vector ' + str(row['num_envs']) + ' envs, env-steps/s':28s}"
            f"{row['env_steps_per_s']:16,.0f}"
            f"{'(' + spread(row.get('env_steps_per_s_runs', [])) + ')':>16s}"
            f"{row['cartpole_env_steps_per_s']:16,.0f}"
        )
    return "\n".join(lines)
