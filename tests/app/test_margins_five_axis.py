"""``contour-env margins --plant five-axis``: the joint loops of the five-axis plant (issue 38:
``--controller pid --json OUT`` ≥ 6 dB / 30°), its JSON fields and its clear errors."""

from __future__ import annotations

import json

import pytest

from contour_env.app.cli import main


def test_margins_cli_five_axis_pid_json(tmp_path, capsys):
    out = tmp_path / "m.json"
    assert main(["margins", "--plant", "five-axis", "--controller", "pid", "--json", str(out),
                 "--check"]) == 0  # fmt: skip
    text = capsys.readouterr().out
    assert "poses (joint loops)" in text and "meets the requirement ≥ 6 dB / ≥ 30°" in text
    rep = json.loads(out.read_text())
    assert rep["plant"] == "five-axis" and rep["machine"] == "nxv560a"
    assert rep["controller"] == "pid" and rep["ideal"] is False and rep["stable"] is True
    assert rep["mass_variation"] == 0.2 and rep["structural_mode"] is False
    assert rep["min_gain_margin_db"] >= 6.0 and rep["min_phase_margin_deg"] >= 30.0
    assert [r["loop"] for r in rep["loops"]] == [f"joint {j}" for j in "xyzAC"]
    for r in rep["loops"]:
        assert set(r) >= {
            "gain_margin_db", "phase_margin_deg", "crossover_hz", "phase_crossover_hz",
            "gain_margin_at", "phase_margin_at",
        }  # fmt: skip
        assert r["crossover_hz"] > 0 and r["phase_crossover_hz"] > r["crossover_hz"]
        at = r["phase_margin_at"]
        assert len(at["mass_scale"]) == 5 and at["pose"] in rep["poses"]
    assert len(rep["by_mass"]) == 33
    assert min(b["min_gain_margin_db"] for b in rep["by_mass"]) == pytest.approx(
        rep["min_gain_margin_db"]
    )


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["--plant", "five-axis", "--controller", "ismc"], "no joint-loop model"),
        (["--plant", "five-axis", "--controller", "ccc"], "not available on the five-axis plant"),
        (["--plant", "nxv560a", "--structural-mode"], "no structural mode"),
        (["--plant", "hsm2", "--controller", "pid"], "needs the five-axis plant"),
    ],
)
def test_margins_cli_five_axis_errors(argv, needle, capsys):
    assert main(["margins", *argv]) == 2
    err = capsys.readouterr().err
    assert needle in err and "unknown plant" not in err
