"""Run one episode with a policy and score it with :func:`contour_env.metrics.score`.

A policy is anything with stable-baselines3's ``predict(observation, state=None,
episode_start=None, deterministic=True) -> (action, state)``; ``None`` is the zero command.
"""

from __future__ import annotations

import numpy as np

from .env.core import core_of
from .env.rollout import compiled_allowed, is_five_axis_env, recorder_for, try_compiled_episode
from .metrics import EpisodeRecord, score


def run_episode(
    env, policy=None, *, seed: int = 0, deterministic: bool = True, compiled: bool | None = None
) -> EpisodeRecord:
    """Run ``env`` from ``reset(seed=seed)`` to the end with ``policy``; return the record.

    The one episode loop of the package: reset, then per servo period the policy's action
    (SB3's ``predict``; None: the zero command), the env's step and a row of the record
    (:func:`contour_env.env.rollout.recorder_for`: on the five-axis machine the record adds
    the tool's orientation error, so every scoring path reports
    ``max/rms_orientation_error_arcsec`` there), until the episode ends.

    A classical controller with a compiled form (``pd``, ``ccc``, ``adaptive-ccc``,
    ``jee-ccc``, ``rfnn``, ``fnn``, and a residual agent on one of them) on an unwrapped,
    non-rendering feed-drive env runs the same loop compiled (:mod:`contour_env.env.rollout`):
    only who computes the action differs, and the record is the same to the bit.
    ``compiled=False`` (or ``CONTOUR_ENV_COMPILED=0``) forces the Python loop, ``None``
    (default) takes the compiled one where it applies."""
    core = core_of(env)[1]
    if compiled_allowed(compiled) and not is_five_axis_env(env):
        record = try_compiled_episode(env, policy, seed)
        if record is not None:
            return record
    if policy is not None and hasattr(policy, "bind"):
        policy.bind(env)  # a classical controller reads the servo signals of this env
    obs, _ = env.reset(seed=seed)
    recorder = recorder_for(core)
    zero = np.zeros(core.dim, dtype=np.float32)
    state = None
    episode_start = np.ones((1,), dtype=bool)
    reason = None
    n = 0
    for n in range(1, core.n_steps):
        if policy is None:
            action = zero
        else:
            action, state = policy.predict(
                obs, state=state, episode_start=episode_start, deterministic=deterministic
            )
            episode_start = np.zeros((1,), dtype=bool)
        obs, _, terminated, truncated, info = env.step(action)
        recorder.record(n - 1, info)
        if terminated or truncated:
            reason = info.get("termination_reason")
            break
    return recorder.finish(n, reason)


def evaluate(env, policy=None, *, seed: int = 0, compiled: bool | None = None) -> dict:
    """Metrics of one episode of ``policy`` on ``env`` (the project's one scoring function);
    ``compiled`` as :func:`run_episode`."""
    metrics = score(run_episode(env, policy, seed=seed, compiled=compiled))
    # a residual agent with an envelope: the share of its decisions taken outside it
    share = getattr(policy, "outside_envelope_fraction", None)
    if callable(share) and share() is not None:
        metrics["outside_envelope_fraction"] = float(share())
    return metrics
