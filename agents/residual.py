"""Residual RL on top of a classical controller: the env wrappers and the trained agent.

Residual policy learning (Johannink et al. 2019, "Residual Reinforcement Learning for Robot
Control"; Silver et al. 2018, "Residual Policy Learning"): the applied command is

    a_applied = clip(a_base + scale · m ⊙ clip(a_agent, −1, 1), −1, 1)    (fractions of the
                                                                            force limit)

with ``a_base`` the base controller's env action (its command in the plant's units divided by
the force limit, clipped to [−1, 1], float32 — exactly what the controller hands the env when
it runs as a policy) and ``a_agent`` the agent's action in [−1, 1]. The residual is bounded by
construction: |a_applied − a_base| ≤ ``scale`` per axis (``scale`` in fractions of the axis
force limit, default :data:`DEFAULT_SCALE` = 0.05; the base controllers' RMS effort is 1–2 %
of the limit on ``friction-table`` and 10–30 % on ``hsm2``/``jee-triaxial``, so 5 % is room to
cancel friction and ripple without letting a bad agent leave the base's neighbourhood; raise
it explicitly to give the agent more authority). With a zero agent action the wrappers apply
``a_base`` bit for bit, so they reproduce the base controller exactly.

``m`` is the axis mask (``residual_axes``): by default 1 on the axes the path uses and 0 on
the others (:func:`path_axes_mask`: the reference spans more than 1 µm on the axis), so a
residual never moves an axis that should stand still — the z axis of a planar part on a
three-axis plant, where the base commands nothing (the linear-motor agent shipped before this
option drove z with 11 N RMS on planar parts). ``residual_axes="all"`` keeps every axis (what
agents trained before the option used; their ``agent.json`` has no ``residual_axes`` and they
are run that way).

``observe_base_command`` appends ``a_base`` (the base command about to be applied, as a
fraction of the force limit) to the observation. Default False: the residual learned better
from the state alone in five of six checkpoints we measured (SAC, seed 0, evaluation RMS ε at
10k / 20k / 30k steps: ``lm-circle3d`` on CCC 2.29 / 1.86 / 1.81 µm without it against
2.93 / 2.03 / 2.14 µm with it; ``sharp-corner`` on PD 0.59 / 0.44 / 1.96 against
1.68 / 1.58 / 1.32 µm), and it keeps the agent independent of the base's gains.

``action_repeat`` k: the agent acts every k servo periods and its residual is held (zero-order
hold) in between, while the base controller still runs every servo period. The reward of a
wrapper step is the mean env reward over the k periods minus ``residual_penalty`` ·
‖a_agent‖² / n. Default k: one agent action per millisecond
(:func:`default_action_repeat`), i.e. k = 1 on the 1 ms plants and k = 10 on ``linear-motor``
(T = 0.1 ms), which keeps the learning problem's horizon in the thousands of steps.

Classes:

- :class:`ResidualWrapper` — ``gymnasium.Wrapper`` over the single env.
- :class:`ResidualVectorWrapper` — ``gymnasium.vector.VectorWrapper`` over the vectorised env
  (``gymnasium.make_vec(..., vectorization_mode="vector_entry_point")``), Gymnasium's
  NEXT_STEP autoreset (as the env) or SAME_STEP (what stable-baselines3 expects).
- :class:`ResidualAgent` — a trained model directory as a :class:`agents.base.Controller`
  (``bind``/``reset``/``act``/``command``/``predict``), scored by
  :func:`contour_env.evaluation.evaluate` like any controller.
"""

from __future__ import annotations

import math
from pathlib import Path

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorWrapper
from gymnasium.vector.utils import batch_space

from contour_env.env.core import core_of

from .base import Controller
from .model_files import MODEL_FORMAT, OBSERVATIONS, RESIDUAL_AXES  # noqa: F401 (re-exported)
from .registry import FIVE_AXIS_CONTROLLERS, controller_names, make_controller, plant_family_of
from .residual_law import (
    REST_FADE_FEED_FRACTION,
    action_size,
    check_flag,
    check_frame,
    path_weights,
    residual_command,
    rest_fade,
)

DEFAULT_SCALE = 0.05
# the default authority of a trained agent per plant where 5 % is not enough (issue 48): the
# linear motor's static friction is 20 N of its 300 N limit (6.7 %) — its teacher, held to 5 %,
# sat on the bound at 48–94 % of the agent steps of generated parts and stopped at 0.50x CCC's
# RMS contour error; at 10 % it reached 0.21x (the closing note)
DEFAULT_SCALE_BY_PLANT = {"linear-motor": 0.10}


def default_scale(plant_name: str) -> float:
    """The default residual authority (fraction of the force limit) of an agent of a plant."""
    from contour_env.plants.catalog import PLANT_ALIASES

    return DEFAULT_SCALE_BY_PLANT.get(PLANT_ALIASES.get(plant_name, plant_name), DEFAULT_SCALE)


# OBSERVATIONS (what of the env observation the agent sees, see observation_fields) and
# RESIDUAL_AXES (which axes take a residual, see path_axes_mask): agents.model_files
# an axis whose reference moves less than this over the episode is not used by the path (m)
AXIS_USE_TOL_M = 1e-6
DEFAULT_AGENT_PERIOD_S = 1e-3


def default_action_repeat(servo_period_s: float) -> int:
    """Servo periods per agent action for one agent action per ms (at least 1)."""
    return max(1, int(round(DEFAULT_AGENT_PERIOD_S / float(servo_period_s))))


def _check_scale(scale) -> float:
    if isinstance(scale, bool) or not isinstance(scale, (int, float, np.number)):
        raise ValueError(
            f"scale: expected a number in (0, 2] (fraction of the force limit), got {scale!r}"
        )
    s = float(scale)
    if not (math.isfinite(s) and 0 < s <= 2):
        raise ValueError(
            f"scale: must be in (0, 2] (fraction of the force limit; 2 spans the whole "
            f"[-1, 1] range), got {scale!r}"
        )
    return s


def _check_repeat(action_repeat, servo_period_s) -> int:
    if action_repeat is None:
        return default_action_repeat(servo_period_s)
    if isinstance(action_repeat, bool) or not isinstance(action_repeat, (int, np.integer)):
        raise ValueError(f"action_repeat: expected an integer >= 1 or None, got {action_repeat!r}")
    if action_repeat < 1:
        raise ValueError(f"action_repeat: must be >= 1 servo period, got {action_repeat}")
    return int(action_repeat)


def _check_axes(residual_axes) -> str:
    if residual_axes not in RESIDUAL_AXES:
        raise ValueError(
            f"residual_axes: must be one of {', '.join(RESIDUAL_AXES)}, got {residual_axes!r}"
        )
    return residual_axes


def path_axes_mask(core) -> np.ndarray:
    """(n_axes,) float: 1.0 for each axis whose reference position spans more than
    :data:`AXIS_USE_TOL_M` over the episode (the path uses it), 0.0 for the others (e.g. z
    of a planar part on a three-axis plant, where the base commands nothing)."""
    p = np.asarray(core.ref_pav)[:, 0, : core.dim]
    span = p.max(axis=0) - p.min(axis=0)
    return (span > AXIS_USE_TOL_M).astype(np.float64)


class _AxisMask:
    """The residual's axis mask for one env core, recomputed when the core's reference
    changes (a new path); all ones with ``residual_axes="all"``."""

    def __init__(self, core, residual_axes: str):
        self.core = core
        self.residual_axes = _check_axes(residual_axes)
        self._ref = None
        self._mask = np.ones(core.dim)

    def __call__(self) -> np.ndarray:
        if self.residual_axes == "all":
            return self._mask
        ref = self.core.ref_pav
        if ref is not self._ref:
            self._mask = path_axes_mask(self.core)
            self._ref = ref
        return self._mask


def _check_penalty(value) -> float:
    v = float(value)
    if not (math.isfinite(v) and v >= 0):
        raise ValueError(f"residual_penalty: must be finite and >= 0, got {value!r}")
    return v


def make_base(base, env, base_kwargs=None) -> Controller:
    """A base controller bound to ``env``: a registry name (see
    :func:`agents.registry.controller_names`) or a :class:`Controller` instance."""
    if isinstance(base, str):
        # the controllers of the env's plant family (pd and ismc on the five-axis plant)
        five_axis = plant_family_of(env) == "five-axis"
        known = list(FIVE_AXIS_CONTROLLERS) if five_axis else controller_names()
        if base not in known:
            raise ValueError(f"base: unknown controller {base!r}; known: {', '.join(known)}")
        ctrl = make_controller(base, env=env, **(base_kwargs or {}))
    elif isinstance(base, Controller):
        ctrl = base
    else:
        raise ValueError(
            f"base: expected a controller name ({', '.join(controller_names())}) or a "
            f"Controller, got {type(base).__name__}"
        )
    return ctrl.bind(env)


def observation_fields(core, observation: str):
    """Indices of the env observation the agent sees: ``None`` for ``"full"`` (every field),
    every field but the previous action for ``"state"``, the task-frame position and velocity
    errors (the first 2 n fields, see ContouringEnv) for ``"errors"``."""
    if observation not in OBSERVATIONS:
        raise ValueError(
            f"observation: must be one of {', '.join(OBSERVATIONS)}, got {observation!r}"
        )
    if observation == "full":
        return None
    if observation == "state":
        # every field but the previous action (the last n): a student copying the previous
        # action, which the teacher's smooth correction makes the best predictor of the next
        # one, feeds its own output back (issue 48)
        return np.arange(core.obs_dim - core.dim)
    return np.arange(2 * core.dim)


def observation_size(core, observation: str, observe_base_command: bool, observe_axes: bool):
    """Length of the agent's observation: the selected env fields, the axis observation
    (2 n) and the base command (n)."""
    fields = observation_fields(core, observation)
    seen = core.obs_dim if fields is None else len(fields)
    return seen + (2 * core.dim if observe_axes else 0) + (core.dim if observe_base_command else 0)


def _obs_space(w) -> spaces.Box:
    clip = w.core.config.obs_clip
    dim = observation_size(w.core, w.observation, w.observe_base_command, w.observe_axes)
    return spaces.Box(-clip, clip, (dim,), dtype=np.float32)


class AgentView:
    """What the agent sees, built from the env observation and the servo signals of the same
    sample (batched): the selected env fields (in the path frame, the previous-action fields
    rotated into it), then the axis observation, then the base command
    (:mod:`agents.residual_law`)."""

    def __init__(self, core, observation, residual_frame, observe_axes, observe_base_command):
        self.fields = observation_fields(core, observation)
        self.n = core.dim
        # the last n fields of the full observation: the previous action, per axis
        self.rotate_prev = residual_frame == "path" and self.fields is None
        self.observe_axes = observe_axes
        self.observe_base_command = observe_base_command
        self.feed = float(core.setup.feedrate_m_s)
        self.acc = float(core.setup.max_accel_m_s2)
        self.clip = float(core.config.obs_clip)

    def __call__(self, obs, signals, base_action) -> np.ndarray:
        """(B, size) float32 for the env observations ``obs`` (B, O), the batched servo
        signals and the base's action (B, n) (read only with ``observe_base_command``). The
        view is :func:`agents.compiled.residual_runner.view_rows`, the definition the compiled
        episode loops run too."""
        from .compiled.forms import signal_tables
        from .compiled.residual_runner import view_rows

        obs = np.ascontiguousarray(obs, dtype=np.float32)
        if obs.ndim != 2:
            raise ValueError(f"obs: expected (B, obs_dim), got shape {obs.shape}")
        needs = ("frame",) if self.rotate_prev else ()
        if self.observe_axes:
            needs += ("reference_acceleration",)
        _, ref_pav, frame, _ = signal_tables(signals, self.n, needs)
        n_fields = obs.shape[1] if self.fields is None else len(self.fields)
        size = n_fields + (2 * self.n if self.observe_axes else 0)
        x = np.empty((obs.shape[0], size), dtype=np.float32)
        view_rows(
            self.n, obs, ref_pav, frame, self._field_index(obs.shape[1]), self.rotate_prev,
            self.observe_axes, self.feed, self.acc, self.clip, x,
        )  # fmt: skip
        if not self.observe_base_command:
            return x
        return np.concatenate([x, np.asarray(base_action, dtype=np.float32)], axis=1)

    def _field_index(self, n_obs: int) -> np.ndarray:
        if self.fields is None:
            return np.arange(n_obs, dtype=np.int64)
        return np.ascontiguousarray(self.fields, dtype=np.int64)


def _agent_action(action, shape, what="action") -> np.ndarray:
    a = np.asarray(action, dtype=np.float64)
    if a.shape != shape:
        if a.size == int(np.prod(shape)):
            a = a.reshape(shape)
        else:
            raise ValueError(f"{what}: expected shape {shape}, got {np.shape(action)}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{what}: must be finite (agent action in [-1, 1]), got {a.tolist()}")
    return np.clip(a, -1.0, 1.0)


def _configure(
    w,
    env,
    core,
    base,
    *,
    scale=DEFAULT_SCALE,
    observe_base_command=False,
    action_repeat=None,
    residual_penalty=0.0,
    base_kwargs=None,
    observation="full",
    residual_axes="path",
    residual_frame="axes",
    gate=False,
    observe_axes=False,
    fade_at_rest=False,
) -> None:
    """The residual law's settings, checked, on wrapper ``w``: both wrappers' keyword
    arguments (``**law``) and their defaults."""
    w.core = core
    w.scale = _check_scale(scale)
    w.residual_axes = _check_axes(residual_axes)
    w.residual_frame = check_frame(residual_frame)
    w.gate = check_flag(gate, "gate")
    w.observe_axes = check_flag(observe_axes, "observe_axes")
    w.fade_at_rest = check_flag(fade_at_rest, "fade_at_rest")
    w._v_rest = rest_speed(core) if w.fade_at_rest else 0.0
    w._axis_mask = _AxisMask(core, residual_axes)
    w.observe_base_command = bool(observe_base_command)
    w.observation = observation
    w._view = AgentView(core, observation, w.residual_frame, w.observe_axes, w.observe_base_command)
    w.action_repeat = _check_repeat(action_repeat, core.T)
    w.residual_penalty = _check_penalty(residual_penalty)
    w.base = make_base(base, env, base_kwargs)
    w.n_axes = core.dim
    w.n_actions = action_size(core.dim, w.gate)
    w._weights = None
    if w.residual_frame == "path":
        if getattr(core.setup.plant, "family", None) == "five-axis":
            raise ValueError(
                "residual_frame: 'path' is for the feed-drive plants (the tool-tip frame does "
                "not span the five joints); use residual_frame='axes' on the five-axis plant"
            )
        w._weights = path_weights(core.setup.plant.nominal)


def _residual(w, a, signals):
    """(residual (B, n), gate (B,)) of wrapper ``w`` for clipped agent actions ``a``."""
    fade = rest_fade(signals["feedrate"], w._v_rest) if w._v_rest else None
    frame = signals["frame"] if w.residual_frame == "path" else None
    return residual_command(
        a, frame, w.scale, w._axis_mask(), w.residual_frame, w.gate, w._weights, fade
    )


def set_error_cap(w, cap_m: float, penalty: float) -> None:
    """Make each servo period's reward of wrapper ``w`` pay ``penalty`` · min(ε − ``cap_m``,
    1 m)⁺ / the env's ``contour_error_scale_m`` on top of the env's reward: the trainer's max
    penalty, the cap the base's max contour error on the part (issue 48: a part is judged on
    its max, and a reward on the error alone let RL trade a higher max for a lower RMS).
    ``penalty`` 0 removes it."""
    cap = float(cap_m)
    p = float(penalty)
    if not (math.isfinite(p) and p >= 0) or not cap >= 0:
        raise ValueError(f"error cap: cap >= 0 m and penalty >= 0, got {cap_m!r}, {penalty!r}")
    w._cap = cap if p > 0 else None
    w._cap_penalty = p


def _cap_cost(w) -> np.ndarray:
    """The max penalty of the period just stepped, per env."""
    scale = float(w.core.config.contour_error_scale_m)
    over = np.maximum(np.nan_to_num(w.core.eps, nan=np.inf) - w._cap, 0.0)
    return w._cap_penalty * np.minimum(over, 1.0) / scale


def rest_speed(core) -> float:
    """v_rest of :func:`agents.residual_law.rest_fade` for an env core (m/s)."""
    return REST_FADE_FEED_FRACTION * float(core.setup.feedrate_m_s)


def _penalty(w, res) -> np.ndarray:
    """residual_penalty · ‖r / scale‖² / n per env: the applied residual (after frame, clip,
    mask and gate), in units of the authority."""
    return w.residual_penalty * np.sum((res / w.scale) ** 2, axis=1) / w.n_axes


_WRAPPER_DOC_ARGS = """
    residual_frame : ``"axes"`` (default here and for agents trained before the option: one
        action component per machine axis) or ``"path"`` (the action pushes along the task
        frame's t, n (, b), rotated onto the axes every servo period; see
        :mod:`agents.residual_law`).
    gate : bool — one more action component g = clip(a_g, 0, 1) multiplying the residual
        (default False).
    observe_axes : bool — append the per-axis reference velocity and acceleration to the
        observation (default False).
    fade_at_rest : bool — no residual while the reference stands still, faded in over the
        first 5 % of the feed (default False).
"""


class ResidualWrapper(gym.Wrapper):
    """Residual action on a single contour_env env (see the module docstring for the law).

    Parameters
    ----------
    env : a ContouringEnv or a wrapper of one (e.g. from ``gymnasium.make``).
    base : str or Controller — base controller (default ``"pd"``); bound to ``env`` here.
    scale : float — residual authority, fraction of the force limit per axis (default 0.05).
    observe_base_command : bool — append the base action (fraction of the force limit) to the
        observation (default False).
    observation : ``"full"`` (default: every field of the env observation), ``"state"``
        (every field but the previous action: what a student of the teacher sees) or ``"errors"``
        (only the task-frame position and velocity errors: a policy of the errors alone, which
        cannot tell one path from another).
    action_repeat : int or None — servo periods per agent action (None: one per ms).
    residual_penalty : float — reward weight on ‖r / scale‖² / n, r the applied residual
        (default 0; the trainer uses 1).
    base_kwargs : dict — arguments of the base controller when ``base`` is a name.
    residual_axes : ``"path"`` (default: a residual only on the axes the path uses, see
        :func:`path_axes_mask`; zero on the others, so an agent cannot disturb an axis that
        should stand still) or ``"all"`` (every axis; the agents shipped before this option).
    residual_frame, gate, observe_axes : see below.

    ``info`` gains ``base_action`` and ``residual_action`` (fractions of the force limit, the
    last servo period of the step), ``gate`` (g, 1 without a gate) and ``servo_steps``
    (periods simulated by the step).
    """

    __doc__ += _WRAPPER_DOC_ARGS

    def __init__(self, env, base="pd", **law):
        holder, core = core_of(env)
        if hasattr(holder, "num_envs"):
            raise ValueError("env: a vectorised env; use ResidualVectorWrapper")
        super().__init__(env)
        _configure(self, env, core, base, **law)
        n = core.dim
        self.action_space = spaces.Box(-1.0, 1.0, (self.n_actions,), dtype=np.float32)
        self.observation_space = _obs_space(self)
        self._base_next = np.zeros((1, n), dtype=np.float32)
        self._sig = None
        self._cap = None
        self._cap_penalty = 0.0

    def set_error_cap(self, cap_m: float, penalty: float) -> None:
        """See :func:`set_error_cap`."""
        set_error_cap(self, cap_m, penalty)

    def _observe(self, obs):
        return self._view(np.asarray(obs)[None, :], self._sig, self._base_next)[0]

    def _next_base(self) -> None:
        self._sig = self.core.signals_batch()
        self._base_next = self.base.action(self._sig)

    def reset(self, *, seed=None, options=None):
        obs, info = self.env.reset(seed=seed, options=options)
        self.base.reset()
        self._next_base()
        return self._observe(obs), info

    def step(self, action):
        a = _agent_action(action, (1, self.n_actions))
        total, steps = 0.0, 0
        obs = info = None
        terminated = truncated = False
        applied = None
        pen = 0.0
        for _ in range(self.action_repeat):
            res, g = _residual(self, a, self._sig)
            applied = np.clip(self._base_next[0].astype(np.float64) + res[0], -1.0, 1.0)
            obs, reward, terminated, truncated, info = self.env.step(applied)
            total += float(reward)
            pen += float(_penalty(self, res)[0]) if self.residual_penalty else 0.0
            if self._cap is not None:
                pen += float(_cap_cost(self)[0])
            steps += 1
            base_used = self._base_next[0]
            self._next_base()
            if terminated or truncated:
                break
        reward = (total - pen) / steps
        info = dict(info)
        info["base_action"] = base_used.astype(np.float64)
        info["residual_action"] = applied - base_used
        info["gate"] = float(g[0])
        info["servo_steps"] = steps
        return self._observe(obs), reward, terminated, truncated, info


class ResidualVectorWrapper(VectorWrapper):
    """Residual action on the vectorised contour_env env (same law and arguments as
    :class:`ResidualWrapper`; the base controller computes on the whole batch).

    ``autoreset_mode``: ``"next_step"`` (default; Gymnasium's NEXT_STEP like the env: the step
    after an env's episode ends resets it, action ignored, reward 0) or ``"same_step"`` (the
    env is reset within the step that ends it; the returned observation is the new episode's
    first, the last one is in ``info["final_obs"]`` with mask ``info["_final_obs"]`` — what
    stable-baselines3 expects). Within a step of k servo periods an env whose episode ends is
    held (not stepped) for the remaining periods. Reset seeds follow the env: ``reset(seed=s)``
    gives env i seed s + i; later autoresets draw from a generator seeded with s.
    """

    def __init__(self, env, base="pd", *, autoreset_mode="next_step", **law):
        holder, core = core_of(env)
        if not hasattr(holder, "num_envs"):
            raise ValueError("env: a single env; use ResidualWrapper")
        super().__init__(env)
        if autoreset_mode not in ("next_step", "same_step"):
            raise ValueError(f"autoreset_mode: 'next_step' or 'same_step', got {autoreset_mode!r}")
        self.core = core
        self.same_step = autoreset_mode == "same_step"
        self.metadata = dict(getattr(env, "metadata", {}))
        self.metadata["autoreset_mode"] = (
            AutoresetMode.SAME_STEP if self.same_step else AutoresetMode.NEXT_STEP
        )
        _configure(self, env, core, base, **law)
        n = core.dim
        self.single_action_space = spaces.Box(-1.0, 1.0, (self.n_actions,), dtype=np.float32)
        self.single_observation_space = _obs_space(self)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self._needs_reset = np.zeros(self.num_envs, dtype=bool)
        self._rng = np.random.default_rng()
        self._cap = None
        self._cap_penalty = 0.0
        self._base_next = np.zeros((self.num_envs, n), dtype=np.float32)
        self._sig = None

    def _observe(self, obs):
        return self._view(obs, self._sig, self._base_next)

    def set_error_cap(self, cap_m: float, penalty: float) -> None:
        """See :func:`set_error_cap`."""
        set_error_cap(self, cap_m, penalty)

    def _next_base(self) -> None:
        self._sig = self.core.signals_batch()
        self._base_next = np.asarray(self.base.action(self._sig))

    def reset(self, *, seed=None, options=None):
        obs, info = self.env.reset(seed=seed, options=options)
        if isinstance(seed, (int, np.integer)):
            self._rng = np.random.default_rng(int(seed))
        self._needs_reset[:] = False
        self.base.reset()
        self._next_base()
        return self._observe(obs), info

    def _reset_envs(self, mask: np.ndarray) -> None:
        """Reset the envs in ``mask`` (the base controller's state is reset separately, right
        before its next action, so that every env gets exactly one base action per period)."""
        envs = np.flatnonzero(mask)
        self.core.reset_envs(envs, self._rng.integers(0, 2**62, size=len(envs)).tolist())

    def step(self, actions):
        core = self.core
        B = self.num_envs
        a = _agent_action(actions, (B, self.n_actions), "actions")
        resetting = self._needs_reset.copy()
        if resetting.any():
            # not stepped in this step (their residual is not applied)
            self._reset_envs(resetting)
        active = ~resetting
        total = np.zeros(B)
        pen = np.zeros(B)
        steps = np.zeros(B, dtype=np.int64)
        terminated = np.zeros(B, dtype=bool)
        truncated = np.zeros(B, dtype=bool)
        base_used = self._base_next
        res, g = _residual(self, a, self._sig)
        for j in range(self.action_repeat):
            if j > 0:
                self._next_base()
                res, g = _residual(self, a, self._sig)
            base_used = self._base_next
            applied = np.clip(base_used.astype(np.float64) + res, -1.0, 1.0)
            core.step(np.ascontiguousarray(applied), active.copy())
            total[active] += core.reward[active]
            if self.residual_penalty:
                pen[active] += _penalty(self, res)[active]
            if self._cap is not None:
                pen[active] += _cap_cost(self)[active]
            steps[active] += 1
            terminated |= active & core.terminated
            truncated |= active & core.truncated
            active &= ~(core.terminated | core.truncated)
            if not active.any():
                break
        reward = np.where(steps > 0, (total - pen) / np.maximum(steps, 1), 0.0)
        done = terminated | truncated
        info = core.batch_info()
        info["base_action"] = base_used.astype(np.float64)
        info["residual_action"] = np.clip(base_used + res, -1.0, 1.0) - base_used
        info["gate"] = g
        info["servo_steps"] = steps
        obs = core.obs.copy()
        base_reset = resetting
        if self.same_step and done.any():
            # the final observation's base part is the last applied base action (the base
            # controller is not asked again at a terminal state)
            final = self._view(obs, core.signals_batch(), base_used)
            self._reset_envs(done)
            obs = core.obs.copy()
            info["final_obs"] = np.where(done[:, None], final, 0.0).astype(np.float32)
            info["_final_obs"] = done.copy()
            base_reset = resetting | done
            self._needs_reset[:] = False
        else:
            self._needs_reset = done
        if base_reset.any():
            self.base.reset(base_reset)
        self._next_base()
        return self._observe(obs), reward, terminated, truncated, info


# --- trained agents -------------------------------------------------------------------------


def read_model_metadata(model_dir) -> dict:
    """The ``agent.json`` of a trained model directory (format, plant, axes, base, scale, …),
    checked key by key (:func:`agents.model_files.read_agent_json`)."""
    from .model_files import read_agent_json

    d = Path(model_dir)
    meta_path = d / "agent.json"
    if not d.is_dir():
        raise FileNotFoundError(f"model: {d} is not a directory (expected a trained model DIR)")
    if not meta_path.is_file():
        raise ValueError(
            f"model: {d} holds no agent.json; not a trained residual agent (train one with "
            "`contour-env train`)"
        )
    return read_agent_json(meta_path)


class ResidualAgent(Controller):
    """A trained residual agent (model DIR written by ``contour-env train``) as a controller.

    ``bind(env)`` checks that the env's plant and number of axes are those the agent was
    trained for (otherwise ``ValueError``), binds the base controller and resets. ``act`` reads
    the bound env's current observation (``env.core.obs``, the observation the env returned
    last), normalises it with the saved VecNormalize statistics, queries the model every
    ``action_repeat`` servo periods (deterministic actions by default) and returns
    (a_base + r) × force limit, in the plant's units, r the residual of
    :func:`agents.residual_law.residual_command` (its frame, gate and axis mask as in
    ``agent.json``). ``action`` returns the applied fraction exactly as
    :class:`ResidualWrapper` computes it, so :func:`contour_env.evaluation.evaluate` scores
    the agent as it was trained.

    An agent whose ``agent.json`` says ``"kept": "base"`` (no checkpoint beat the base
    controller on the validation set, :mod:`agents.rl.validation`) is its base: ``is_base``
    is True and the applied action is the base's, bit for bit; the network is not queried.
    """

    name = "residual"

    def __init__(self, model_dir, *, deterministic: bool = True, device: str = "cpu"):
        from .rl.checkpoint import load_model, load_normalization

        d = Path(model_dir)
        meta = read_model_metadata(d)
        self._setup(
            meta,
            load_model(d / "model.zip", meta["algo"], device=device),
            load_normalization(d / "normalization.json", int(meta["obs_dim"])),
            deterministic,
        )
        self.model_dir = d

    @classmethod
    def from_parts(cls, meta: dict, model, normalizer, *, deterministic: bool = True):
        """An agent from an in-memory sb3 model and observation normaliser (used by the
        trainer's periodic evaluation); ``meta`` as ``agent.json``."""
        agent = cls.__new__(cls)
        agent._setup(meta, model, normalizer, deterministic)
        agent.model_dir = Path("<in memory>")
        return agent

    def _setup(self, meta, model, normalizer, deterministic):
        Controller.__init__(self)
        self.meta = meta
        self.model = model
        self.norm = normalizer
        self.deterministic = bool(deterministic)
        # the deterministic action as NumPy products (agents.rl.actor): every path that
        # scores the agent uses it, so they agree to the bit
        self._actor = None
        if self.deterministic:
            from .rl.actor import numpy_actor

            self._actor = numpy_actor(model)
        self.scale = float(meta["scale"])
        self.observe_base_command = bool(meta["observe_base_command"])
        self.observation = meta.get("observation", "full")
        if self.observation not in OBSERVATIONS:
            raise ValueError(
                f"agent.json: observation {self.observation!r}, expected one of "
                f"{', '.join(OBSERVATIONS)}"
            )
        self.action_repeat = int(meta["action_repeat"])
        # agents trained before the options: a residual on every axis, in the axes frame,
        # no gate, no axis observation
        self.residual_axes = _check_axes(meta.get("residual_axes", "all"))
        self.residual_frame = check_frame(meta.get("residual_frame", "axes"))
        self.gate = check_flag(meta.get("gate", False), "agent.json: gate")
        self.observe_axes = check_flag(meta.get("observe_axes", False), "agent.json: observe_axes")
        self.fade_at_rest = check_flag(meta.get("fade_at_rest", False), "agent.json: fade_at_rest")
        self._v_rest = 0.0
        self.is_base = meta.get("kept") == "base"
        self._axis_mask = None
        self.base_name = meta["base"]
        self.base_kwargs = dict(meta.get("base_kwargs") or {})
        # the ranges it was trained on (agents/envelope.py); agents before issue 48 have none
        self.envelope = None
        if meta.get("envelope") is not None:
            from .envelope import Envelope

            self.envelope = Envelope.from_dict(meta["envelope"], int(meta["n_axes"]))
        self.use_envelope = self.envelope is not None
        self._decisions = 0
        self._outside = 0
        self.base: Controller | None = None
        self._a = None
        self._count = None
        self._view = None

    def bind(self, env) -> ResidualAgent:
        _, core = core_of(env)
        plant = core.setup.plant
        want_plant, want_axes = self.meta["plant"], int(self.meta["n_axes"])
        if plant.n_axes != want_axes:
            raise ValueError(
                f"env: the agent in {self.model_dir} was trained for a {want_axes}-axis plant "
                f"({want_plant!r}); the env has {plant.n_axes} axes ({plant.name!r})"
            )
        want_T = self.meta.get("servo_period_s")
        if want_T is not None and not math.isclose(want_T, core.T, rel_tol=1e-9):
            raise ValueError(
                f"env: the agent in {self.model_dir} was trained at a servo period of "
                f"{want_T!r} s (agent.json: servo_period_s); the env's is {core.T!r} s"
            )
        if plant.name != want_plant:
            raise ValueError(
                f"env: the agent in {self.model_dir} was trained for plant {want_plant!r}; the "
                f"env's plant is {plant.name!r} (train an agent for it with `contour-env train`)"
            )
        obs_dim = observation_size(
            core, self.observation, self.observe_base_command, self.observe_axes
        )
        if obs_dim != int(self.meta["obs_dim"]):
            raise ValueError(
                f"env: observation size {obs_dim} differs from the agent's {self.meta['obs_dim']}"
                " (preview_times_s or observation options changed)"
            )
        self._view = AgentView(
            core, self.observation, self.residual_frame, self.observe_axes,
            self.observe_base_command,
        )  # fmt: skip
        self.base = make_base(self.base_name, env, self.base_kwargs)
        self._axis_mask = _AxisMask(core, self.residual_axes)
        self._weights = path_weights(plant.nominal)
        self._v_rest = rest_speed(core) if self.fade_at_rest else 0.0
        super().bind(env)
        return self

    def reset(self, mask=None) -> None:
        if self.base is None:
            return
        self.base.reset(mask)
        n_act = action_size(self.n_axes, self.gate)
        if mask is None or self._a is None:
            self._a = np.zeros((self.n_envs, n_act))
            self._count = np.zeros(self.n_envs, dtype=np.int64)
            self._decisions = 0
            self._outside = 0
        else:
            self._a[mask] = 0.0
            self._count[mask] = 0
            if np.all(mask):  # a new episode of every env (the compiled loop's reset)
                self._decisions = 0
                self._outside = 0

    def agent_action(self, obs: np.ndarray, signals: dict, base_action: np.ndarray):
        """The agent's action in [-1, 1] (B, n [+ 1]) for raw env observations (B, obs_dim)
        and the servo signals of the same sample."""
        x = self.norm(self._view(obs, signals, base_action))
        if self._actor is not None:
            return self._actor(x)
        a, _ = self.model.predict(x, deterministic=False)
        return np.clip(np.asarray(a, dtype=np.float64).reshape(x.shape[0], -1), -1.0, 1.0)

    def applied_action(self, signals: dict) -> np.ndarray:
        """The applied env action (B, A), float64 fractions of the force limit."""
        if self.base is None:
            raise ValueError("residual agent: call bind(env) first")
        from contour_env.env.core import signals_to_batch

        sig = signals_to_batch(signals)
        base_a = np.asarray(self.base.action(sig))
        if self.is_base:
            return np.clip(base_a.astype(np.float64), -1.0, 1.0)
        B = base_a.shape[0]
        due = self._count[:B] % self.action_repeat == 0
        if due.any():
            a = self.agent_action(self._core.obs[:B], sig, base_a)
            if self.use_envelope:
                from .envelope import features_of_core

                feed = float(self._core.setup.feedrate_m_s)
                f = self.envelope.factor(features_of_core(self._core)[:B], feed)
                a = self.fade_action(a, f, due)
            self._a[:B][due] = a[due]
        self._count[:B] += 1
        fade = rest_fade(sig["feedrate"], self._v_rest) if self._v_rest else None
        res, _ = residual_command(
            self._a[:B], sig["frame"], self.scale, self._axis_mask(), self.residual_frame,
            self.gate, self._weights, fade,
        )  # fmt: skip
        return np.clip(base_a.astype(np.float64) + res, -1.0, 1.0)

    def fade_action(self, a: np.ndarray, f, due=None) -> np.ndarray:
        """The agent's actions ``a`` (B, n_act) with the envelope's fade ``f`` (B,) applied:
        the gate (without one: the push) times f — clip(f a_g, 0, 1) = f clip(a_g, 0, 1) for
        f in [0, 1]. Counts the decisions (``due``: which rows decide now) and those taken
        outside the envelope (f < 1)."""
        f = np.asarray(f, dtype=np.float64).reshape(-1)
        a = np.array(a, dtype=np.float64)
        n = self.n_axes if self._core is not None else int(self.meta["n_axes"])
        if self.gate:
            a[:, n] *= f
        else:
            a[:, :n] *= f[:, None]
        rows = np.ones(len(f), dtype=bool) if due is None else np.asarray(due)
        self._decisions += int(rows.sum())
        self._outside += int(np.sum(rows & (f < 1.0)))
        return a

    def base_reason(self) -> str:
        """Why an agent kept as its base is its base (``agent.json``)."""
        release = self.meta.get("release") or {}
        if release.get("failures"):
            n = len(release["failures"])
            return (
                f"the release gate refused the trained agent (worse than its base on {n} "
                'held-out target(s), agent.json "release")'
            )
        return 'no checkpoint beat it on the validation set (agent.json "kept": "base")'

    def outside_envelope_fraction(self) -> float | None:
        """The share of the last episode's agent decisions taken outside the envelope (the
        gate faded, f < 1); None for an agent without an envelope, or kept as its base."""
        if not self.use_envelope or self.is_base or self._decisions == 0:
            return None
        return self._outside / self._decisions

    def act(self, signals: dict) -> np.ndarray:
        return self.applied_action(signals) * self.force_limit

    def action(self, signals: dict) -> np.ndarray:
        return self.applied_action(signals)

    def compiled_form(self):
        """The compiled episode loop (:mod:`agents.compiled.residual_runner`) when the base has
        a compiled form and the agent does not observe the base command (None otherwise:
        the Python loop). An agent kept as its base is its base's compiled form."""
        if self.base is None or self.observe_base_command:
            return None
        from .compiled import compiled_form

        base_form = compiled_form(self.base)
        if base_form is None or self.is_base:
            return base_form
        from .compiled.residual_runner import ResidualForm

        return ResidualForm(self, base_form)


def residual_controller(model_dir, **kwargs) -> ResidualAgent:
    """The ``residual`` row of ``contour-env compare``: the agent in ``model_dir`` (unbound;
    ``compare`` binds it to each env, which checks plant and axes)."""
    return ResidualAgent(model_dir, **kwargs)
