"""The stable-baselines3 VecEnv the trainers use, built on :class:`ResidualVectorWrapper`.

- One fixed task (a single case or G-code file, no randomisation): one compiled vectorised env
  of ``n_envs`` envs (``gymnasium.make_vec(..., vectorization_mode="vector_entry_point")``),
  stepped by one kernel call per servo period.
- Randomised tasks: ``n_envs`` vectorised envs of one env each; when an episode ends its env is
  rebuilt on a newly drawn task (:class:`agents.rl.tasks.TaskSampler`) — a path's reference
  table is built once per episode (milliseconds against the seconds an episode takes).

Episode ends follow stable-baselines3: the returned observation is the next episode's first,
``infos[i]["terminal_observation"]`` the last one, ``infos[i]["TimeLimit.truncated"]`` set when
the path ended (truncation) rather than the crash guard (termination).
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
from stable_baselines3.common.vec_env import VecEnv

from contour_env import ENV_ID

from ..residual import ResidualVectorWrapper

# the reward scale of a task is never below this (m): a part the base follows within a tenth
# of a micrometre would otherwise give rewards of thousands per step
MIN_REWARD_SCALE_M = 1e-7


def base_error_figures(task: dict, base: str) -> tuple[float, float]:
    """(RMS, max) contour error of the base on the task (m; seed 0, the compiled loop where it
    applies): the reward's scale (at least :data:`MIN_REWARD_SCALE_M`) and the cap above which
    the max penalty acts (:class:`agents.residual.ResidualVectorWrapper`'s ``error_cap_m``);
    (10 µm, ∞) when the base does not complete the task."""
    from contour_env.evaluation import evaluate

    from ..registry import make_controller

    kw = dict(task)
    params = kw.pop("plant_params", None)
    if params is not None:
        kw["plant_params"] = params[:1]
    m = evaluate(gym.make(ENV_ID, **kw), make_controller(base))
    rms = m["rms_contour_error_um"]
    if rms is None or not np.isfinite(rms) or not m["completed"]:
        return 10e-6, np.inf
    return max(float(rms) * 1e-6, MIN_REWARD_SCALE_M), float(m["max_contour_error_um"]) * 1e-6


def base_error_scale(task: dict, base: str) -> float:
    """The base controller's RMS contour error (m) on the task (seed 0, the compiled loop where
    it applies), at least :data:`MIN_REWARD_SCALE_M`: the task's reward scale with
    ``reward_scale="base"``, so that a step's reward −ε / ε_base is in units of what the base
    does on this part and every part weighs the same in the return, as in the per-part ratios
    that choose and judge the agent."""
    from contour_env.evaluation import evaluate

    from ..registry import make_controller

    kw = dict(task)
    params = kw.pop("plant_params", None)
    if params is not None:
        kw["plant_params"] = params[:1]
    m = evaluate(gym.make(ENV_ID, **kw), make_controller(base))
    rms = m["rms_contour_error_um"]
    if rms is None or not np.isfinite(rms) or not m["completed"]:
        return 10e-6  # the env's default scale: the base does not complete the task
    return max(float(rms) * 1e-6, MIN_REWARD_SCALE_M)


def make_residual_vec(
    task: dict, n: int, wrapper_kwargs: dict, reward_scale="fixed", max_penalty: float = 0.0
):  # fmt: skip
    """The residual vector env of ``n`` envs on ``task``; with ``reward_scale="base"`` the
    env's ``contour_error_scale_m`` is the base's RMS contour error on the task, and with
    ``max_penalty`` > 0 the wrapper's reward pays that much per unit of that scale by which
    the contour error exceeds the base's max on the task."""
    kw = dict(task)
    cap = np.inf
    if reward_scale == "base" or max_penalty > 0:
        scale, cap = base_error_figures(task, wrapper_kwargs["base"])
        if reward_scale == "base":
            kw["contour_error_scale_m"] = scale
    params = kw.pop("plant_params", None)
    if params is not None and len(params) != n:
        params = [params[i % len(params)] for i in range(n)]
    venv = gym.make_vec(
        ENV_ID, num_envs=n, vectorization_mode="vector_entry_point", plant_params=params, **kw
    )
    w = ResidualVectorWrapper(venv, autoreset_mode="same_step", **wrapper_kwargs)
    if max_penalty > 0 and np.isfinite(cap):
        w.set_error_cap(cap, max_penalty)
    return w


class ResidualTrainVecEnv(VecEnv):
    """sb3 VecEnv of ``n_envs`` residual envs drawn from ``sampler`` (seeded by ``seed``)."""

    def __init__(
        self, sampler, n_envs: int, wrapper_kwargs: dict, seed: int, reward_scale="fixed",
        max_penalty: float = 0.0,
    ):  # fmt: skip
        self.sampler = sampler
        self.wrapper_kwargs = dict(wrapper_kwargs)
        self.reward_scale = reward_scale
        self.max_penalty = float(max_penalty)
        self.rng = np.random.default_rng(seed)
        self.resample = not sampler.fixed
        if self.resample:
            self.groups = [self._build(1) for _ in range(n_envs)]
        else:
            self.groups = [self._build(n_envs)]
        g0 = self.groups[0]
        self._actions = None
        # the envelope of the states trained on (agents/envelope.py), widened every step when
        # ``track_envelope`` is set (the trainer's, with TrainConfig.envelope)
        self.envelope = None
        self.track_envelope = False
        super().__init__(n_envs, g0.single_observation_space, g0.single_action_space)

    def _build(self, n: int) -> ResidualVectorWrapper:
        return make_residual_vec(
            self.sampler.sample(), n, self.wrapper_kwargs, self.reward_scale, self.max_penalty
        )

    def _seed(self) -> int:
        return int(self.rng.integers(0, 2**31))

    def _slices(self):
        start = 0
        for g in self.groups:
            yield g, slice(start, start + g.num_envs)
            start += g.num_envs

    @property
    def action_repeat(self) -> int:
        return self.groups[0].action_repeat

    def reset(self):
        obs = np.empty((self.num_envs, *self.observation_space.shape), dtype=np.float32)
        for g, sl in self._slices():
            o, _ = g.reset(seed=self._seed())
            obs[sl] = o
        self._reset_seeds()
        self._reset_options()
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions)

    def step_wait(self):
        n = self.num_envs
        obs = np.empty((n, *self.observation_space.shape), dtype=np.float32)
        rewards = np.empty(n, dtype=np.float32)
        dones = np.zeros(n, dtype=bool)
        infos = [{} for _ in range(n)]
        for gi, (g, sl) in enumerate(list(self._slices())):
            if self.track_envelope:
                self._widen(g)
            o, r, term, trunc, info = g.step(self._actions[sl])
            obs[sl] = o
            rewards[sl] = r
            done = term | trunc
            dones[sl] = done
            for j in np.flatnonzero(done):
                i = sl.start + int(j)
                infos[i]["terminal_observation"] = info["final_obs"][j].copy()
                infos[i]["TimeLimit.truncated"] = bool(trunc[j] and not term[j])
                infos[i]["termination_reason"] = str(info["termination_reason"][j]) or None
            if self.resample and done.any():
                fresh = self._build(1)
                self.groups[gi] = fresh
                o, _ = fresh.reset(seed=self._seed())
                obs[sl] = o
        return obs, rewards, dones, infos

    def _widen(self, g) -> None:
        """The envelope widened by the current state of group ``g``'s envs (where the agent's
        residual acts: the reference moving)."""
        from ..envelope import Envelope, features_of_core

        core = g.core
        if self.envelope is None:
            self.envelope = Envelope(core.dim)
        kk = np.minimum(core.k, core.n_steps - 1)
        moving = core.scal[kk, 0] > 0
        if moving.any():
            self.envelope.update(features_of_core(core)[moving])
            self.envelope.update_feed(core.setup.feedrate_m_s)

    def close(self) -> None:
        for g in self.groups:
            g.close()

    # --- the rest of sb3's VecEnv interface ------------------------------------------------
    def _indices(self, indices):
        if indices is None:
            return range(self.num_envs)
        if isinstance(indices, int):
            return [indices]
        return indices

    def _group_of(self, i):
        for g, sl in self._slices():
            if sl.start <= i < sl.stop:
                return g
        raise IndexError(i)

    def get_attr(self, attr_name, indices=None):
        if attr_name == "render_mode":
            return [None for _ in self._indices(indices)]
        return [getattr(self._group_of(i), attr_name) for i in self._indices(indices)]

    def set_attr(self, attr_name, value, indices=None):
        for i in self._indices(indices):
            setattr(self._group_of(i), attr_name, value)

    def env_method(self, method_name, *method_args, indices=None, **method_kwargs):
        return [
            getattr(self._group_of(i), method_name)(*method_args, **method_kwargs)
            for i in self._indices(indices)
        ]

    def env_is_wrapped(self, wrapper_class, indices=None):
        return [False for _ in self._indices(indices)]
