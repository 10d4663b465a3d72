"""One scored episode on the five-axis env: :func:`contour_env.evaluation.run_episode`'s
record plus the tool's orientation error per step (``EpisodeRecord.orientation_error``), so
:func:`contour_env.metrics.score` reports ``max/rms_orientation_error_arcsec``."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..metrics import EpisodeRecord
from .rollout import empty_record, episode_record


def is_five_axis_env(env) -> bool:
    core = getattr(env, "core", None) or getattr(getattr(env, "unwrapped", None), "core", None)
    return getattr(getattr(core, "setup", None), "family", None) == "five-axis"


def run_five_axis_episode(env, policy=None, *, seed: int = 0, deterministic=True) -> EpisodeRecord:
    """Run the five-axis ``env`` from ``reset(seed=seed)`` to the end with ``policy`` (SB3's
    ``predict``; None: zero command); the record of ``run_episode`` with the orientation
    error (rad) of every step. Its ``tracking_error`` (n, 3) is the tool-tip tracking error
    p_d − p (m, workpiece frame), the quantity of the env's tracking guard, so ``completed``
    applies the follow limit to the tool tip (joint errors mix m and rad)."""
    core = env.unwrapped.core
    if policy is not None and hasattr(policy, "bind") and getattr(policy, "_core", None) is None:
        policy.bind(env)
    obs, _ = env.reset(seed=seed)
    n_max = core.n_steps - 1
    rec = empty_record(core)
    rec["tracking_error"] = np.empty((n_max, 3))
    theta = np.empty(n_max)
    zero = np.zeros(5, dtype=np.float32)
    state, start, reason, n = None, np.ones((1,), dtype=bool), None, 0
    for n in range(1, n_max + 1):
        if policy is None:
            action = zero
        else:
            action, state = policy.predict(
                obs, state=state, episode_start=start, deterministic=deterministic
            )
            start = np.zeros((1,), dtype=bool)
        obs, _, terminated, truncated, info = env.step(action)
        i = n - 1
        rec["time"][i] = info["time"]
        rec["contour_error"][i] = info["contour_error"]
        rec["position"][i] = info["position"]
        rec["reference"][i] = info["reference"]
        rec["tracking_error"][i] = info["reference_tool_tip"] - info["tool_tip"]
        rec["force"][i] = info["force"]
        theta[i] = info["orientation_error"]
        if terminated or truncated:
            reason = info.get("termination_reason")
            break
    # the tool tip's resolution is the linear scales' count: the rotary counts are angles
    # (rad), not comparable with a contour error in m
    linear_counts = np.asarray(core.setup.plant.params.encoder_resolution_m, dtype=float)[:3]
    return replace(
        episode_record(core, rec, n, reason),
        orientation_error=theta[:n].copy(),
        encoder_resolution_m=linear_counts,
    )
