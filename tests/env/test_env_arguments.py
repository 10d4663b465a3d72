"""Bad arguments of the env are refused with one clear error (issue 36 items 9-12): an unknown
argument, a render mode the env does not have, a step after the episode ended, a seed outside
numpy's range."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.error import ResetNeeded

from contour_env import ENV_ID
from contour_env.env.contouring_env import ContouringEnv
from contour_env.env.core import EnvConfig

CASE = "hsm2-circle-III"


# ------------------------------------------------------------- 9: unknown arguments
def test_unknown_argument_is_named_with_the_known_ones():
    with pytest.raises(ValueError) as e:
        gym.make(ENV_ID, case=CASE, foo=1)
    msg = str(e.value)
    assert msg.startswith("unknown argument 'foo'; the env's arguments are: case, plant, path")
    # every documented argument is listed: the env's own and EnvConfig's fields
    for name in (
        "render_mode",
        "num_threads",
        "strict",
        "rapid_feed_m_s",
        *EnvConfig.__dataclass_fields__,
    ):
        assert name in msg
    assert "\n" not in msg and "EnvConfig.__init__" not in msg
    with pytest.raises(ValueError, match=r"^unknown arguments 'foo', 'w_contur'; "):
        gym.make(ENV_ID, case=CASE, foo=1, w_contur=2.0)
    with pytest.raises(ValueError, match=r"^unknown argument 'bar'"):
        gym.make_vec(ENV_ID, num_envs=2, vectorization_mode="vector_entry_point", case=CASE, bar=1)


# --------------------------------------------------------------- 10: render modes
@pytest.mark.parametrize("mode", ["human", "rgb_array_list", "ansi"])
def test_render_modes_the_env_does_not_have_are_refused(mode):
    assert ContouringEnv.metadata["render_modes"] == ["rgb_array"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no HumanRendering wrapper with only a warning
        with pytest.raises(ValueError) as e:
            gym.make(ENV_ID, case=CASE, render_mode=mode)
    assert str(e.value) == (
        f"render_mode: must be None or one of the env's render modes ('rgb_array'), got {mode!r}"
    )


def test_rgb_array_is_still_made_unwrapped():
    env = gym.make(ENV_ID, case=CASE, render_mode="rgb_array")
    assert env.render_mode == "rgb_array"
    assert not isinstance(env, gym.wrappers.HumanRendering)
    assert isinstance(env.unwrapped, ContouringEnv)


# ------------------------------------------------------- 11: step after the end
def test_step_after_the_episode_ended_raises_until_reset():
    env = gym.make(ENV_ID, case="sharp-corner").unwrapped
    env.reset(seed=0)
    n, done = 0, False
    while not done:  # a tool that never moves is stopped by the tracking guard
        _, reward, terminated, truncated, info = env.step(np.zeros(2))
        n += 1
        done = terminated or truncated
    assert terminated and info["termination_reason"] == "tracking_error_limit"
    k = info["step"]
    with pytest.raises(
        ResetNeeded, match=rf"episode has ended \(tracking_error_limit, step {k}\); call reset\(\)"
    ):
        env.step(np.zeros(2))
    assert env.core.k[0] == k  # time did not advance
    env.reset(seed=0)
    _, reward, terminated, _, info = env.step(np.zeros(2))
    assert info["step"] == 1 and not terminated and reward == 0.0


def test_step_after_truncation_raises():
    env = gym.make(ENV_ID, case=CASE, settle_time_s=0.0).unwrapped
    from agents import make_controller

    policy = make_controller("pd").bind(env)
    obs, info = env.reset(seed=0)
    truncated = False
    while not truncated:
        action, _ = policy.predict(obs)
        obs, _, terminated, truncated, info = env.step(action.reshape(-1))
        assert not terminated
    with pytest.raises(ResetNeeded, match="truncated: the path is done"):
        env.step(np.zeros(2))


# ---------------------------------------------------------------- 12: seed range
@pytest.mark.parametrize(
    "seed, what", [(2**70, "about 2\\*\\*70"), (2**64, "about 2\\*\\*64"), (-1, "negative")]
)
def test_seed_outside_numpys_range_is_refused(seed, what):
    env = gym.make(ENV_ID, case=CASE)
    with pytest.raises(
        ValueError,
        match=rf"^seed: must be in \[0, 2\*\*64 - 1\] \(numpy's seed range\), "
        rf"got {seed} \({what}\)$",
    ):
        env.reset(seed=seed)


def test_seeds_in_range_are_accepted_and_distinct():
    env = gym.make(ENV_ID, case=CASE, measurement_noise_std_m=1e-6)
    largest, _ = env.reset(seed=2**64 - 1)
    zero, _ = env.reset(seed=0)
    assert env.unwrapped.core.seed[0] == 0
    env.reset(seed=2**64 - 1)
    assert int(env.unwrapped.core.seed[0]) == 2**64 - 1
    with pytest.raises(ValueError, match="seed: expected None or an integer"):
        env.reset(seed=1.5)


def test_vector_env_seed_range():
    venv = gym.make_vec(ENV_ID, num_envs=4, vectorization_mode="vector_entry_point", case=CASE)
    with pytest.raises(ValueError, match=r"^seed: must be in \[0, 2\*\*64 - 1\]"):
        venv.reset(seed=2**70)
    with pytest.raises(ValueError, match=r"with 4 envs the seed must be <= 2\*\*64 - 4"):
        venv.reset(seed=2**64 - 2)
    venv.reset(seed=2**64 - 4)
    assert int(venv.core.seed[-1]) == 2**64 - 1
