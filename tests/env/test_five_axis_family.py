"""contour_env/FiveAxis-v0 (issue 52, item 3): the five-axis machine as an env id of its own,
Gymnasium's env checker on both ids, and Contouring-v0 with plant="five-axis" as an alias that
gives the same results to the bit."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from contour_env import ENV_ID, FIVE_AXIS_ENV_ID
from contour_env.env.five_axis_family import DEFAULT_CASE


def _rollout(env, steps=300, seed=0):
    rng = np.random.default_rng(seed)
    obs, _ = env.reset(seed=seed)
    out = [obs]
    for _ in range(steps):
        obs, r, term, trunc, info = env.step(rng.uniform(-0.05, 0.05, env.action_space.shape))
        out.append(np.concatenate([obs, [r, info["contour_error"]]]))
        if term or trunc:
            break
    return np.concatenate(out)


@pytest.mark.parametrize("case", ["five-axis-line", "five-axis-circle"])
def test_the_alias_is_the_same_env_to_the_bit(case):
    new = gym.make(FIVE_AXIS_ENV_ID, case=case)
    old = gym.make(ENV_ID, case=case)
    assert type(new.unwrapped) is type(old.unwrapped)
    assert new.observation_space == old.observation_space
    np.testing.assert_array_equal(_rollout(new), _rollout(old))


def test_the_default_is_the_line_and_a_program_runs_on_the_machine():
    env = gym.make(FIVE_AXIS_ENV_ID)
    assert env.unwrapped.core.setup.name == DEFAULT_CASE
    prog = "G21 G90 G94\nG01 X10 Y0 Z0 A0 C0 F600\nG01 X10 Y10 A5 C10\n"
    a = _rollout(gym.make(FIVE_AXIS_ENV_ID, path=prog), steps=100)
    b = _rollout(gym.make(ENV_ID, plant="five-axis", path=prog), steps=100)
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize(
    "env_id, kwargs", [(FIVE_AXIS_ENV_ID, {}), (ENV_ID, {"case": "five-axis-line"})]
)
def test_gymnasiums_env_checker_passes_on_both_ids(env_id, kwargs):
    check_env(gym.make(env_id, **kwargs).unwrapped, skip_render_check=True)


def test_the_vector_env_of_the_id_is_the_vector_env_of_the_alias():
    kw = dict(num_envs=3, vectorization_mode="vector_entry_point")
    new = gym.make_vec(FIVE_AXIS_ENV_ID, case="five-axis-circle", **kw)
    old = gym.make_vec(ENV_ID, case="five-axis-circle", **kw)
    o1, _ = new.reset(seed=1)
    o2, _ = old.reset(seed=1)
    np.testing.assert_array_equal(o1, o2)
    a = np.full(new.action_space.shape, 0.01, dtype=np.float32)
    for _ in range(20):
        s1, s2 = new.step(a), old.step(a)
        for x, y in zip(s1[:4], s2[:4], strict=True):
            np.testing.assert_array_equal(x, y)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"plant": "hsm2"}, "plant: contour_env/FiveAxis-v0 drives the five-axis machine only"),
        ({"case": "hsm2-circle-II"}, "case: contour_env/FiveAxis-v0 has the five-axis cases"),
    ],
)
def test_a_feed_drive_plant_or_case_is_refused_naming_the_allowed_ones(kwargs, match):
    with pytest.raises(ValueError, match=match):
        gym.make(FIVE_AXIS_ENV_ID, **kwargs)
    with pytest.raises(ValueError, match=match):
        gym.make_vec(
            FIVE_AXIS_ENV_ID, num_envs=2, vectorization_mode="vector_entry_point", **kwargs
        )
