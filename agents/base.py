"""The one policy protocol: reset, then act from what a real servo controller measures.

A :class:`Controller` is bound to a contour_env env (``bind``), from which it reads the
nominal plant model, the servo period and, every sample, ``env.signals()`` (measured
position/velocity, the reference and its derivatives, the path frame and curvature). Its
``predict(observation, state=None, episode_start=None, deterministic=True)`` has
stable-baselines3's shape, so one evaluation path scores controllers and agents alike.
"""

from __future__ import annotations

import numpy as np


def _core_of(env):
    for candidate in (env, getattr(env, "unwrapped", None)):
        core = getattr(candidate, "core", None)
        if core is not None:
            return candidate, core
    raise ValueError("env: expected a contour_env ContouringEnv (or a wrapper of one)")


class Controller:
    """Base class. Subclasses implement :meth:`act` (command in the plant's units, N) and may
    keep internal state (integrators, adaptive estimates) reset by :meth:`reset`."""

    name = "controller"

    def __init__(self):
        self._env = None
        self.nominal = None
        self.servo_period_s = None
        self.force_limit = None
        self.n_axes = None

    def bind(self, env) -> Controller:
        """Attach to an env (single env or a wrapper of one) and reset."""
        holder, core = _core_of(env)
        plant = core.setup.plant
        if self.n_axes is not None and self.n_axes != plant.n_axes:
            raise ValueError(
                f"env: controller {self.name!r} was built for a {self.n_axes}-axis plant, the "
                f"env has {plant.n_axes} axes"
            )
        self._env = holder
        self.nominal = plant.nominal
        self.servo_period_s = plant.servo_period_s
        self.force_limit = plant.params.force_limit_N.copy()
        self.n_axes = plant.n_axes
        self.configure()
        self.reset()
        return self

    def configure(self) -> None:
        """Derive gains from the bound plant (called by :meth:`bind`)."""

    def reset(self) -> None:
        """Start of an episode: clear integrators and estimates."""

    def act(self, signals: dict) -> np.ndarray:
        raise NotImplementedError

    def action(self, signals: dict) -> np.ndarray:
        """The env action: the command as a fraction of the force limit, clipped to [-1, 1]."""
        u = np.asarray(self.act(signals), dtype=np.float64)
        return np.clip(u / self.force_limit, -1.0, 1.0).astype(np.float32)

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        """stable-baselines3 signature; reads the bound env's servo signals."""
        if self._env is None:
            raise ValueError(f"controller {self.name!r}: call bind(env) before predict")
        if episode_start is not None and np.any(episode_start):
            self.reset()
        return self.action(self._env.signals()), state
