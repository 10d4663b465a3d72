"""Run one episode with a policy and score it with :func:`contour_env.metrics.score`.

A policy is anything with stable-baselines3's ``predict(observation, state=None,
episode_start=None, deterministic=True) -> (action, state)``; ``None`` is the zero command.
"""

from __future__ import annotations

import numpy as np

from .env import kernel as K
from .env.five_axis_rollout import is_five_axis_env, run_five_axis_episode
from .env.rollout import compiled_allowed, empty_record, episode_record, try_compiled_episode
from .metrics import EpisodeRecord, score


def _unwrap(env):
    core = getattr(env, "core", None) or getattr(getattr(env, "unwrapped", None), "core", None)
    if core is None:
        raise ValueError("env: expected a contour_env ContouringEnv (or a wrapper of one)")
    return core


def run_episode(
    env, policy=None, *, seed: int = 0, deterministic: bool = True, compiled: bool | None = None
) -> EpisodeRecord:
    """Run ``env`` from ``reset(seed=seed)`` to the end with ``policy``; return the record.

    A classical controller with a compiled form (``pd``, ``ccc``, ``adaptive-ccc``,
    ``jee-ccc``, ``rfnn``, ``fnn``) on an unwrapped, non-rendering env runs as one compiled loop
    (:mod:`contour_env.env.rollout`), with the same record to the bit; ``compiled=False`` (or
    ``CONTOUR_ENV_COMPILED=0``) forces the Python loop, ``None`` (default) takes the compiled
    one where it applies.

    On the five-axis env the episode runs in :func:`contour_env.env.five_axis_rollout.
    run_five_axis_episode` (Python loop), whose record adds the tool's orientation error, so
    every scoring path reports ``max/rms_orientation_error_arcsec`` there."""
    core = _unwrap(env)
    if is_five_axis_env(env):
        return run_five_axis_episode(env, policy, seed=seed, deterministic=deterministic)
    if compiled_allowed(compiled):
        record = try_compiled_episode(env, policy, seed)
        if record is not None:
            return record
    if policy is not None and hasattr(policy, "bind") and getattr(policy, "_env", None) is None:
        policy.bind(env)  # a classical controller reads the servo signals of this env
    obs, _ = env.reset(seed=seed)
    n_max = core.n_steps - 1
    d = core.dim
    rec = empty_record(core)
    zero = np.zeros(d, dtype=np.float32)
    state = None
    episode_start = np.ones((1,), dtype=bool)
    reason = None
    n = 0
    for n in range(1, n_max + 1):
        if policy is None:
            action = zero
        else:
            action, state = policy.predict(
                obs, state=state, episode_start=episode_start, deterministic=deterministic
            )
            episode_start = np.zeros((1,), dtype=bool)
        obs, _, terminated, truncated, info = env.step(action)
        i = n - 1
        kk = min(int(core.k[0]), core.n_steps - 1)
        rec["time"][i] = core.k[0] * core.T
        rec["contour_error"][i] = core.eps[0]
        pos = core.z[0, :, 0]
        ref = core.ref_pav[kk, 0, :d]
        rec["position"][i] = pos
        rec["reference"][i] = ref
        rec["tracking_error"][i] = ref - pos
        rec["force"][i] = core.ax[K.AX_APPLIED, 0]
        if terminated or truncated:
            reason = info.get("termination_reason")
            break
    return episode_record(core, rec, n, reason)


def evaluate(env, policy=None, *, seed: int = 0, compiled: bool | None = None) -> dict:
    """Metrics of one episode of ``policy`` on ``env`` (the project's one scoring function);
    ``compiled`` as :func:`run_episode`."""
    return score(run_episode(env, policy, seed=seed, compiled=compiled))
