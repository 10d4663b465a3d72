"""A controller spec is read in one function (issue 52, acceptance line 6):
:func:`agents.registry.parse_spec` turns ``"ccc:wp=3e4"`` into a :class:`ControllerSpec` and
everything after it (``make_controller``, ``compare``, ``robustness``) takes that record."""

from __future__ import annotations

import dataclasses
import pickle
import re
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import agents
from agents import compare as C
from agents import registry
from agents.parameters import ControllerSpec
from agents.registry import make_controller, parse_spec
from contour_env import ENV_ID

ROOT = Path(__file__).resolve().parents[2]
# two short moves on the friction table (tests/agents/conftest.py's SHORT_PROGRAM)
TINY = {"plant": "friction-table", "path": "G21 G90 G17 G61\nG01 X2 F1200\nG01 Y2\n"}


@pytest.fixture
def split_count(monkeypatch):
    """How many times the tokenizer has read a string since the test began."""
    calls = []
    real = registry.split_spec

    def counting(text):
        calls.append(text)
        return real(text)

    monkeypatch.setattr(registry, "split_spec", counting)
    return calls


def test_the_record_holds_name_keywords_and_label():
    spec = parse_spec("ccc:wp=3e4:wd=20")
    assert spec.name == "ccc" and spec.label == "ccc:wp=3e4:wd=20" and spec.family is None
    assert dict(spec.keywords) == {"W_p": 3e4, "W_d": 20.0}  # the constructor's keywords
    assert spec.parameters == (("wp", "3e4"), ("wd", "20"))  # as typed
    # immutable: neither its fields nor its keywords change
    with pytest.raises(dataclasses.FrozenInstanceError):
        spec.name = "pd"
    with pytest.raises(TypeError):
        spec.keywords["W_p"] = 1.0
    assert pickle.loads(pickle.dumps(spec)) == spec and hash(spec) == hash(parse_spec(spec.label))
    # adapt_parameters is applied (adaptive-ccc's gamma sets both gains)
    assert dict(parse_spec("adaptive-ccc:gamma=0").keywords) == {"gamma": (0.0, 0.0)}
    # a record passes through unchanged; agents exports both names
    assert parse_spec(spec) is spec
    assert agents.parse_spec is parse_spec and agents.ControllerSpec is ControllerSpec


def test_a_record_is_resolved_again_for_another_plant_family():
    spec = parse_spec("pd:p=600:d=50")
    five = parse_spec(spec, "five-axis")
    assert five.family == "five-axis" and five.label == spec.label
    assert dict(five.keywords) == {"P": 600.0, "D": 50.0}  # Kp (1/s²), Kd (1/s)
    assert parse_spec(five, "five-axis") is five
    with pytest.raises(ValueError, match="'ccc': not available on the five-axis plant"):
        parse_spec(parse_spec("ccc"), "five-axis")


def test_make_controller_takes_the_record_as_it_takes_the_string():
    env = gym.make(ENV_ID, case="hsm2-circle-I")
    for text in ("ccc:wp=3e4:wd=20", "pd:p=2e6/1e6:d=3e4", "adaptive-ccc:gamma=0"):
        a = make_controller(text).bind(env)
        b = make_controller(parse_spec(text)).bind(env)
        assert type(a) is type(b), text
        for gain in ("P", "D", "W_p", "W_d", "Gamma"):
            if hasattr(a, gain):
                np.testing.assert_array_equal(getattr(a, gain), getattr(b, gain), err_msg=text)
    # the record's keywords and a keyword given again are still a clear error
    with pytest.raises(ValueError, match="W_p given both"):
        make_controller(parse_spec("ccc:wp=3e4"), W_p=1e4)


def test_compare_reads_each_spec_string_once(split_count, monkeypatch):
    monkeypatch.setenv("CONTOUR_ENV_COMPILED", "0")  # the Python loop: no compile time
    specs = ["ccc:wp=3e4", "pd"]
    out = C.compare(specs, **TINY)
    assert sorted(split_count) == sorted(specs)
    assert [r["controller"] for r in out["results"]] == specs  # the label: the string given
    assert list(out["records"]) == specs


def test_robustness_reads_each_spec_string_once(split_count):
    specs = ["ccc:wp=3e4", "pd:w=60"]
    rows = C.robustness(specs, 0.1, 2, **TINY)
    assert sorted(split_count) == sorted(specs)
    assert [r["controller"] for r in rows] == specs


def test_check_controllers_returns_the_records_bound_controller_takes(split_count):
    env = gym.make(ENV_ID, **TINY)
    (spec,) = C.check_controllers(["ccc:wp=4e4"])
    assert isinstance(spec, ControllerSpec) and spec.keywords["W_p"] == 4e4
    assert C.bound_controller(spec, env).W_p == 4e4
    assert split_count == ["ccc:wp=4e4"]
    (residual,) = C.check_controllers(["residual"])
    assert residual.name == "residual" and not residual.keywords


def test_split_spec_is_called_by_parse_spec_only():
    # the tokenizer's one caller: agents/registry.py's parse_spec
    calls = []
    for root in ("agents", "contour_env", "scripts"):
        for path in (ROOT / root).rglob("*.py"):
            for n, line in enumerate(path.read_text().splitlines(), 1):
                if re.search(r"\bsplit_spec\(", line) and "def split_spec" not in line:
                    calls.append(f"{path.relative_to(ROOT)}:{n}")
    assert len(calls) == 1 and calls[0].startswith("agents/registry.py:"), calls
