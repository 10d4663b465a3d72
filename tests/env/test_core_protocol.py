"""Both simulation cores implement the one Core protocol, with the same signatures."""

from __future__ import annotations

import inspect

import gymnasium as gym
import numpy as np
import pytest

import contour_env
from contour_env import ENV_ID
from contour_env.env.core import EnvCore
from contour_env.env.five_axis_core import FiveAxisCore
from contour_env.env.protocol import CORE_ATTRIBUTES, CORE_METHODS, Core


@pytest.fixture(scope="module")
def cores():
    feed = gym.make(ENV_ID, case="hsm2-circle-II").unwrapped.core
    five = gym.make(contour_env.FIVE_AXIS_ENV_ID).unwrapped.core
    return {"feed-drive": feed, "five-axis": five}


def test_both_cores_are_cores(cores):
    assert isinstance(cores["feed-drive"], EnvCore)
    assert isinstance(cores["five-axis"], FiveAxisCore)
    for name, core in cores.items():
        assert isinstance(core, Core), name
        for attr in CORE_ATTRIBUTES:
            assert hasattr(core, attr), (name, attr)
        B = core.n_envs
        assert core.obs.shape == (B, core.obs_dim) and core.obs.dtype == np.float32
        assert core.force_limit.shape == (core.dim,)
        assert core.ref_pav.shape[:2] == (core.n_steps, 3)


@pytest.mark.parametrize("method", CORE_METHODS)
def test_the_methods_have_the_protocols_signature(method):
    want = inspect.signature(getattr(Core, method))
    for cls in (EnvCore, FiveAxisCore):
        got = inspect.signature(getattr(cls, method))
        assert list(got.parameters) == list(want.parameters), (cls.__name__, method)
        for p, q in zip(got.parameters.values(), want.parameters.values(), strict=True):
            assert p.default == q.default, (cls.__name__, method, p.name)


def test_something_else_is_not_a_core():
    assert not isinstance(object(), Core)
    assert not isinstance(gym.make("CartPole-v1"), Core)


def test_one_step_through_the_protocol(cores):
    # the same calls drive both: reset, a zero step, the info and the signals
    for name, core in cores.items():
        core.reset_envs(np.arange(core.n_envs), [0] * core.n_envs)
        action = np.zeros((core.n_envs, core.dim))
        ended = core.step(action, core.all_active)
        assert ended == 0, name
        assert np.all(core.k == 1), name
        info = core.info(0)
        assert np.isfinite(info["contour_error"]), name
        sig = core.signals_batch()
        assert sig["measured_position"].shape == (core.n_envs, core.dim), name
        bad = action.copy()
        bad[0, 0] = np.nan
        with pytest.raises(ValueError, match="action: must be finite"):
            core.refuse_nonfinite(bad, core.all_active)
