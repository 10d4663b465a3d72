"""Vectorised contouring env: N envs stepped by one compiled call (same kernel as the single env).

Created by ``gymnasium.make_vec("contour_env/Contouring-v0", num_envs=N,
vectorization_mode="vector_entry_point", ...)``. Autoreset follows Gymnasium's default
NEXT_STEP mode: the step after an env's episode ends resets it (its action is ignored, reward
0, not done; a NaN or infinite action is refused all the same, as at any step).
``reset(seed=s)`` seeds env i with s + i, so env i replays exactly what a single env reset
with seed s + i does (noise and random disturbances are keyed by that seed).

The arrays returned by ``reset`` and ``step`` are new at every call and never written again
by the env, so they may be kept without copying.
"""

from __future__ import annotations

import numpy as np
from gymnasium import spaces
from gymnasium.error import ResetNeeded
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from .core import MAX_SEED, check_seed
from .factory import make_core
from .protocol import Core


class ContouringVectorEnv(VectorEnv):
    """N independent contouring envs on one case; arguments as :class:`ContouringEnv`."""

    metadata = {"render_modes": [], "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(
        self, num_envs: int = 1, case=None, plant=None, path=None, *, render_mode=None, **kwargs
    ):
        if render_mode is not None:
            raise ValueError("render_mode: the vector env does not render; use the single env")
        self.core: Core = make_core(case, plant, path, n_envs=num_envs, **kwargs)
        self.num_envs = self.core.n_envs
        n = self.core.dim
        self.single_action_space = spaces.Box(-1.0, 1.0, (n,), dtype=np.float32)
        clip = self.core.config.obs_clip
        self.single_observation_space = spaces.Box(
            -clip, clip, (self.core.obs_dim,), dtype=np.float32
        )
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.render_mode = None
        # envs whose episode ended at the last step (reset at this one); None: no env
        self._needs_reset = None
        self._rng = np.random.default_rng()
        self._was_reset = False  # step before the first reset: ResetNeeded

    @property
    def setup(self):
        return self.core.setup

    def reset(self, *, seed=None, options=None):
        if seed is None:
            base = int(self._rng.integers(0, 2**62))
        elif isinstance(seed, (int, np.integer)) and not isinstance(seed, (bool, np.bool_)):
            base = check_seed(seed)
            if base + self.num_envs - 1 > MAX_SEED:
                raise ValueError(
                    f"seed: env i gets seed + i, so with {self.num_envs} envs the seed must be "
                    f"<= 2**64 - {self.num_envs} (numpy's seed range), got {base}"
                )
            self._rng = np.random.default_rng(base)
        else:
            raise ValueError("seed: the vector env takes one integer (env i gets seed + i)")
        # new output arrays first: the ones handed out by the last step stay as they were
        self.core.renew_outputs()
        self.core.reset_envs(np.arange(self.num_envs), [base + b for b in range(self.num_envs)])
        self._needs_reset = None
        self._was_reset = True
        return self.core.obs, self.core.batch_info()

    def step(self, actions):
        if not self._was_reset:
            raise ResetNeeded(
                "step: call reset() before the first step (the episodes have not begun)"
            )
        core = self.core
        a = np.asarray(actions)
        if a.dtype.kind not in "fiu":
            # complex (its imaginary part would be dropped), bool, text, objects: no command
            raise ValueError(f"actions: expected real numbers, got dtype {a.dtype}")
        a = a.astype(np.float64, copy=False)
        if a.shape != (self.num_envs, core.dim):
            raise ValueError(
                f"actions: expected shape ({self.num_envs}, {core.dim}), got {a.shape}"
            )
        a = np.ascontiguousarray(a)
        resetting = self._needs_reset
        if resetting is not None:
            # the autoreset ignores these envs' actions; a non-finite one is refused all the same
            core.refuse_nonfinite(a, resetting)
        active = core.all_active if resetting is None else ~resetting
        # The kernel writes the info of every env it steps, and the observations, rewards and
        # done flags into new arrays (fresh_outputs): cheaper than copying them afterwards,
        # while the data is still in the stepping threads' caches. Those arrays are returned
        # as they are; the core never writes them again.
        info = core.new_info_arrays()
        # the envs not stepped are reset right below, which writes their output rows: nothing
        # to carry over from the previous arrays
        n_ended = core.step(a, active, info, fresh_outputs=True, carry_inactive=False)
        if resetting is not None:
            envs = np.flatnonzero(resetting)
            # one draw per env in index order (the same seeds as drawing them one by one)
            core.reset_envs(envs, self._rng.integers(0, 2**62, size=len(envs)))
            core.fill_info(info, envs)
        self._needs_reset = core.terminated | core.truncated if n_ended else None
        return core.obs, core.reward, core.terminated, core.truncated, core.info_dict(info)
