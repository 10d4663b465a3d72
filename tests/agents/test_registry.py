"""Controller variants ``name:key=value:...``: parsing, binding, clear errors."""

import gymnasium as gym
import numpy as np
import pytest

import contour_env  # noqa: F401  (registers the env)
from agents.compare import bound_controller, check_controllers
from agents.registry import (
    CONTROLLERS,
    controller_parameters,
    format_controllers,
    make_controller,
    parse_controller_spec,
)
from contour_env import ENV_ID

CASE = "hsm2-circle-I"


@pytest.fixture(scope="module")
def env():
    e = gym.make(ENV_ID, case=CASE)
    e.reset(seed=0)
    return e


def test_ccc_spec_sets_both_coupling_gains(env):
    c = make_controller("ccc:wp=3e4:wd=20").bind(env)
    assert c.W_p == 3e4 and c.W_d == 20.0
    # the keyword form is the same controller
    k = make_controller("ccc", W_p=3e4, W_d=20).bind(env)
    assert (k.W_p, k.W_d) == (c.W_p, c.W_d)
    np.testing.assert_array_equal(k.P, c.P)


def test_pd_bandwidth_spec_places_the_poles(env):
    c = make_controller("pd:w=80").bind(env)
    m = c.nominal.mass_kg
    np.testing.assert_allclose(c.P, m * 80.0**2)
    assert c.omega == 80.0


def test_per_axis_values_and_other_controllers(env):
    c = make_controller("pd:p=2e6/1e6:d=3e4").bind(env)
    np.testing.assert_array_equal(c.P, [2e6, 1e6])
    np.testing.assert_array_equal(c.D, [3e4, 3e4])
    assert parse_controller_spec("jee-ccc:kp=8:cp=2")[1] == {"K_P": 8.0, "C_P": 2.0}
    v = make_controller("vilcfd:dob=0:friction=false:lead=2:gn=0.9")
    assert v.dob_bandwidth_arg == 0.0 and v.friction_compensation is False
    assert v.lead_steps_arg == 2 and v.normal_gain_max == 0.9
    i = make_controller("ilc-pd:gain=0.8:q=40:w=100")
    assert i.learning_gain == 0.8 and i.q_cutoff_arg == 40.0
    assert i.feedback.bandwidth_rad_s == 100.0


def test_adaptive_gamma_zero_switches_adaptation_off(env):
    c = make_controller("adaptive-ccc:gamma=0").bind(env)
    assert c.gamma == (0.0, 0.0)
    np.testing.assert_array_equal(c.Gamma, 0.0)
    # one gain alone keeps the plant's default for the other
    default = make_controller("adaptive-ccc").bind(env)
    only_m = make_controller("adaptive-ccc:gamma_m=0").bind(env)
    assert only_m.gamma == (0.0, default.gamma[1])


def test_every_controller_has_a_parameter_table_with_units():
    for name in CONTROLLERS:
        table = controller_parameters(name)
        assert table, name
        for key, p in table.items():
            assert key == key.lower() and p.description
    # subclasses extend their parent's table
    assert set(controller_parameters("pd")) < set(controller_parameters("ccc"))
    text = format_controllers()
    for name in CONTROLLERS:
        assert f"\n{name}" in text
    assert "wp" in text and "1/s²" in text


def test_unknown_parameter_lists_the_controllers_parameters():
    with pytest.raises(ValueError, match="unknown parameter 'wx' of 'ccc'") as info:
        make_controller("ccc:wx=1")
    msg = str(info.value)
    for key in ("wp", "wd", "w", "zeta", "p", "d"):
        assert f"\n  {key} " in msg
    assert "cross-coupling proportional gain" in msg


@pytest.mark.parametrize(
    "spec, words",
    [
        ("ccc:", "empty parameter"),
        ("ccc:wp", "'wp' is not key=value"),
        ("ccc:wp=", "'wp' has no value"),
        ("ccc:wp=abc", "wp must be a number >= 0, got 'abc'"),
        ("ccc:wp=nan", "wp must be a number >= 0, got 'nan'"),
        ("ccc:wp=inf", "wp must be a number >= 0"),
        ("ccc:wp=1:wp=2", "'wp' given twice"),
        ("pd:w=-3", "w must be a number > 0"),
        ("pd:p=1/abc", "one per axis"),
        ("ilc-pd:lead=1.5", "lead must be an integer >= 0"),
        ("vilcfd:friction=maybe", "friction must be true or false"),
        ("adaptive-ccc:gamma=1:gamma_m=2", "not both"),
        ("ilc-pd:gain=3", "learning_gain"),
        (":wp=1", "no controller name"),
    ],
)
def test_malformed_specs_are_clear_errors(spec, words):
    with pytest.raises(ValueError, match="controller") as info:
        make_controller(spec)
    assert words in str(info.value)


def test_unknown_controller_keeps_the_list_of_known_names():
    with pytest.raises(ValueError, match=r"unknown controller 'nope'; known: pd, ccc"):
        make_controller("nope:w=1")
    with pytest.raises(ValueError, match=r"known: .*residual"):
        check_controllers(["pd", "nope"])


def test_residual_takes_no_parameters(env):
    with pytest.raises(ValueError, match="residual takes no parameters"):
        check_controllers(["residual:x=1"])
    with pytest.raises(ValueError, match="residual takes no parameters"):
        bound_controller("residual:x=1", env)


def test_bound_controller_accepts_a_spec(env):
    c = bound_controller("ccc:wp=4e4", env)
    assert c.W_p == 4e4


def test_a_keyword_given_twice_is_an_error():
    with pytest.raises(ValueError, match="W_p given both"):
        make_controller("ccc:wp=3e4", W_p=1e4)
