"""A step before the first reset raises ResetNeeded (issue 49, item 7): it used to run an
episode from an unset state (reward -678,500, contour_error_limit)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.error import ResetNeeded

from contour_env import ENV_ID


def test_the_single_env_refuses_a_step_before_reset():
    env = gym.make(ENV_ID, case="hsm2-circle-III")
    with pytest.raises(ResetNeeded, match="call reset\\(\\) before the first step"):
        env.unwrapped.step(np.zeros(2))
    env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.unwrapped.step(np.zeros(2))
    assert np.isfinite(reward) and not terminated and info["termination_reason"] is None


def test_the_vector_env_refuses_a_step_before_reset():
    venv = gym.make_vec(ENV_ID, num_envs=3, vectorization_mode="vector_entry_point",
                        case="hsm2-circle-III")  # fmt: skip
    with pytest.raises(ResetNeeded, match="call reset\\(\\) before the first step"):
        venv.step(np.zeros((3, 2)))
    venv.reset(seed=0)
    _, reward, terminated, _, _ = venv.step(np.zeros((3, 2)))
    assert np.all(np.isfinite(reward)) and not terminated.any()
