"""The ``residual`` run of a suite: a residual agent against its base controller on one test
contour (the figures of issue 5's acceptance; ``scripts/residual_benchmark.py`` prints them).

The agent and its base are scored with the project's one scoring function
(:func:`contour_env.evaluation.evaluate`, seed 0): RMS contour error agent / base, and RMS
effort agent / base per axis (the effort budget is +10 %). Test contours of an agent
(:func:`test_targets`):

- its training cases (``agent.json``) and every named case of its plant;
- every program of the held-out suite ``tests/data/heldout/`` the plant takes (the 3-D ones on
  3-axis plants only; :func:`agents.rl.scorecard.targets_for`), labelled by file name;
- ``polygon``: the 40 mm square with four sharp 90° corners (``contour_env/data/
  square_corners.nc``, exact stop at each corner), at the plant's case feedrate;
- ``spline``: an open C² spline through five fixed points (:data:`SPLINE_POINTS`, scaled
  to the plant's workspace), at the plant's case feedrate.

Neither the held-out programs, nor the polygon, nor the spline is a training path of the
shipped agents, so these rows measure generalisation.
"""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path

import numpy as np

# unit-square points of the test spline (scaled by SPLINE_SIZE_M of the plant); not a circle
SPLINE_POINTS = np.array(
    [[0.0, 0.0, 0.0], [0.35, 0.6, 0.0], [0.7, 0.15, 0.0], [1.0, 0.8, 0.0], [0.55, 1.0, 0.0]]
)
# RMS effort below which an axis counts as idle for the effort ratio, N
EFFORT_FLOOR_N = 1e-6
# workspace scale of the test spline per plant, m
SPLINE_SIZE_M = {"hsm2": 0.15, "jee-triaxial": 0.08, "linear-motor": 0.08, "friction-table": 0.04}


def _plant_feed(plant: str) -> float:
    """The feedrate of the plant's first named case, m/s."""
    from contour_env.cases import case_names, get_case

    for c in case_names():
        spec = get_case(c)
        if spec.plant == plant:
            return spec.feedrate_m_s
    raise ValueError(f"plant: no named case uses {plant!r}")


def _n_axes(plant: str) -> int:
    from contour_env.plants import Plant

    return Plant(plant).n_axes


def test_targets(meta: dict) -> list[tuple[str, dict]]:
    """(label, env kwargs) of every test contour for the agent described by ``meta``."""
    from agents.rl.scorecard import targets_for
    from contour_env.paths import spline

    plant = meta["plant"]
    scored = targets_for(plant, int(meta.get("n_axes") or _n_axes(plant)))
    named = [label for kind, label, _ in scored if kind == "case"]
    cases = [c for c in meta.get("cases") or [] if c not in named] + named
    targets = [(c, {"case": c}) for c in cases]
    targets += [(label, kw) for kind, label, kw in scored if kind == "heldout"]
    feed = _plant_feed(plant)
    polygon = str(files("contour_env") / "data" / "square_corners.nc")
    targets.append(("polygon", {"plant": plant, "path": polygon, "feedrate_m_s": feed}))
    pts = SPLINE_POINTS * SPLINE_SIZE_M[plant]
    targets.append(("spline", {"plant": plant, "path": spline(pts), "feedrate_m_s": feed}))
    return targets


test_targets.__test__ = False  # not a pytest test


def score_target(model_dir, meta: dict, label: str, env_kwargs: dict) -> dict:
    """The agent of ``model_dir`` (described by ``meta``) and its base on one test contour."""
    import gymnasium as gym

    from agents.registry import make_controller
    from agents.residual import ResidualAgent
    from contour_env import ENV_ID
    from contour_env.evaluation import evaluate

    base = evaluate(gym.make(ENV_ID, **env_kwargs), make_controller(meta["base"]))
    agent = evaluate(gym.make(ENV_ID, **env_kwargs), ResidualAgent(model_dir))
    # ratio per axis; None where the base does not use the axis (e.g. z on a planar path)
    effort = [
        a / b if b > EFFORT_FLOOR_N else None
        for a, b in zip(agent["rms_effort"], base["rms_effort"], strict=True)
    ]
    return {
        "model": str(model_dir),
        "plant": meta["plant"],
        "base": meta["base"],
        "target": label,
        "base_rms_contour_error_um": base["rms_contour_error_um"],
        "agent_rms_contour_error_um": agent["rms_contour_error_um"],
        "base_max_contour_error_um": base["max_contour_error_um"],
        "agent_max_contour_error_um": agent["max_contour_error_um"],
        "rms_ratio": agent["rms_contour_error_um"] / base["rms_contour_error_um"],
        "base_rms_effort": base["rms_effort"],
        "agent_rms_effort": agent["rms_effort"],
        "effort_ratio": effort,
        "agent_completed": bool(agent["completed"]),
    }


def benchmark_model(model_dir) -> list[dict]:
    """Every test contour's row for the agent of ``model_dir``."""
    from agents.residual import read_model_metadata

    meta = read_model_metadata(model_dir)
    return [score_target(model_dir, meta, label, kw) for label, kw in test_targets(meta)]


def shipped_agents() -> list[dict]:
    """The shipped agents (``contour-env models``) that read: name, path, plant, base, cases."""
    from agents.rl.models import list_models

    return [r for r in list_models() if "error" not in r]


def shipped_targets() -> list[tuple[str, str]]:
    """(model name, target label) of every shipped agent's test contours, in table order."""
    from agents.residual import read_model_metadata

    out = []
    for r in shipped_agents():
        meta = read_model_metadata(r["path"])
        out += [(r["name"], label) for label, _ in test_targets(meta)]
    return out


def residual_run(model: str, target: str) -> tuple[str, dict]:
    """(plant, metrics) of the shipped agent named ``model`` against its base on ``target``;
    the metrics name the model by its name (the folder moves with the checkout)."""
    from agents.residual import read_model_metadata

    rows = {r["name"]: r for r in shipped_agents()}
    if model not in rows:
        raise ValueError(f"model: no shipped agent named {model!r} (have: {', '.join(rows)})")
    model_dir = Path(rows[model]["path"])
    meta = read_model_metadata(model_dir)
    targets = dict(test_targets(meta))
    if target not in targets:
        raise ValueError(f"target: {target!r} is not a test contour of {model!r}")
    row = score_target(model_dir, meta, target, targets[target])
    row["model"] = model
    return meta["plant"], row
