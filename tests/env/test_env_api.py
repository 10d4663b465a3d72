"""The Gymnasium env: registration, checkers, info keys, determinism, termination, rendering."""

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import contour_env  # noqa: F401
from contour_env import ENV_ID
from contour_env.cases import case_names

INFO_KEYS = {
    "time",
    "position",
    "measured_position",
    "velocity",
    "reference",
    "contour_error",
    "contour_error_estimate",
    "tracking_error",
    "force",
    "saturated",
    "termination_reason",
}


@pytest.mark.parametrize("case", case_names())
def test_gymnasium_and_sb3_checkers_pass_for_every_case(case):
    env = gym.make(ENV_ID, case=case, disable_env_checker=True)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        gym_check_env(env.unwrapped, skip_render_check=True)
    sb3_check_env(gym.make(ENV_ID, case=case).unwrapped, warn=True)


def test_info_has_every_documented_key_in_physical_units():
    env = gym.make(ENV_ID, case="hsm2-circle-II")
    obs, info = env.reset(seed=0)
    assert INFO_KEYS <= set(info)
    obs, r, term, trunc, info = env.step(np.array([0.01, -0.01], dtype=np.float32))
    assert INFO_KEYS <= set(info)
    assert info["time"] == pytest.approx(1e-3)
    assert info["position"].shape == (2,)
    np.testing.assert_allclose(info["tracking_error"], info["reference"] - info["position"])
    # hsm2 encoders: 2 µm (x) and 1 µm (y) -> the measured position is on that grid
    res = np.array([2e-6, 1e-6])
    np.testing.assert_allclose(
        np.round(info["measured_position"] / res) * res, info["measured_position"], atol=1e-15
    )
    assert info["contour_error"] >= 0.0
    assert info["termination_reason"] is None


def test_step_info_equals_a_readout_of_the_state_every_step():
    # the kernel fills the step's info while it steps; it must equal core.info, a readout of
    # the state after the step, key by key and in type, up to the crash-guard termination
    env = gym.make(ENV_ID, case="hsm2-circle-I", abort_contour_error_m=1e-4)
    env.reset(seed=1)
    core = env.unwrapped.core
    for _ in range(400):
        *_, term, trunc, info = env.step(np.array([1.0, -0.5], dtype=np.float32))
        expected = core.info(0)
        assert set(info) == set(expected)
        for key, value in expected.items():
            assert type(info[key]) is type(value), key
            np.testing.assert_array_equal(info[key], value, err_msg=key)
        if term:
            break
    assert term and info["termination_reason"] == "contour_error_limit"


def _rollout(env, seed, n=300):
    rng = np.random.default_rng(123)
    obs, _ = env.reset(seed=seed)
    out = [obs]
    for _ in range(n):
        obs, r, term, trunc, info = env.step(rng.uniform(-0.05, 0.05, env.action_space.shape))
        out.append(np.concatenate([obs, [r, info["contour_error"]], info["position"]]))
        if term or trunc:
            break
    return out


def test_same_seed_gives_bit_identical_episode_with_noise_and_disturbance():
    kw = dict(case="sharp-corner", measurement_noise_std_m=2e-6, disturbance_force_N=5.0)
    a = _rollout(gym.make(ENV_ID, **kw), seed=7)
    b = _rollout(gym.make(ENV_ID, **kw), seed=7)
    c = _rollout(gym.make(ENV_ID, **kw), seed=8)
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    assert not all(np.array_equal(x, y) for x, y in zip(a, c, strict=False))


def test_named_cases_are_noise_free_by_default():
    a = _rollout(gym.make(ENV_ID, case="sharp-corner"), seed=1)
    b = _rollout(gym.make(ENV_ID, case="sharp-corner"), seed=2)
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))


def test_crash_guard_terminates_with_reason():
    env = gym.make(ENV_ID, case="hsm2-circle-I", abort_contour_error_m=1e-4)
    env.reset(seed=0)
    for _ in range(2000):
        _, _, term, trunc, info = env.step(np.array([1.0, 1.0], dtype=np.float32))
        if term or trunc:
            break
    assert term and not trunc
    assert info["termination_reason"] == "contour_error_limit"
    assert info["contour_error"] > 1e-4


def test_truncates_when_path_and_settle_time_are_done():
    # a tracking guard beyond the circle's 0.12 m diameter lets the zero command run to the end
    env = gym.make(ENV_ID, case="hsm2-circle-III", abort_tracking_error_m=0.5)
    env.reset(seed=0)
    core = env.unwrapped.core
    steps = 0
    while True:
        _, _, term, trunc, info = env.step(np.zeros(2, dtype=np.float32))
        steps += 1
        if term or trunc:
            break
    assert trunc and not term
    assert steps == core.n_steps - 1
    # the reference ends at rest on the end point after the settle time
    assert info["time"] == pytest.approx(core.setup.reference.time[-1])


def test_reward_follows_the_documented_formula():
    env = gym.make(
        ENV_ID,
        case="hsm2-circle-II",
        w_contour=2.0,
        w_lag=0.5,
        w_effort=0.1,
        contour_error_scale_m=1e-5,
    )
    env.reset(seed=0)
    a = np.array([0.3, -0.2], dtype=np.float32)
    for _ in range(50):
        _, r, _, _, info = env.step(a)
    eps = info["contour_error"]
    e_t = info["contour_error_estimate"][0]
    expected = -(2.0 * eps + 0.5 * abs(e_t)) / 1e-5 - 0.1 * float(np.sum(a.astype(float) ** 2)) / 2
    assert r == pytest.approx(expected, rel=1e-9)


def test_render_rgb_array_returns_an_image():
    env = gym.make(ENV_ID, case="hsm2-circle-III", render_mode="rgb_array")
    env.reset(seed=0)
    for _ in range(100):
        env.step(np.array([0.02, 0.02], dtype=np.float32))
    img = env.render()
    assert img.dtype == np.uint8 and img.ndim == 3 and img.shape[2] == 3
    assert img.shape[0] > 100 and img.shape[1] > 100
    assert img.std() > 0  # not a blank canvas


def test_signals_expose_what_a_servo_measures():
    env = gym.make(ENV_ID, case="jee-circle3d")
    env.reset(seed=0)
    env.step(np.zeros(3, dtype=np.float32))
    s = env.unwrapped.signals()
    assert s["frame"].shape == (3, 3)
    np.testing.assert_allclose(s["frame"].T @ s["frame"], np.eye(3), atol=1e-12)
    assert s["servo_period_s"] == pytest.approx(1e-3)
    assert s["measured_position"].shape == (3,)


def test_encoder_reads_the_drive_side_with_the_structural_mode():
    """With the two-mass mode the encoder reads the drive (motor) side, state index 2
    (semi-closed loop), and the contour error is the load's (index 0)."""
    from contour_env.plants import quantize

    env = gym.make("contour_env/Contouring-v0", case="hsm2-circle-I", structural_mode=True)
    env.reset(seed=0)
    core = env.unwrapped.core
    res = core.setup.plant.params.encoder_resolution_m
    differs = False
    for _ in range(300):
        _, _, terminated, truncated, info = env.step(np.full(2, 0.05, dtype=np.float32))
        drive, load = core.z[0, :, 2], core.z[0, :, 0]
        np.testing.assert_array_equal(info["measured_position"], quantize(drive, res))
        np.testing.assert_array_equal(info["position"], load)
        differs |= bool(np.any(quantize(drive, res) != quantize(load, res)))
        if terminated or truncated:  # a step after the end raises (issue 36 item 11)
            break
    assert differs
