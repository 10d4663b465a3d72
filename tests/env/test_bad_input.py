"""Bad input gets a clear error naming the parameter and the allowed values."""

import gymnasium as gym
import numpy as np
import pytest

import contour_env  # noqa: F401
from contour_env import ENV_ID
from contour_env.paths import circle


def test_unknown_case_lists_known_cases():
    with pytest.raises(ValueError, match=r"unknown case 'nope'.*hsm2-circle-I"):
        gym.make(ENV_ID, case="nope")


def test_unknown_plant_lists_known_plants():
    with pytest.raises(ValueError, match=r"unknown plant 'nope'.*hsm2.*linear-motor"):
        gym.make(ENV_ID, plant="nope", path=circle((0, 0), 0.05), feedrate_m_s=0.1)


@pytest.mark.parametrize("value", [0.0, -0.1, float("nan")])
def test_non_positive_feedrate(value):
    with pytest.raises(ValueError, match="feedrate"):
        gym.make(ENV_ID, case="hsm2-circle-I", feedrate_m_s=value)


@pytest.mark.parametrize("radius", [0.0, -0.01])
def test_non_positive_radius(radius):
    with pytest.raises(ValueError, match="radius"):
        circle((0, 0), radius)


def test_non_positive_mass_and_servo_period_in_custom_plant():
    base = dict(mass=[10.0, 10.0], force_limit=100.0, servo_period=1e-3)
    path = circle((0, 0), 0.01)
    with pytest.raises(ValueError, match="mass"):
        gym.make(ENV_ID, plant={**base, "mass": [0.0, 10.0]}, path=path, feedrate_m_s=0.01)
    with pytest.raises(ValueError, match="servo_period"):
        gym.make(ENV_ID, plant={**base, "servo_period": 0.0}, path=path, feedrate_m_s=0.01)


def test_custom_plant_runs():
    plant = dict(mass=[10.0, 12.0], viscous=5.0, force_limit=100.0, servo_period=1e-3)
    env = gym.make(ENV_ID, plant=plant, path=circle((0, 0), 0.01), feedrate_m_s=0.01)
    env.reset(seed=0)
    _, _, term, trunc, info = env.step(np.zeros(2, dtype=np.float32))
    assert not term


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_action_is_a_clear_error(bad):
    env = gym.make(ENV_ID, case="hsm2-circle-I")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action: must be finite"):
        env.step(np.array([bad, 0.0]))


def test_wrong_action_shape():
    env = gym.make(ENV_ID, case="hsm2-circle-I", disable_env_checker=True)
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"action: expected shape \(2,\)"):
        env.step(np.zeros(3))


def test_three_d_path_on_two_axis_plant():
    path = circle((0, 0, 0), 0.05, normal=(1.0, 0.0, 1.0))
    with pytest.raises(ValueError, match="3-D path"):
        gym.make(ENV_ID, plant="hsm2", path=path, feedrate_m_s=0.1)


@pytest.mark.parametrize(
    "kw, name",
    [
        ({"abort_contour_error_m": 0.0}, "abort_contour_error_m"),
        ({"w_contour": -1.0}, "w_contour"),
        ({"preview_times_s": ()}, "preview_times_s"),
        ({"measurement_noise_std_m": float("nan")}, "measurement_noise_std_m"),
    ],
)
def test_bad_env_arguments_name_the_parameter(kw, name):
    with pytest.raises(ValueError, match=name):
        gym.make(ENV_ID, case="hsm2-circle-I", **kw)


def test_malformed_gcode_names_line_and_word():
    # M03 (spindle on) is a setup word the reader accepts and reports; M98 (a subprogram
    # call) would change the geometry and is refused, naming its line and word
    with pytest.raises(ValueError, match=r"line 2.*M98"):
        gym.make(ENV_ID, plant="hsm2", path="G21 G90 G17 F600\nM98 P100\nG01 X10 Y0\n")
    env = gym.make(ENV_ID, plant="hsm2", path="G21 G90 G17 F600\nM03\nG01 X10 Y0\n")
    assert "M03" in env.unwrapped.setup.program_summary


def test_gcode_text_and_file(tmp_path):
    text = "G21 G90 G17\nG01 X10 Y0 F600\nG01 X10 Y10\nG02 X0 Y10 I-5 J0\n"
    env = gym.make(ENV_ID, plant="friction-table", path=text)
    env.reset(seed=0)
    _, _, _, _, info = env.step(np.zeros(2, dtype=np.float32))
    assert info["reference"].shape == (2,)
    f = tmp_path / "part.nc"
    f.write_text(text)
    env2 = gym.make(ENV_ID, plant="friction-table", path=str(f))
    assert env2.unwrapped.core.n_steps == env.unwrapped.core.n_steps
    # the path is in metres: 10 mm leg
    assert env.unwrapped.setup.path.total_length == pytest.approx(0.02 + np.pi * 0.005, rel=1e-9)


def test_disturbance_phase_option():
    import gymnasium as gym

    with pytest.raises(ValueError, match="disturbance_phase: must be one of"):
        gym.make("contour_env/Contouring-v0", case="sharp-corner", disturbance_phase="late")

    def run(seed, phase):
        env = gym.make("contour_env/Contouring-v0", case="sharp-corner", disturbance_phase=phase)
        env.reset(seed=seed)
        for _ in range(300):
            _, _, terminated, truncated, info = env.step(np.full(2, 0.05, dtype=np.float32))
            if terminated or truncated:  # a step after the end raises (issue 36 item 11)
                break
        return info["position"]

    # fixed: the seed does not matter (noise-free case); random: it does, and repeats
    np.testing.assert_array_equal(run(0, "fixed"), run(1, "fixed"))
    assert not np.array_equal(run(0, "random"), run(1, "random"))
    np.testing.assert_array_equal(run(1, "random"), run(1, "random"))
