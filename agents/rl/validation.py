"""Keep-best-by-validation: score the policy on a fixed set of generated paths and keep the
checkpoint with the lowest mean RMS contour error (docs/RESIDUAL_TRAINING.md).

The validation set (:func:`agents.rl.families.validation_set`) is generated from seeds that
training never draws; it contains no named case and no held-out program. Each path is scored
once per evaluation by :func:`contour_env.evaluation.evaluate` (deterministic policy, the
path's own episode seed, so its random disturbance phase is the same every time); a path the
policy does not complete scores ∞, so a policy that crashes one path is never kept.

The best model so far lives in ``<out>/best/step_<timesteps>`` (one checkpoint directory,
written atomically with a manifest by :func:`agents.rl.checkpoint.write_checkpoint`; a new
best replaces it only once complete), with ``validation.json`` holding its timesteps and
score. ``validation_curve.json`` in the output folder records the paths, the base's score and
every evaluation.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import gymnasium as gym
import numpy as np

from contour_env import ENV_ID
from contour_env.evaluation import evaluate
from contour_env.io import atomic_write_json

from ..registry import make_controller
from ..residual import ResidualAgent
from .checkpoint import checkpoint_dirs, verify, write_checkpoint
from .families import validation_set

BEST_DIR = "best"
BEST_STATE = "validation.json"


class Validator:
    """Scores a policy on the validation paths of a :class:`~agents.rl.config.TrainConfig`:
    the mean RMS contour error (µm) over them and the per-path figures."""

    def __init__(self, cfg):
        self.paths = validation_set(
            cfg.plant_name,
            cfg.training_families,
            cfg.validation_paths,
            plant_variation=cfg.randomize_plant,
        )
        self.env_config = cfg.env_config()
        self.base_per_path = [self._score(p, make_controller(cfg.base)) for p in self.paths]
        self.base_rms = _mean(self.base_per_path)

    def _score(self, part, policy) -> float:
        env = gym.make(ENV_ID, **part.env_kwargs(), **self.env_config)
        m = evaluate(env, policy, seed=part.reset_seed)
        rms = m["rms_contour_error_um"]
        return math.inf if rms is None or not m["completed"] else float(rms)

    def __call__(self, meta: dict, model, normalizer) -> tuple[float, list]:
        agent = ResidualAgent.from_parts(meta, model, normalizer)
        per_path = [self._score(p, agent) for p in self.paths]
        return _mean(per_path), per_path

    def describe(self) -> list[dict]:
        return [p.describe() for p in self.paths]


def _mean(values) -> float:
    return float(np.mean(values)) if values else math.nan


def _json_number(x: float):
    """∞ (an incomplete path) as None: JSON has no infinity."""
    return None if not math.isfinite(x) else float(x)


class BestKeeper:
    """The best checkpoint by validation under ``<out>/best``; resumes from the one there."""

    def __init__(self, out: Path):
        self.root = Path(out) / BEST_DIR
        self.timesteps: int | None = None
        self.rms = math.inf
        dirs = checkpoint_dirs(self.root)
        if dirs:
            verify(dirs[-1])
            state = json.loads((dirs[-1] / BEST_STATE).read_text())
            self.timesteps = int(state["timesteps"])
            rms = state["validation_rms_contour_error_um"]
            self.rms = math.inf if rms is None else float(rms)

    @property
    def folder(self) -> Path | None:
        dirs = checkpoint_dirs(self.root)
        return dirs[-1] if dirs else None

    def offer(self, timesteps: int, rms: float, writer) -> bool:
        """Keep this model (``writer(folder)`` writes its files) if its validation RMS is
        strictly lower than the best so far (the earlier one wins a tie); a policy that does
        not complete every path (∞) is kept only while nothing better exists."""
        first = self.timesteps is None
        if not (first or rms < self.rms):
            return False

        def write(folder: Path) -> None:
            writer(folder)
            atomic_write_json(
                folder / BEST_STATE,
                {"timesteps": int(timesteps), "validation_rms_contour_error_um": _json_number(rms)},
            )

        write_checkpoint(self.root, int(timesteps), write, keep=1)
        self.timesteps, self.rms = int(timesteps), float(rms)
        return True


def validation_record(validator: Validator, base: str, curve: list, best: BestKeeper) -> dict:
    """The content of ``validation_curve.json``."""
    return {
        "base": base,
        "base_rms_contour_error_um": _json_number(validator.base_rms),
        "base_per_path_um": [_json_number(x) for x in validator.base_per_path],
        "paths": validator.describe(),
        "curve": curve,
        "best": {
            "timesteps": best.timesteps,
            "validation_rms_contour_error_um": _json_number(best.rms),
        },
    }


def curve_point(timesteps: int, rms: float, per_path: list) -> dict:
    return {
        "timesteps": int(timesteps),
        "rms_contour_error_um": _json_number(rms),
        "per_path_um": [_json_number(x) for x in per_path],
    }
