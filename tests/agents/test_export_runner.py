"""agents/export/c_runner.py: the exported C law compiled and run in the simulator on top of a
base controller, as the machine would run it (the sim-to-real chain's last step)."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import pytest

from agents.export import write_c
from agents.export.bench import compiler
from agents.export.c_runner import CLaw, CLawController
from agents.registry import make_controller
from agents.residual import ResidualAgent
from contour_env.evaluation import evaluate

MODELS = Path(__file__).resolve().parents[2] / "agents" / "models"
SQUARE = "G21 G90 G17 G61\nG01 X10 F1200\nG01 Y10\nG01 X0\nG01 Y0\n"

pytestmark = pytest.mark.skipif(compiler() is None, reason="no C compiler")


def test_the_zero_law_on_top_of_ccc_is_ccc_to_the_bit(tmp_path):
    iface = write_c(MODELS / "friction-table", tmp_path)
    law = CLaw(tmp_path, iface)
    kw = dict(plant="friction-table", path=SQUARE, measurement_noise_std_m=1e-7)
    base = evaluate(gym.make("contour_env/Contouring-v0", **kw), make_controller("ccc"))
    mine = evaluate(gym.make("contour_env/Contouring-v0", **kw), CLawController(law, "ccc"))
    assert mine["completed"]
    assert mine["rms_contour_error_um"] == base["rms_contour_error_um"]
    assert mine["max_contour_error_um"] == base["max_contour_error_um"]


def test_the_linear_motor_law_runs_the_part_as_the_python_agent(tmp_path):
    iface = write_c(MODELS / "linear-motor", tmp_path)
    law = CLaw(tmp_path, iface)
    kw = dict(plant="linear-motor", path=SQUARE, feedrate_m_s=0.05, max_accel_m_s2=0.5)
    py = evaluate(
        gym.make("contour_env/Contouring-v0", **kw), ResidualAgent(MODELS / "linear-motor")
    )
    c = evaluate(gym.make("contour_env/Contouring-v0", **kw), CLawController(law, "ccc"))
    assert c["completed"]
    # the closed loop's own sensitivity below float rounding (tests/agents/test_export_c.py)
    assert c["rms_contour_error_um"] == pytest.approx(py["rms_contour_error_um"], rel=0.03)
    assert c["max_contour_error_um"] == pytest.approx(py["max_contour_error_um"], rel=0.03)


def test_a_law_that_does_not_compile_is_one_clear_error(tmp_path):
    iface = write_c(MODELS / "friction-table", tmp_path)
    (tmp_path / "residual.c").write_text("this is not C\n")
    with pytest.raises(ValueError, match="residual.c does not compile"):
        CLaw(tmp_path, iface)
