"""Plant files users edit by hand (contour_env.plants.from_file, file_schema): checked key by
key on load by every command that takes ``--plant`` and by ``gym.make`` (issue 49, items 1,
13, 14)."""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from contour_env import ENV_ID
from contour_env.app.cli import main
from contour_env.env.contouring_env import ContouringEnv
from contour_env.plants import Plant
from contour_env.plants.file_schema import FIELD_ALIASES, PLANT_KEYS

SQUARE = "G21 G90 G17 G61\nG01 X5 F600\nG01 Y5\nG01 X0\n"
WORKSPACE = {"travel": [0.04, 0.04], "feed_range": [0.008, 0.08], "max_acceleration": 1.0}


def plant_file(tmp_path: Path, file="plant.json", **change) -> Path:
    """The friction table's true parameters as a plant file (the plain names)."""
    params = Plant("friction-table").params.to_dict()
    data = {
        FIELD_ALIASES.get(k, "axes" if k == "axis_names" else k): v
        for k, v in params.items()
        if v is not None and k != "controller_gains"
    }
    data.update(change)
    path = tmp_path / file
    path.write_text(json.dumps(data))
    return path


NULL_LIMIT = "force_limit: must be a number in [1e-06, 1e+07] N, or one per axis, got null"


def test_a_cleared_force_limit_is_one_line_on_every_command_and_in_gym_make(tmp_path, capsys):
    # item 1: KeyError: 'force_limit_N' from plants/params.py on each of these
    path = plant_file(tmp_path, force_limit=None)
    gcode = tmp_path / "square.nc"
    gcode.write_text(SQUARE)
    for argv in (
        ["margins", "--plant", str(path), "--controller", "pd"],
        ["run", "--plant", str(path), "--gcode", str(gcode)],
        ["excite", "--plant", str(path), "--out", str(tmp_path / "x.csv")],
    ):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip()
        assert err == f"error: {path}: {NULL_LIMIT}", argv
    with pytest.raises(ValueError) as info:
        gym.make(ENV_ID, plant=str(path), path=SQUARE)
    assert str(info.value) == f"{path}: {NULL_LIMIT}"


@pytest.mark.parametrize(
    "change, message",
    [
        ({"mass": "heavy"}, 'mass: must be a number in [1e-06, 1e+06] kg, or one per axis, got '
         '"heavy"'),
        ({"servo_period": [0.001, 0.001]}, "servo_period: must be a number in [1e-06, 0.1] s, "
         "got [0.001, 0.001]"),
        ({"travel": 0.0}, "travel: must be a number in (0, 10] m, or one per axis (or null), "
         "got 0.0"),
        ({"feed_range": [0.01, "fast"]}, 'feed_range: must be a list of numbers in (0, 10] m/s '
         '(or null), got [0.01, "fast"]'),
        ({"mass_kg": 2.0}, "'mass' given twice (as 'mass' and 'mass_kg')"),
    ],
)  # fmt: skip
def test_each_key_is_checked_naming_the_file_and_key(tmp_path, change, message):
    path = plant_file(tmp_path, **change)
    with pytest.raises(ValueError) as info:
        Plant(str(path))
    assert str(info.value) == f"{path}: {message}"


def test_a_file_that_is_not_an_object_or_not_json_is_named(tmp_path):
    path = tmp_path / "p.json"
    path.write_text("[1, 2, 3]")
    with pytest.raises(ValueError, match=r"p.json must hold a JSON object .*got a list"):
        Plant(str(path))
    path.write_text('{"mass": 1,}')
    with pytest.raises(ValueError, match=r"p.json: not valid JSON \(Expecting property name"):
        Plant(str(path))


def test_an_identified_servo_period_is_the_cases_and_a_real_difference_is_shown_in_full():
    # item 13: "servo period 0.001 s ... got ... servo period 0.001 s" for 0.001000000000000112
    base = ContouringEnv(case="sharp-corner").plant.params
    identified = base.replace(servo_period_s=0.001000000000000112)
    env = ContouringEnv(case="sharp-corner", plant_params=[identified])
    env.reset(seed=0)
    assert np.isfinite(env.step(np.zeros(2))[1])
    with pytest.raises(ValueError, match=r"servo period 0.001 s .* servo period 0.0010001 s"):
        ContouringEnv(case="sharp-corner", plant_params=[base.replace(servo_period_s=0.0010001)])


def test_train_on_a_plant_file_without_its_parts_ranges_names_the_keys(tmp_path, capsys):
    path = plant_file(tmp_path)
    assert main(["train", "--plant", str(path), "--out", str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"error: {path}: training on a plant file needs travel, feed_range, "
                          "max_acceleration")  # fmt: skip
    assert "contour-env identify writes them" in err and "\n" not in err


def test_train_on_a_plant_file_draws_parts_within_it_and_writes_a_model_folder(tmp_path):
    # item 14: "no training path families"; --plant alone trains on the file's families
    from agents.residual import ResidualAgent
    from agents.rl.families import generate_path, plant_ranges

    path = plant_file(tmp_path, file="machine.json", name="my-table", **WORKSPACE)
    r = plant_ranges(str(path))
    assert r.feed_m_s == (0.008, 0.08) and r.travel_m == 0.04 and r.max_accel_m_s2 == 1.0
    part = generate_path("arcs", str(path), 7)
    assert 0.008 <= part.feedrate_m_s <= 0.08 and part.plant == str(path)
    out = tmp_path / "run"
    rc = main(
        ["train", "--plant", str(path), "--out", str(out), "--timesteps", "60",
         "--net-arch", "8", "--no-progress", "--validation-paths", "1", "--teacher-parts", "2",
         "--teacher-trials", "2"]
    )  # fmt: skip
    assert rc == 0
    meta = json.loads((out / "agent.json").read_text())
    assert (meta["plant"], meta["plant_file"]) == ("my-table", "machine.json")
    agent = ResidualAgent(out)
    env = gym.make(ENV_ID, plant=str(path), path=SQUARE, feedrate_m_s=0.02)
    agent.bind(env)  # the file's plant is the agent's


def test_every_key_of_the_docs_table_is_a_key_a_plant_file_may_hold():
    from contour_env.plants.params import MAPPING_KEYS, WORKSPACE_FIELDS

    names = [k.name for k in PLANT_KEYS]
    assert len(names) == len(set(names))
    assert set(MAPPING_KEYS) | set(WORKSPACE_FIELDS) <= set(names)
