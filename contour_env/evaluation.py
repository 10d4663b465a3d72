"""Run one episode with a policy and score it with :func:`contour_env.metrics.score`.

A policy is anything with stable-baselines3's ``predict(observation, state=None,
episode_start=None, deterministic=True) -> (action, state)``; ``None`` is the zero command.
"""

from __future__ import annotations

import numpy as np

from .env import kernel as K
from .metrics import EpisodeRecord, score


def _unwrap(env):
    core = getattr(env, "core", None) or getattr(getattr(env, "unwrapped", None), "core", None)
    if core is None:
        raise ValueError("env: expected a contour_env ContouringEnv (or a wrapper of one)")
    return core


def run_episode(env, policy=None, *, seed: int = 0, deterministic: bool = True) -> EpisodeRecord:
    """Run ``env`` from ``reset(seed=seed)`` to the end with ``policy``; return the record."""
    core = _unwrap(env)
    if policy is not None and hasattr(policy, "bind") and getattr(policy, "_env", None) is None:
        policy.bind(env)  # a classical controller reads the servo signals of this env
    obs, _ = env.reset(seed=seed)
    n_max = core.n_steps - 1
    d = core.dim
    rec = {
        "time": np.empty(n_max),
        "contour_error": np.empty(n_max),
        "tracking_error": np.empty((n_max, d)),
        "force": np.empty((n_max, d)),
        "position": np.empty((n_max, d)),
        "reference": np.empty((n_max, d)),
    }
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
    sl = slice(0, n)
    force = rec["force"][sl]
    limit = core.setup.plant.params.force_limit_N
    # rapid (G00) steps: the flag of the reference index each recorded step ended at
    step_is_rapid = getattr(core.setup, "step_is_rapid", None)
    rapid = None
    if step_is_rapid is not None:
        rapid = step_is_rapid[np.minimum(np.arange(1, n + 1), core.n_steps - 1)].copy()
    return EpisodeRecord(
        time=rec["time"][sl],
        contour_error=rec["contour_error"][sl],
        tracking_error=rec["tracking_error"][sl],
        force=force,
        saturated=np.abs(force) >= limit * (1 - 1e-12),
        position=rec["position"][sl],
        reference=rec["reference"][sl],
        force_limit=limit.copy(),
        termination_reason=reason,
        n_steps_planned=n_max,
        encoder_resolution_m=np.array(core.setup.plant.params.encoder_resolution_m, dtype=float),
        rapid=rapid,
    )


def evaluate(env, policy=None, *, seed: int = 0) -> dict:
    """Metrics of one episode of ``policy`` on ``env`` (the project's one scoring function)."""
    return score(run_episode(env, policy, seed=seed))
