"""Compare controllers on one case with the project's one scoring function (Lee 2012 Tables 2
and 3 style), optionally over plant-parameter variations with the vectorised env."""

from __future__ import annotations

import gymnasium as gym
import numpy as np

from contour_env import ENV_ID
from contour_env.evaluation import run_episode
from contour_env.metrics import score
from contour_env.plants.randomize import randomized

from .registry import make_controller

CVAR_FRACTION = 0.10
# the row name of a trained residual agent (``model``: a model DIR, or the shipped agent)
RESIDUAL = "residual"


def comparable_names() -> list[str]:
    """Names ``compare`` accepts: every fixed controller of the registry and ``residual``."""
    from .registry import controller_names

    return [*controller_names(), RESIDUAL]


def bound_controller(name: str, env, model=None):
    """``name`` bound to ``env``; ``residual`` is the agent in ``model`` (a model DIR written
    by ``contour-env train``) or, without one, the shipped agent for the env's plant
    (``ValueError`` when there is none, or when the agent was trained for another plant or
    number of axes)."""
    if name != RESIDUAL:
        return make_controller(name).bind(env)
    from .base import _core_of
    from .residual import ResidualAgent
    from .rl.models import shipped_model_for

    _, core = _core_of(env)
    model_dir = model if model is not None else shipped_model_for(core.setup.plant.name)
    return ResidualAgent(model_dir).bind(env)


def compare(
    controllers: list[str], *, seed: int = 0, progress=None, model=None, **env_kwargs
) -> dict:
    """Run every controller on the same env; an unstable one is reported, not raised.
    ``model``: the model DIR of the ``residual`` row (default: the shipped agent).

    Returns {"case": ..., "plant": ..., "results": [{"controller", "stable", metrics...}],
    "records": {name: EpisodeRecord}} (records are for plotting; not JSON).
    """
    results, records = [], {}
    setup = None
    for name in controllers:
        env = gym.make(ENV_ID, **env_kwargs)
        setup = env.unwrapped.setup
        controller = bound_controller(name, env, model)
        record = run_episode(env, controller, seed=seed)
        m = score(record)
        row = {"controller": name, "stable": record.completed, **m}
        results.append(row)
        records[name] = record
        if progress:
            progress(name, row)
    return {"case": setup.name, "plant": setup.plant.name, "results": results, "records": records}


def robustness(
    controllers: list[str],
    fraction: float,
    episodes: int,
    *,
    seed: int = 0,
    progress=None,
    model=None,
    **env_kwargs,
) -> list[dict]:
    """Each controller over ``episodes`` true-plant variations (every per-axis parameter of
    :data:`contour_env.plants.randomize.RANDOMIZED_FIELDS` scaled by U[1 − f, 1 + f]), run as
    one vectorised env; the controllers keep the nominal model. Reports the mean and the
    CVaR of the worst 10 % of RMS contour error, the worst max contour error and the failure
    rate (episodes stopped by the crash guard)."""
    probe = gym.make(ENV_ID, **env_kwargs).unwrapped
    variants = randomized(probe.plant.params, fraction, episodes, seed=seed)
    rows = []
    for name in controllers:
        venv = gym.make_vec(
            ENV_ID,
            num_envs=episodes,
            vectorization_mode="vector_entry_point",
            plant_params=variants,
            **env_kwargs,
        )
        controller = bound_controller(name, venv, model)
        obs, _ = venv.reset(seed=seed)
        core = venv.core if hasattr(venv, "core") else venv.unwrapped.core
        n = core.n_steps - 1
        running = np.ones(episodes, dtype=bool)
        failed = np.zeros(episodes, dtype=bool)
        sq = np.zeros(episodes)
        peak = np.zeros(episodes)
        count = np.zeros(episodes)
        for _ in range(n):
            action, _ = controller.predict(obs)
            obs, _, term, trunc, info = venv.step(action)
            eps = np.where(np.isfinite(info["contour_error"]), info["contour_error"], np.inf)
            sq[running] += np.minimum(eps[running], 1e3) ** 2
            peak[running] = np.maximum(peak[running], eps[running])
            count[running] += 1
            failed |= running & term
            running &= ~(term | trunc)
            if not running.any():
                break
        rms = np.sqrt(sq / np.maximum(count, 1)) * 1e6
        worst = np.sort(rms)[::-1][: max(1, int(round(CVAR_FRACTION * episodes)))]
        row = {
            "controller": name,
            "episodes": episodes,
            "randomize": fraction,
            "mean_rms_contour_error_um": float(np.mean(rms)),
            "cvar10_rms_contour_error_um": float(np.mean(worst)),
            "worst_max_contour_error_um": float(np.max(np.minimum(peak, 1e3)) * 1e6),
            "failure_rate": float(np.mean(failed)),
        }
        rows.append(row)
        if progress:
            progress(name, row)
    return rows


def format_table(comparison: dict, robust: list[dict] | None = None) -> str:
    """Lee 2012 Tables 2 and 3 layout: max/RMS contour error (µm), RMS effort per axis."""
    rows = comparison["results"]
    pd_rms = next((r["rms_contour_error_um"] for r in rows if r["controller"] == "pd"), None)
    lines = [
        f"case {comparison['case']} (plant {comparison['plant']})",
        f"{'controller':14s}{'max ε µm':>11s}{'RMS ε µm':>11s}{'RMS/PD':>8s}"
        f"{'  RMS effort per axis':s}",
    ]
    for r in rows:
        if not r["stable"]:
            lines.append(
                f"{r['controller']:14s}  UNSTABLE ({r['termination_reason']} after "
                f"{r['n_steps']} steps)"
            )
            continue
        ratio = f"{r['rms_contour_error_um'] / pd_rms:8.2f}" if pd_rms else f"{'':8s}"
        effort = ", ".join(f"{e:.4g}" for e in r["rms_effort"])
        lines.append(
            f"{r['controller']:14s}{r['max_contour_error_um']:11.1f}"
            f"{r['rms_contour_error_um']:11.2f}{ratio}  [{effort}]"
        )
    if robust:
        lines.append("")
        lines.append(
            f"robustness: {robust[0]['episodes']} plant variations, "
            f"±{robust[0]['randomize'] * 100:.0f} %"
        )
        lines.append(
            f"{'controller':14s}{'mean RMS ε':>12s}{'CVaR10 RMS ε':>14s}"
            f"{'worst max ε':>13s}{'failures':>10s}"
        )
        for r in robust:
            lines.append(
                f"{r['controller']:14s}{r['mean_rms_contour_error_um']:12.2f}"
                f"{r['cvar10_rms_contour_error_um']:14.2f}"
                f"{r['worst_max_contour_error_um']:13.1f}{r['failure_rate']:10.1%}"
            )
    return "\n".join(lines)
