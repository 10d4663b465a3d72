"""``contour-env compare`` checks every option before it runs anything and names every bad one
in one error (issue 36 item 13; contour_env.app.cli_checks)."""

from __future__ import annotations

import re

import pytest

from contour_env.app.cli import main


def _error(argv, capsys) -> str:
    rc = main(argv)
    captured = capsys.readouterr()
    assert rc != 0
    assert captured.out == ""  # nothing ran: no nominal result printed before the error
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ")
    return lines[0]


def test_randomize_and_episodes_both_named_before_anything_runs(capsys):
    argv = ["compare", "--case", "hsm2-circle-III", "--controllers", "pd"]
    err = _error([*argv, "--randomize", "-1", "--episodes", "0"], capsys)
    assert err == (
        "error: --randomize: must be a fraction in [0, 1), got -1; --episodes: must be >= 1, got 0"
    )


def test_every_bad_option_is_named_in_one_error(capsys):
    argv = [
        "compare",
        "--case",
        "hsm2-circle-III",
        "--controllers",
        "pd,nope",
        "--metrics",
        "bogus",
        "--model",
        "somewhere",
        "--feedrate",
        "0",
        "--rapid-feed",
        "nan",
        "--randomize",
        "1.5",
        "--episodes",
        "-2",
        "--seed",
        str(2**70),
    ]
    err = _error(argv, capsys)
    named = re.findall(r"(?:^error: |; )(--[a-z-]+):", err)
    assert named == [
        "--controllers",
        "--model",
        "--metrics",
        "--feedrate",
        "--rapid-feed",
        "--randomize",
        "--episodes",
        "--seed",
    ]
    assert "unknown controller 'nope'" in err and "unknown metric 'bogus'" in err


@pytest.mark.parametrize(
    "extra, fragment",
    [
        (["--randomize", "1"], "--randomize: must be a fraction in [0, 1), got 1"),
        (["--episodes", "0"], "--episodes: must be >= 1, got 0"),
        (["--seed", "-1"], "--seed: must be in [0, 2**64 - 1]"),
        (["--feedrate", "1e3"], "--feedrate: must be > 0 and <= 100 m/s, got 1000"),
    ],
)
def test_one_bad_option(extra, fragment, capsys):
    err = _error(["compare", "--case", "hsm2-circle-III", "--controllers", "pd", *extra], capsys)
    assert fragment in err and err.count(": must") == 1
