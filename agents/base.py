"""The one policy protocol: reset, then act from what a real servo controller measures.

A :class:`Controller` is bound to a contour_env env (``bind``: a single env, a wrapper of one,
or the vectorised env), from which it reads the nominal plant model, the servo period and,
every sample, the servo signals (``env.signals()``: measured position/velocity, the reference
and its derivatives, the path frame and curvature). Controllers compute on a batch (leading
axis B; a single env is a batch of one), so the same object runs as a policy, as the base of
a residual agent (:meth:`command`) and inside repeated-batch ILC. ``predict(observation,
state=None, episode_start=None, deterministic=True)`` has stable-baselines3's shape, so one
evaluation path scores controllers and agents alike.
"""

from __future__ import annotations

import numpy as np

from contour_env.env.core import core_of, signals_to_batch

# the controllers of the five-axis plant (agents.registry.FIVE_AXIS_CONTROLLERS, which imports
# this module): what a feed-drive controller bound to that plant is told to use instead
FIVE_AXIS_NAMES = ("pd", "pid", "ismc")


class Controller:
    """Base class. Subclasses implement :meth:`act` on batched signals (command in the plant's
    units, N; velocity-command units for ``jee-triaxial``) and keep per-env state (integrators,
    adaptive estimates) that :meth:`reset` clears."""

    name = "controller"
    # the plant family the class runs on: None = the feed-drive plants (2/3 axes)
    plant_family = None

    def __init__(self):
        self._core = None
        self._single = True
        self.nominal = None
        self.servo_period_s = None
        self.force_limit = None
        self.n_axes = None
        self.n_envs = 1
        self.computation_delay_steps = 0

    def bind(self, env) -> Controller:
        """Attach to an env and reset; returns this controller, of its own class. The
        controller keeps the axis count it was first bound with: binding it to an env with
        another number of axes is an error.

        A feed-drive controller (``plant_family`` None) bound to a five-axis env is a
        ``ValueError`` naming the controller, the plant and the fix: build the five-axis class
        with ``agents.make_controller(spec, env=env)`` (or ``plant_family='five-axis'``;
        :data:`FIVE_AXIS_NAMES`)."""
        holder, core = core_of(env)
        family = getattr(core.setup, "family", None)
        if family == "five-axis" and self.plant_family != family:
            raise ValueError(self._five_axis_refusal(core.setup.plant))
        self._attach(core.setup.plant, core.n_envs)
        self._core = core
        self._single = not hasattr(holder, "num_envs")
        self.configure()
        self.reset()
        return self

    def configure_for(self, plant) -> Controller:
        """Derive the gains for ``plant`` (a :class:`contour_env.plants.Plant`) without an env,
        for analysis (loop margins); the controller cannot :meth:`predict` until bound."""
        self._attach(plant, 1)
        self.configure()
        self.reset()
        return self

    def _attach(self, plant, n_envs: int) -> None:
        if self.n_axes is not None and self.n_axes != plant.n_axes:
            raise ValueError(
                f"env: controller {self.name!r} was built for a {self.n_axes}-axis plant, the "
                f"env has {plant.n_axes} axes"
            )
        self.nominal = plant.nominal
        self.servo_period_s = plant.servo_period_s
        self.force_limit = plant.params.force_limit_N.copy()
        self.n_axes = plant.n_axes
        self.n_envs = n_envs
        # the controller's own computation delay (samples) is a property of the servo
        # hardware its designer knows, not a plant uncertainty
        self.computation_delay_steps = int(plant.params.computation_delay)

    def _five_axis_refusal(self, plant) -> str:
        """Why this feed-drive controller does not bind to the five-axis ``plant``, and the fix
        (the spec it was made from by :func:`agents.make_controller`, else its name)."""
        spec = getattr(getattr(self, "_spec", None), "label", self.name)
        head = (
            f"env: controller {spec!r} ({type(self).__name__}) is a feed-drive controller; the "
            f"env has the five-axis plant {plant.name!r}"
        )
        names = ", ".join(FIVE_AXIS_NAMES)
        if self.name not in FIVE_AXIS_NAMES:
            return (
                f"{head}, and {self.name!r} is not available on the five-axis plant (its "
                f"controllers: {names}; build one with agents.make_controller(name, env=env) or "
                "plant_family='five-axis')"
            )
        return (
            f"{head}; build its five-axis controller with agents.make_controller({spec!r}, "
            f"env=env) or agents.make_controller({spec!r}, plant_family='five-axis') (the "
            f"five-axis controllers: {names})"
        )

    def compiled_form(self):
        """The law as arrays for the compiled episode loop (:mod:`agents.compiled`), or None
        (no compiled law for this exact class, or not bound). ``act`` stays the reference the
        compiled law follows."""
        from .compiled import compiled_form

        return compiled_form(self)

    def configure(self) -> None:
        """Derive gains from the bound plant (called by :meth:`bind`)."""

    def reset(self, mask=None) -> None:
        """Start of an episode for the envs in ``mask`` (all if None)."""

    def act(self, signals: dict) -> np.ndarray:
        """Command (B, A) from batched signals (see :meth:`EnvCore.signals_batch`)."""
        raise NotImplementedError

    def loop_gains(
        self,
        frame: np.ndarray,
        curvature: float = 0.0,
        torsion: float = 0.0,
        feedrate_m_s: float = 0.0,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The feedback law linearised at a frozen path point, for loop analysis
        (:mod:`agents.margins`): matrices (A0, A1, A2), each (A, A), such that

            u_k = A0 E_k + A1 (E_k − E_{k−1}) / T + A2 T Σ_{j≤k} E_j,    E = x_d − x_measured,

        with ``frame`` (A, A) the path frame columns [t n (b)], the signed curvature (1/m),
        torsion (1/m) and feedrate (m/s) of that point. Feedforward terms (which do not close a
        loop) and slow adaptation are left out. Controllers without a linear feedback model
        raise ``ValueError``."""
        raise ValueError(f"controller {self.name!r}: no linear feedback model for loop analysis")

    def command(self, signals: dict) -> np.ndarray:
        """The residual-base interface: command (B, A) in the plant's units for (single or
        batched) signals."""
        return self.act(signals_to_batch(signals))

    def action(self, signals: dict) -> np.ndarray:
        """Env action (B, A): the command as a fraction of the force limit, clipped to [-1, 1]."""
        u = np.asarray(self.command(signals), dtype=np.float64)
        return np.clip(u / self.force_limit, -1.0, 1.0).astype(np.float32)

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        """stable-baselines3 signature; reads the bound env's servo signals."""
        if self._core is None:
            raise ValueError(f"controller {self.name!r}: call bind(env) before predict")
        if episode_start is not None:
            mask = np.asarray(episode_start, dtype=bool).reshape(-1)
            if mask.any():
                self.reset(mask if mask.size == self.n_envs else None)
        a = self.action(self._core.signals_batch())
        return (a[0] if self._single else a), state


def per_axis(name: str, value, n_axes: int) -> np.ndarray:
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim == 0:
        arr = np.full(n_axes, float(arr))
    if arr.shape != (n_axes,):
        raise ValueError(
            f"{name}: expected a scalar or {n_axes} per-axis values (the controller is bound to "
            f"a {n_axes}-axis plant), got shape {arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: must be finite")
    return arr
