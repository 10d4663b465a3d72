"""contour_env.schema: the one check of the files users edit (messages, ranges, tables)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from contour_env.schema import (
    FileFormatError,
    Key,
    check_column,
    check_object,
    markdown_table,
    read_json,
    show,
)

KEYS = (
    Key("gain", "number", "N/m", 0.0, 10.0, lo_open=True, per_axis=True, required=True),
    Key("count", "integer", "", 1, 5),
    Key("on", "bool"),
    Key("mode", "choice", choices=("a", "b")),
    Key("opt", "object", nullable=True),
    Key("names", "strings"),
)


GAIN = "f.json: gain: must be a number in (0, 10] N/m, or one per axis"


@pytest.mark.parametrize(
    "data, message",
    [
        ({"gain": 0.0}, f"{GAIN}, got 0.0"),
        ({"gain": None}, f"{GAIN}, got null"),
        ({"gain": math.nan}, f"{GAIN}, got NaN"),
        ({"gain": True}, f"{GAIN}, got true"),
        ({"gain": "big"}, f'{GAIN}, got "big"'),
        ({"gain": [1.0, 2.0, 3.0]}, f"{GAIN} "
         "(2 per-axis values), got [1.0, 2.0, 3.0]"),
        ({"gain": 1.0, "count": 0}, "f.json: count: must be an integer in [1, 5], got 0"),
        ({"gain": 1.0, "count": 2.0}, "f.json: count: must be an integer in [1, 5], got 2.0"),
        ({"gain": 1.0, "on": 1}, "f.json: on: must be true or false, got 1"),
        ({"gain": 1.0, "mode": "c"}, 'f.json: mode: must be one of "a", "b", got "c"'),
        ({"gain": 1.0, "opt": [1]}, "f.json: opt: must be a JSON object (or null), got [1]"),
        ({"gain": 1.0, "names": ["x", 1]}, 'f.json: names: must be a list of strings, '
         'got ["x", 1]'),
        ({}, "f.json: gain: required (a number in (0, 10] N/m, or one per axis), missing"),
        ({"gain": 1.0, "gian": 1.0}, 'f.json: unknown key "gian"; allowed: gain, count, on, mode, '
         "opt, names"),
        ([1, 2, 3], 'f.json must hold a JSON object ({"key": value, ...}), got a list ([1, 2, 3])'),
    ],
)  # fmt: skip
def test_each_bad_value_is_one_line_naming_file_key_value_and_rule(data, message):
    with pytest.raises(FileFormatError) as info:
        check_object(data, KEYS, "f.json", n_axes=2)
    assert str(info.value) == message


def test_good_values_pass_and_null_is_allowed_only_where_nullable():
    ok = {"gain": [1.0, 10.0], "count": 5, "on": False, "mode": "b", "opt": None, "names": []}
    assert check_object(ok, KEYS, "f.json", n_axes=2) is ok
    check_object({"gain": np.float32(3.0), "count": np.int64(1)}, KEYS, "f.json")
    check_object({"gain": 1.0, "x": 1}, KEYS, "f.json", unknown="ignore")


def test_a_column_names_the_first_line_out_of_range_and_counts_the_rest():
    key = Key("position_x", "number", "m", -100.0, 100.0)
    x = np.array([0.0, 1.0, 1e308, 2.0])
    with pytest.raises(FileFormatError) as info:
        check_column("t.csv", "position_x", x, [2, 3, 4, 5], key, hint="metres")
    assert str(info.value) == (
        "t.csv line 4, column 'position_x': 1e+308 m is outside [-100, 100] m (the only row "
        "outside: a glitch? remove or repair that row)"
    )
    with pytest.raises(FileFormatError, match=r"line 3, .* \(3 rows outside\); metres$"):
        check_column(
            "t.csv", "position_x", [0.0, 1e6, 1e308, 2e6], [2, 3, 4, 5], key, hint="metres"
        )
    np.testing.assert_array_equal(check_column("t.csv", "p", x[:2], [2, 3], key), x[:2])


def test_read_json_names_the_file(tmp_path):
    bad = tmp_path / "a.json"
    bad.write_text('{"a": 1,}')
    with pytest.raises(FileFormatError, match=r"a.json: not valid JSON \(Expecting property name"):
        read_json(bad)
    with pytest.raises(FileFormatError, match=r"nope.json: no such file \(agent.json\)"):
        read_json(tmp_path / "nope.json", "agent.json")
    good = tmp_path / "b.json"
    good.write_text(json.dumps({"a": [1, 2]}))
    assert read_json(good) == {"a": [1, 2]}


def test_markdown_table_has_a_row_per_key_with_unit_and_range():
    table = markdown_table(KEYS)
    lines = table.strip().splitlines()
    assert len(lines) == 2 + len(KEYS)
    assert lines[2].startswith("| `gain` | N/m | a number in (0, 10], or one per axis | yes |")
    assert show("x" * 100).endswith('..."'[:3]) and len(show("x" * 100)) == 80
