"""agents.model_files: a model folder edited or damaged by hand is refused on load, with one
line that names the file, the key, the value and the allowed values (issue 49, items 2, 4, 5,
6, 11, 12), through ``contour-env evaluate --model`` as a user runs it."""

from __future__ import annotations

import json
import math
import shutil
import zipfile
from pathlib import Path

import pytest

from agents.model_files import AGENT_KEYS, NORMALIZATION_KEYS, read_agent_json
from agents.residual import ResidualAgent
from contour_env.app.cli import main

SHIPPED = Path(__file__).resolve().parents[2] / "agents" / "models" / "friction-table"


def model_copy(tmp_path: Path, change=None, name="m") -> Path:
    d = tmp_path / name
    shutil.copytree(SHIPPED, d)
    if change is not None:
        meta = json.loads((d / "agent.json").read_text())
        meta = change(meta) if callable(change) else {**meta, **change}
        (d / "agent.json").write_text(json.dumps(meta))
    return d


def evaluate_error(d: Path, capsys, case="sharp-corner") -> str:
    assert main(["evaluate", "--model", str(d), "--case", case]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "Traceback" not in err
    return err


@pytest.mark.parametrize(
    "change, message",
    [
        # 2. a JSON value that is not an object
        (lambda m: [1, 2, 3], 'agent.json must hold a JSON object ({"key": value, ...}), got a '
         "list ([1, 2, 3])"),
        # 4. a repeat of 0 hung the evaluation
        ({"action_repeat": 0}, "agent.json: action_repeat: must be an integer in [1, 100000] "
         "servo periods, got 0"),
        # 5. NaN scored every metric n/a
        ({"scale": math.nan}, "agent.json: scale: must be a number in (0, 2] fraction of the "
         "force limit, got NaN"),
        # 6. a negative servo period was accepted silently
        ({"servo_period_s": -1}, "agent.json: servo_period_s: must be a number in [1e-06, 0.1] "
         "s, got -1"),
        # 11. text where a number belongs
        ({"scale": "big"}, 'agent.json: scale: must be a number in (0, 2] fraction of the force '
         'limit, got "big"'),
        # a misspelt key is not silently ignored
        ({"gaet": True}, 'agent.json: unknown key "gaet"; allowed: format, algo, plant'),
        ({"gate": "yes"}, 'agent.json: gate: must be true or false, got "yes"'),
        ({"residual_frame": "tool"}, 'agent.json: residual_frame: must be one of "axes", "path", '
         'got "tool"'),
        (lambda m: {k: v for k, v in m.items() if k != "obs_dim"}, "agent.json: obs_dim: "
         "required (an integer in [1, 10000]), missing"),
    ],
)  # fmt: skip
def test_a_bad_agent_json_is_one_line_naming_the_key(tmp_path, capsys, change, message):
    d = model_copy(tmp_path, change)
    err = evaluate_error(d, capsys)
    assert err.startswith(f"error: {d / 'agent.json'}")
    assert message in err
    with pytest.raises(ValueError, match="agent.json"):
        ResidualAgent(d)


def test_a_servo_period_other_than_the_envs_is_refused_naming_both(tmp_path):
    import gymnasium as gym

    from contour_env import ENV_ID

    d = model_copy(tmp_path, {"servo_period_s": 0.002})
    agent = ResidualAgent(d)
    env = gym.make(ENV_ID, case="sharp-corner")
    with pytest.raises(ValueError, match=r"servo period of 0.002 s .*; the env's is 0.001 s"):
        agent.bind(env)


@pytest.mark.parametrize(
    "change, message",
    [
        ({"var": None}, "normalization.json: var: required"),
        ({"clip_obs": -1.0}, "normalization.json: clip_obs: must be a number in (0, 1e+06], "
         "got -1.0"),
        ({"mean": [0.0]}, "normalization.json: mean and var: one value per observation field, "
         "17 (agent.json's obs_dim); got 1 and 17"),
    ],
)  # fmt: skip
def test_a_bad_normalization_json_is_one_line(tmp_path, capsys, change, message):
    d = model_copy(tmp_path)
    norm = json.loads((d / "normalization.json").read_text())
    norm.update(change)
    norm = {k: v for k, v in norm.items() if v is not None}
    (d / "normalization.json").write_text(json.dumps(norm))
    assert json.loads((d / "agent.json").read_text())["obs_dim"] == 17
    err = evaluate_error(d, capsys)
    assert message in err and str(d / "normalization.json") in err


def test_a_bad_json_member_inside_model_zip_names_the_file_and_member(tmp_path, capsys):
    # 12. "Expecting property name..." with no file named
    d = model_copy(tmp_path)
    src = d / "model.zip"
    bad = tmp_path / "bad.zip"
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(bad, "w") as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename == "data":
                data = b'{"policy_class": 1,}'
            zout.writestr(item, data)
    shutil.move(bad, src)
    err = evaluate_error(d, capsys)
    assert f"{src}, member 'data': not valid JSON (Expecting property name" in err


def test_the_shipped_agents_pass_the_check():
    for d in (SHIPPED.parent).iterdir():
        if (d / "agent.json").is_file():
            meta = read_agent_json(d / "agent.json")
            ResidualAgent(d)  # normalization.json and model.zip too
            assert meta["format"] == "contour_env.residual_agent/1"


def test_every_key_the_trainer_writes_is_in_the_schema():
    from agents.rl.trainer import _metadata  # noqa: F401  (the writer of agent.json)

    names = {k.name for k in AGENT_KEYS}
    meta = json.loads((SHIPPED / "agent.json").read_text())
    assert set(meta) <= names
    assert {k.name for k in NORMALIZATION_KEYS} == {"mean", "var", "clip_obs", "epsilon"}
