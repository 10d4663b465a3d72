"""The five-axis machine in the env (issue 16, items 2–5): checkers, vector = single envs,
info keys, bad input, a five-axis G-code program, and what scores best."""

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import contour_env  # noqa: F401
from agents.registry import make_controller
from contour_env import ENV_ID
from contour_env.env import ContouringEnv, ContouringVectorEnv
from contour_env.env.five_axis_core import FiveAxisCore
from contour_env.paths import circle
from contour_env.plants.five_axis import forward
from contour_env.tool_errors import tool_errors_from_samples

CASES = ("five-axis-line", "five-axis-circle")
PROGRAM = """(five-axis test: X Y Z in mm, A C in degrees)
G21 G90
G01 X0 Y0 Z0 A0 C0 F600
X10 Y5 Z2 A-5 C10
X20 Y-5 A-15 C40
G00 X0 Y0 Z10 A0 C0
M30
"""


def _run(env, policy=None, n=None):
    obs, info = env.reset(seed=0)
    total = 0.0
    steps = 0
    while n is None or steps < n:
        a = np.zeros(5, np.float32) if policy is None else policy.predict(obs)[0]
        obs, r, term, trunc, info = env.step(a)
        total += r
        steps += 1
        if term or trunc:
            break
    return total, info


@pytest.mark.parametrize("case", CASES)
def test_env_checkers_clean(case):
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(ContouringEnv(case=case), skip_render_check=True)
        sb3_check_env(ContouringEnv(case=case), warn=True)
    assert [str(w.message) for w in caught] == []


@pytest.mark.parametrize("case", CASES)
def test_make_core_dispatches_and_info_keys(case):
    env = gym.make(ENV_ID, case=case)
    assert isinstance(env.unwrapped.core, FiveAxisCore)
    assert env.action_space.shape == (5,)
    obs, info = env.reset(seed=0)
    assert obs.shape == (22,) and env.observation_space.contains(obs)
    obs, reward, term, trunc, info = env.step(np.zeros(5, np.float32))
    keys = {
        "time", "step", "position", "measured_position", "velocity", "reference",
        "tracking_error", "force", "saturated", "termination_reason", "contour_error",
        "orientation_error", "tool_tip", "tool_vector", "reference_tool_tip",
    }  # fmt: skip
    assert keys <= set(info)
    assert info["position"].shape == (5,) and info["tool_tip"].shape == (3,)
    tip, tool = forward(info["position"], env.unwrapped.setup.plant.geometry)
    np.testing.assert_allclose(info["tool_tip"], tip, atol=1e-15)
    np.testing.assert_allclose(info["tool_vector"], tool, atol=1e-15)
    assert abs(np.linalg.norm(info["tool_vector"]) - 1) < 1e-12
    assert info["contour_error"] >= 0 and info["orientation_error"] >= 0
    assert info["step"] == 1 and info["termination_reason"] is None


def test_contour_error_is_the_tip_distance_to_the_path():
    env = gym.make(ENV_ID, case="five-axis-circle", ideal=True)
    pd = make_controller("pd", plant_family="five-axis").bind(env)
    _, info = _run(env, pd, n=800)
    fpath = env.unwrapped.setup.five_axis_path
    from contour_env.tool_errors import tool_errors

    exact = tool_errors(info["tool_tip"], info["tool_vector"], fpath.tip_path, fpath.tool_at)
    # the env refines the 1 ms polyline's nearest chord on a cubic: the chord alone would
    # be off by its sagitta, (4e-4 m)² / (8 r) = 0.2 µm on the r = 0.1 m circle at 0.4 m/s
    assert abs(info["contour_error"] - exact.contour_error_m[0]) < 1e-9
    assert abs(info["orientation_error"] - exact.orientation_error_rad[0]) < 1e-9


def test_vector_env_equals_single_envs():
    n_envs, n_steps = 3, 60
    venv = ContouringVectorEnv(n_envs, case="five-axis-line")
    obs0, _ = venv.reset(seed=7)
    rng = np.random.default_rng(1)
    actions = rng.uniform(-0.2, 0.2, (n_steps, n_envs, 5)).astype(np.float32)
    out = []
    for a in actions:
        out.append(venv.step(a))
    for b in range(n_envs):
        env = ContouringEnv(case="five-axis-line")
        obs, _ = env.reset(seed=7 + b)
        assert np.array_equal(obs, obs0[b])
        for i, a in enumerate(actions):
            obs, r, term, trunc, info = env.step(a[b])
            v_obs, v_r, v_term, v_trunc, v_info = out[i]
            assert np.array_equal(obs, v_obs[b]) and r == v_r[b]
            assert term == v_term[b] and trunc == v_trunc[b]
            for key, value in info.items():
                if key == "termination_reason":
                    assert (value or "") == v_info[key][b]
                else:
                    assert np.array_equal(np.asarray(value), np.asarray(v_info[key][b])), key
            if term or trunc:
                break


def test_standing_still_scores_far_worse_than_pd():
    for case in CASES:
        env = gym.make(ENV_ID, case=case)
        still, info = _run(env)
        assert info["termination_reason"] in ("tracking_error_limit", "contour_error_limit")
        pd_return, pd_info = _run(env, make_controller("pd", plant_family="five-axis").bind(env))
        assert pd_info["termination_reason"] is None  # PD runs the whole path
        assert still < 10 * pd_return < 0, (case, still, pd_return)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(case="five-axis-line", plant="hsm2"), "five-axis case.*not 'hsm2'"),
        (dict(case="hsm2-circle-II", plant="five-axis"), "2/3-axis.*five-axis"),
        (dict(plant="five-axis", path=circle((0, 0), 0.01)), "PathGeometry"),
        (dict(plant="five-axis", path="G21\nG01 X1 Y1 F100\n"), "no A or C word"),
        (dict(plant="hsm2", path="G21\nG01 X1 A10 F100\n"), r"'A10'.*plant 'hsm2'.*five-axis"),
        (dict(plant="five-axis", path="G21\nG01 X1 A40 F100\n"), "line 2.*travel.*40 deg"),
        (dict(plant="five-axis", path="G21\nG02 X1 Y1 I1 A-5 F100\n"), "arc 'G02'"),
        (dict(case="five-axis-line", measurement_noise_std_m=1e-8), "noise.*five-axis"),
        (dict(case="five-axis-line", feedrate_m_s=0.1), "feed override"),
    ],
)
def test_bad_inputs(kwargs, match):
    with pytest.raises(ValueError, match=match):
        gym.make(ENV_ID, **kwargs)


def test_bad_actions():
    env = gym.make(ENV_ID, case="five-axis-line")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="must be finite"):
        env.step(np.array([0, 0, np.nan, 0, 0], np.float32))
    with pytest.raises(ValueError, match="shape"):
        env.step(np.zeros(3, np.float32))


def test_ismc_refuses_a_three_axis_env_and_a_gcode_path():
    with pytest.raises(ValueError, match="five-axis plant"):
        make_controller("ismc").bind(gym.make(ENV_ID, case="hsm2-circle-II"))
    env = gym.make(ENV_ID, plant="five-axis", path=PROGRAM)
    with pytest.raises(ValueError, match="only as G-code"):
        make_controller("ismc", plant_family="five-axis").bind(env)


def test_five_axis_gcode_program_runs():
    env = gym.make(ENV_ID, plant="five-axis", path=PROGRAM)
    setup = env.unwrapped.setup
    ref = setup.reference
    # joint-space linear blocks through the programmed joints (A and C in degrees)
    ends = np.array(
        [[0.01, 0.005, 0.002, -5, 10], [0.02, -0.005, 0.002, -15, 40], [0, 0, 0.01, 0, 0]]
    )
    ends[:, 3:] = np.radians(ends[:, 3:])
    for end in ends:
        # an exact stop at each block end (between two samples: within 0.1 µm, µrad)
        assert np.min(np.max(np.abs(ref.joints - end), axis=1)) < 1e-7
    np.testing.assert_allclose(ref.joints[-1], ends[-1], atol=1e-12)
    # mid-block samples lie on the joint-space line of their block
    # (joint-space length: degrees count as mm, √(10² + 5² + 2² + 5² + 10²) mm)
    first_len = np.sqrt(10**2 + 5**2 + 2**2 + 5**2 + 10**2) * 1e-3
    first = ref.joints[(ref.arc_length_m > 0) & (ref.arc_length_m < first_len)]
    direction = ends[0] / np.linalg.norm(ends[0])
    off_line = first - (first @ direction)[:, None] * direction
    assert np.max(np.abs(off_line)) < 1e-12
    pd = make_controller("pd", plant_family="five-axis").bind(env)
    obs, _ = env.reset(seed=0)
    eps, tips, tools = [], [], []
    while True:
        obs, _, term, trunc, info = env.step(pd.predict(obs)[0])
        eps.append(info["contour_error"])
        tips.append(info["tool_tip"])
        tools.append(info["tool_vector"])
        if term or trunc:
            break
    assert info["termination_reason"] is None and info["step"] == ref.n_steps - 1
    # ε is the distance to the whole tip path, also where the path folds back (the G00)
    exact = tool_errors_from_samples(np.array(tips), np.array(tools), ref.tip_m, ref.tool)
    np.testing.assert_allclose(eps, exact.contour_error_m, rtol=0, atol=1e-9)
    assert max(eps) < 1e-3
    assert "five-axis blocks" in setup.program_summary


def test_five_axis_plant_alias_and_travel():
    env = gym.make(ENV_ID, plant="nxv560a", path=PROGRAM)
    assert env.unwrapped.setup.plant.name == "five-axis"
