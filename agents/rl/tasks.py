"""Domain randomisation: what each training episode runs on (case or path, feed, plant).

Every episode draws, with the sampler's own seeded generator:

- a path source, uniformly among the training cases, the G-code files and each enabled kind of
  ``path_variety``: ``circles`` (radius uniform in ``circle_radius_m``, start angle uniform,
  sweep uniform in [π/2, 2π] rad, either direction; plane: xy on a 2-axis plant, a uniformly
  random normal on a 3-axis plant) or ``splines`` (an open C² spline through 5 points drawn
  uniformly in a cube of side ``spline_size_m``, xy-plane on a 2-axis plant; see
  :func:`contour_env.paths.spline`) or ``families``: a part of a family drawn uniformly from
  ``TrainConfig.training_families`` with a path seed drawn in
  [0, :data:`~agents.rl.families.VALIDATION_SEED_BASE`)
  (:func:`~agents.rl.families.generate_path`: its own feed and feed limits, plant variation
  with p = ``randomize_plant`` and a random disturbance phase);
- the feedrate: the source's own (the case's, the program's F words; circles and splines use
  the first case's feed, or the middle of the plant's family feed range without cases) times
  U[1 − f, 1 + f] with f = ``randomize_feedrate`` (not for ``families``: they draw their own);
- the true plant: every per-axis parameter of
  :data:`contour_env.plants.randomize.RANDOMIZED_FIELDS` times U[1 − p, 1 + p] with
  p = ``randomize_plant`` (:func:`contour_env.plants.randomize.randomized`); the base
  controller keeps the nominal model, as on a real machine.

G-code files of the held-out evaluation suite are refused (:mod:`agents.rl.heldout`).
"""

from __future__ import annotations

import math

import numpy as np

from contour_env.cases import build_setup, get_case
from contour_env.paths import circle, spline
from contour_env.plants import Plant
from contour_env.plants.randomize import randomized

from .families import VALIDATION_SEED_BASE, generate_path, plant_ranges
from .heldout import refuse_heldout

DEFAULT_RANDOM_PATH_FEED_M_S = 0.02


class TaskSampler:
    """Draws env keyword arguments per episode for a :class:`~agents.rl.config.TrainConfig`."""

    def __init__(self, config, seed: int):
        self.config = config
        self.rng = np.random.default_rng(seed)
        self.plant_name = config.plant_name
        self.plant = Plant(self.plant_name)
        self.n_axes = self.plant.n_axes
        for f in config.gcode:
            refuse_heldout(f, "gcode")
        self.families = config.training_families if "families" in config.path_variety else ()
        self.sources = [("case", c) for c in config.cases]
        self.sources += [("gcode", f) for f in config.gcode]
        self.sources += [(kind, None) for kind in config.path_variety]
        if config.cases:
            self.random_feed = get_case(config.cases[0]).feedrate_m_s
        elif config.gcode:
            self.random_feed = build_setup(plant=self.plant_name, path=config.gcode[0]).feedrate_m_s
        else:
            self.random_feed = float(np.mean(plant_ranges(self.plant_name).feed_m_s))

    @property
    def fixed(self) -> bool:
        return not self.config.randomized

    def nominal_tasks(self) -> list[dict]:
        """The training cases and G-code files without randomisation (the evaluation set)."""
        env = self.config.env_config()
        tasks = [{"case": c, **env} for c in self.config.cases]
        tasks += [{"plant": self.plant_name, "path": f, **env} for f in self.config.gcode]
        return tasks

    def sample(self) -> dict:
        cfg = self.config
        rng = self.rng
        kind, value = self.sources[int(rng.integers(len(self.sources)))]
        kw = dict(cfg.env_config())
        if kind == "families":
            family = self.families[int(rng.integers(len(self.families)))]
            seed = int(rng.integers(0, VALIDATION_SEED_BASE))
            part = generate_path(family, self.plant_name, seed, plant_variation=cfg.randomize_plant)
            kw.update(part.env_kwargs())
            return kw
        if kind == "case":
            kw["case"] = value
            feed = get_case(value).feedrate_m_s
        elif kind == "gcode":
            kw.update(plant=self.plant_name, path=value)
            feed = build_setup(plant=self.plant_name, path=value).feedrate_m_s
        else:
            kw.update(plant=self.plant_name, path=self._random_path(kind))
            feed = self.random_feed
        f = cfg.randomize_feedrate
        if f or kind not in ("case", "gcode"):
            kw["feedrate_m_s"] = float(feed * rng.uniform(1 - f, 1 + f))
        if cfg.randomize_plant:
            seed = int(rng.integers(0, 2**31))
            kw["plant_params"] = randomized(self.plant.params, cfg.randomize_plant, 1, seed=seed)
        return kw

    def _random_path(self, kind: str):
        rng = self.rng
        cfg = self.config
        if kind == "circles":
            r = float(rng.uniform(*cfg.circle_radius_m))
            if self.n_axes == 2:
                normal = (0.0, 0.0, 1.0)
            else:
                v = rng.normal(size=3)
                normal = tuple(v / np.linalg.norm(v))
            return circle(
                (0.0, 0.0, 0.0),
                r,
                normal=normal,
                start_angle=float(rng.uniform(0, 2 * math.pi)),
                sweep=float(rng.uniform(math.pi / 2, 2 * math.pi)),
                ccw=bool(rng.integers(2)),
            )
        if kind == "splines":
            size = cfg.spline_size_m
            pts = rng.uniform(0.0, size, size=(5, 3))
            if self.n_axes == 2:
                pts[:, 2] = 0.0
            pts[0] = 0.0
            return spline(pts)
        raise ValueError(f"path_variety: unknown kind {kind!r}")
