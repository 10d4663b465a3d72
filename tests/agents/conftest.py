"""Shared fixtures of the agent tests."""

import pytest

# a two-move part on the friction table: what the tiny training runs train on
SHORT_PROGRAM = "G21 G90 G17 G61\nG01 X2 F1200\nG01 Y2\n"


@pytest.fixture(scope="module")
def gcode(tmp_path_factory):
    """The path of :data:`SHORT_PROGRAM` written to a file (one per test module)."""
    p = tmp_path_factory.mktemp("gcode") / "short.nc"
    p.write_text(SHORT_PROGRAM)
    return str(p)
