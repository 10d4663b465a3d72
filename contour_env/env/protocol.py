"""The one interface of a simulation core: what the single env, the vector env, the episode
runner, the renderer and the controllers use of a batch of envs.

Two classes implement it: :class:`contour_env.env.core.EnvCore` (the feed-drive plants, 2 or
3 axes) and :class:`contour_env.env.five_axis_core.FiveAxisCore` (the five-axis machine, 5
joints). ``tests/env/test_core_protocol.py`` holds both to it, member by member and signature
by signature. What is not in it (EnvCore's kernel records, the five-axis joint tables) is the
business of each core and its own kernel.
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import numpy as np


@runtime_checkable
class Core(Protocol):
    """A batch of ``n_envs`` contouring envs on one setup. Units: SI (m, s, N; rad and N·m on
    the five-axis joints). Arrays have a leading batch axis B = ``n_envs``."""

    setup: Any  # the case, plant, path and reference (Setup / FiveAxisSetup)
    config: Any  # EnvConfig: reward weights, guards, observation scales
    n_envs: int
    dim: int  # axes (2, 3) or joints (5): the action's width
    T: float  # servo period, s
    n_steps: int  # reference samples
    obs_dim: int
    force_limit: np.ndarray  # (dim,) the drive limit an action of ±1 commands, N (N·m)
    ref_pav: np.ndarray  # (n_steps, 3, ≥dim): reference position, velocity, acceleration
    k: np.ndarray  # (B,) reference index of each env
    eps: np.ndarray  # (B,) true contour error, m
    status: np.ndarray  # (B,) 0 running, else the termination code
    obs: np.ndarray  # (B, obs_dim) float32
    reward: np.ndarray  # (B,)
    terminated: np.ndarray  # (B,) bool
    truncated: np.ndarray  # (B,) bool
    all_active: np.ndarray  # (B,) bool, all True: "step every env"

    @property
    def num_threads(self) -> Any: ...

    def step(
        self,
        action: np.ndarray,
        active: np.ndarray,
        info_arrays=None,
        fresh_outputs=False,
        carry_inactive=True,
    ) -> int: ...

    def reset_env(self, b: int, noise_seed: int) -> None: ...

    def reset_envs(self, envs, noise_seeds) -> None: ...

    def refuse_nonfinite(self, action: np.ndarray, rows: np.ndarray) -> None: ...

    def renew_outputs(self) -> None: ...

    def new_info_arrays(self) -> Any: ...  # opaque: handed back to step / fill_info / info_*

    def fill_info(self, info_arrays, envs) -> None: ...

    def info_of(self, info_arrays, b: int) -> dict: ...

    def info_dict(self, info_arrays) -> dict: ...

    def info(self, b: int) -> dict: ...

    def batch_info(self) -> dict: ...

    def signals(self, b: int = 0) -> dict: ...

    def signals_batch(self) -> dict: ...


#: the members of :class:`Core`, for the conformance test and the docs
CORE_METHODS = (
    "step", "reset_env", "reset_envs", "refuse_nonfinite", "renew_outputs", "new_info_arrays",
    "fill_info", "info_of", "info_dict", "info", "batch_info", "signals", "signals_batch",
)  # fmt: skip
CORE_ATTRIBUTES = tuple(Core.__annotations__)
