"""``controller_gains`` in a plant file or mapping (:mod:`contour_env.plants.gains`): validated
with one-line errors naming the controller or gain, kept through ``to_dict``, and loaded from a
file."""

from __future__ import annotations

import json

import pytest

from contour_env.plants import Plant, params_from_mapping
from contour_env.plants.gains import TUNABLE_GAINS, tuned_gain

BASE = {"mass": [300.0, 200.0], "force_limit": 3000.0, "servo_period": 0.001}


def test_gains_kept_and_read():
    gains = {"pd": {"bandwidth_rad_s": 80}, "ccc": {"W_p": 3e3, "W_i": 3e5, "W_d": 0}}
    p = params_from_mapping({**BASE, "controller_gains": gains})
    assert p.controller_gains == {
        "pd": {"bandwidth_rad_s": 80.0},
        "ccc": {"W_p": 3e3, "W_i": 3e5, "W_d": 0.0},
    }
    assert tuned_gain(p, "pd", "bandwidth_rad_s") == 80.0
    assert tuned_gain(p, "ccc", "W_d") == 0.0
    again = params_from_mapping({**p.to_dict()})  # the full field names round-trip
    assert again.controller_gains == p.controller_gains
    assert params_from_mapping(BASE).controller_gains == {}
    assert tuned_gain(params_from_mapping(BASE), "pd", "bandwidth_rad_s") is None
    assert tuned_gain(Plant("hsm2").nominal, "pd", "bandwidth_rad_s") is None  # named: built in


def test_gains_from_a_plant_file(tmp_path):
    path = tmp_path / "p.json"
    path.write_text(json.dumps({**BASE, "controller_gains": {"pd": {"bandwidth_rad_s": 60}}}))
    plant = Plant(str(path))
    assert plant.nominal.controller_gains == {"pd": {"bandwidth_rad_s": 60.0}}


@pytest.mark.parametrize(
    ("gains", "message"),
    [
        ([80], "plant: controller_gains: must be a JSON object \\(or null\\), got \\[80\\]"),
        ({"pid": {}}, "controller_gains: unknown controller 'pid'; allowed: pd, ccc"),
        ({"pd": 80}, r"controller_gains.pd: a mapping of gain → value \(bandwidth_rad_s\), got"),
        ({"pd": {"w": 80}}, "controller_gains.pd: unknown gain 'w'; allowed: bandwidth_rad_s"),
        ({"pd": {"bandwidth_rad_s": 0}}, "controller_gains.pd.bandwidth_rad_s: .* > 0, got 0"),
        ({"ccc": {"W_i": -1}}, r"controller_gains.ccc.W_i: .* >= 0, got -1"),
        ({"ccc": {"W_p": float("inf")}}, "controller_gains.ccc.W_p: must be a finite number"),
        ({"ccc": {"W_p": "3e3"}}, "controller_gains.ccc.W_p: must be a finite number"),
        ({"ccc": {"W_p": True}}, "controller_gains.ccc.W_p: must be a finite number"),
    ],
)
def test_bad_gains_one_line_error(gains, message):
    with pytest.raises(ValueError, match=message) as info:
        params_from_mapping({**BASE, "controller_gains": gains})
    assert "\n" not in str(info.value)


def test_every_tunable_gain_is_a_controller_parameter():
    """The gains a plant may carry are parameters of the controllers that read them."""
    from agents.ccc import CCCController
    from agents.pd import PDController

    names = {
        "pd": {p.keyword for p in PDController.PARAMETERS.values()},
        "ccc": {p.keyword for p in CCCController.PARAMETERS.values()},
    }
    for ctrl, gains in TUNABLE_GAINS.items():
        assert set(gains) <= names[ctrl], ctrl
