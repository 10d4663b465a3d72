"""Controller resolution and scoring on the five-axis env (issue 16): every way a user names a
controller with the env's family (``make_controller(name, env=env)``, ``plant_family=``, the
command line's ``run``) gets the five-axis law (``make_controller(name).bind(env)`` refuses,
naming that fix, issue 52), and every scoring path (``evaluate``, ``run_episode``,
``compare``) reports the same metrics, orientation error included."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest

from agents import make_controller
from agents.compare import compare
from agents.five_axis_controllers import FiveAxisPDController, ISMCController
from agents.pd import PDController
from contour_env import ENV_ID
from contour_env.app.cli import main
from contour_env.evaluation import evaluate, run_episode


@pytest.fixture(scope="module")
def env():
    return gym.make(ENV_ID, case="five-axis-line", ideal=True)


def test_make_controller_takes_the_family_from_the_env(env):
    assert isinstance(make_controller("pd", env=env), FiveAxisPDController)
    assert isinstance(make_controller("ismc:rho=40", env=env), ISMCController)
    assert isinstance(make_controller("pd"), PDController)  # no env: the feed-drive PD
    with pytest.raises(ValueError, match="not available on the five-axis plant"):
        make_controller("ccc", env=env)
    with pytest.raises(ValueError, match="plant family"):
        make_controller("pd", plant_family="five-axis", env=gym.make(ENV_ID, case="sharp-corner"))


def test_feed_drive_pd_bound_to_the_five_axis_env_is_refused_naming_the_fix(env):
    # issue 52: bind returns the class it was given, or refuses (no silent swap)
    spec = "pd:p=600:d=50"
    plain = make_controller(spec)  # no env, no family: the feed-drive PD
    with pytest.raises(ValueError) as info:
        plain.bind(env)
    msg = str(info.value)
    for words in (
        f"controller {spec!r} (PDController) is a feed-drive controller",
        "five-axis plant 'five-axis'",
        f"agents.make_controller({spec!r}, env=env)",
        "plant_family='five-axis'",
        "pd, pid, ismc",
    ):
        assert words in msg, (words, msg)
    assert plain._core is None  # nothing bound
    # the fix the message names: the five-axis class of the same spec
    five = make_controller(spec, env=env).bind(env)
    assert type(five) is FiveAxisPDController
    np.testing.assert_array_equal(five.Kp, 600.0)
    np.testing.assert_array_equal(five.Kd, 50.0)
    assert type(make_controller(spec, plant_family="five-axis").bind(env)) is FiveAxisPDController
    # the refused controller still binds to a feed-drive env, as itself
    assert type(plain.bind(gym.make(ENV_ID, case="sharp-corner"))) is PDController
    with pytest.raises(ValueError, match="'ccc' is not available on the five-axis plant"):
        make_controller("ccc").bind(env)
    with pytest.raises(ValueError, match="plant_family='five-axis'"):
        PDController().bind(env)  # built directly: named by its name


def test_the_refusal_lists_the_registry_s_five_axis_controllers():
    from agents.base import FIVE_AXIS_NAMES
    from agents.registry import FIVE_AXIS_CONTROLLERS

    assert set(FIVE_AXIS_NAMES) == set(FIVE_AXIS_CONTROLLERS)


def test_every_scoring_path_reports_the_orientation_error(env):
    result = compare(["pd", "ismc"], case="five-axis-line", ideal=True)
    for name in ("pd", "ismc"):
        row = next(r for r in result["results"] if r["controller"] == name)
        m = evaluate(env, make_controller(name, env=env))
        assert m["rms_orientation_error_arcsec"] > 0
        for key in ("rms_contour_error_um", "max_contour_error_um", "rms_orientation_error_arcsec"):
            assert m[key] == pytest.approx(row[key], rel=1e-12)
    rec = run_episode(env, make_controller("pd", env=env))
    assert rec.orientation_error is not None and rec.orientation_error.shape == rec.time.shape
    assert rec.tracking_error.shape[1] == 3  # the tool tip's tracking error


def test_cli_run_on_the_five_axis_case(tmp_path, capsys):
    js = tmp_path / "r.json"
    for name in ("pd", "ismc"):
        argv = ["run", "--case", "five-axis-line", "--ideal", "--controller", name]
        assert main([*argv, "--json", str(js)]) == 0
        m = json.loads(js.read_text())["metrics"]
        assert m["rms_orientation_error_arcsec"] > 0
        assert "rms_orientation_error_arcsec" in capsys.readouterr().out


CAM_PROGRAM = """%
O0716 (five-axis finishing pass, as a post-processor writes it: A/C in degrees)
G21 G90 G94
G00 X0. Y0. Z20. A0. C0.
G01 Z2.5 F300.
G01 X12.5 Y-4.2 Z1.8 A-6.25 C12.5 F900.
X20.1 Y3.3 Z1.2 A-12.5 C35.
X14.2 Y11.9 Z1.6 A-18.75 C70.2
X2.0 Y14.5 Z2.4 A-12. C110.
M30
%
"""


def test_cli_runs_a_five_axis_gcode_program_with_plant_five_axis(tmp_path, capsys):
    # the reader takes X Y Z A C words in joint space; a program nobody here tuned on
    prog = tmp_path / "finish.nc"
    prog.write_text(CAM_PROGRAM)
    js = tmp_path / "g.json"
    argv = ["run", "--plant", "five-axis", "--gcode", str(prog), "--controller", "pd"]
    assert main([*argv, "--json", str(js)]) == 0
    rec = json.loads(js.read_text())
    m = rec["metrics"]
    assert np.isfinite(m["rms_contour_error_um"]) and m["rms_contour_error_um"] > 0
    assert np.isfinite(m["rms_orientation_error_arcsec"])
    out = capsys.readouterr().out
    assert "orientation" in out
    # on a three-axis plant the A and C words are refused, naming them and the plant
    assert main(["run", "--plant", "hsm2", "--gcode", str(prog), "--controller", "pd"]) != 0
    assert "five-axis" in capsys.readouterr().err


def test_compare_and_run_plot_five_axis_runs(tmp_path):
    from PIL import Image

    png = tmp_path / "c.png"
    argv = ["compare", "--case", "five-axis-line", "--ideal", "--controllers", "pd,ismc"]
    assert main([*argv, "--plot", str(png)]) == 0
    with Image.open(png) as im:
        assert im.size[0] > 800 and im.size[1] > 500
    png2 = tmp_path / "r.png"
    argv = ["run", "--case", "five-axis-line", "--ideal", "--controller", "pd"]
    assert main([*argv, "--plot", str(png2)]) == 0 and png2.stat().st_size > 10_000


def test_five_axis_commands_without_a_five_axis_version_refuse_in_one_line(capsys):
    argv = ["compare", "--case", "five-axis-line", "--controllers", "pd,ismc", "--randomize", "0.1"]
    assert main(argv) != 0
    assert "randomize: plant variations are not implemented for the five-axis plant" in (
        capsys.readouterr().err
    )
    assert main(["compare", "--case", "five-axis-line", "--controllers", "ccc"]) != 0
    assert "not available on the five-axis plant; known there: pd, ismc" in capsys.readouterr().err


@pytest.mark.parametrize("base", ["pd", "ismc"])
def test_five_axis_controllers_are_residual_bases(base):
    from agents.residual import ResidualWrapper

    # a zero residual is the base alone, step for step
    w = ResidualWrapper(gym.make(ENV_ID, case="five-axis-line", ideal=True), base)
    w.reset(seed=0)
    ref = gym.make(ENV_ID, case="five-axis-line", ideal=True)
    ctrl = make_controller(base, env=ref).bind(ref)
    obs, _ = ref.reset(seed=0)
    zero = np.zeros(w.action_space.shape, dtype=np.float32)
    for k in range(400):
        _, r, _, _, info = w.step(zero)
        act, _ = ctrl.predict(obs, episode_start=np.array([k == 0]))
        obs, r_ref, _, _, info_ref = ref.step(act)
        assert r == r_ref and info["contour_error"] == info_ref["contour_error"]
    # a residual moves the tool: the wrapper's action reaches the plant
    errors = {}
    for a in (0.0, 0.5):
        w.reset(seed=0)
        for _ in range(50):
            _, _, _, _, info = w.step(np.full(w.action_space.shape, a, dtype=np.float32))
        errors[a] = info["contour_error"]
    assert errors[0.5] > 10 * errors[0.0]
    with pytest.raises(ValueError, match="base: unknown controller 'ccc'; known: pd, ismc"):
        ResidualWrapper(gym.make(ENV_ID, case="five-axis-line", ideal=True), "ccc")


def test_the_path_frame_residual_is_refused_on_the_five_axis_plant():
    from agents.residual import ResidualWrapper

    env = gym.make(ENV_ID, case="five-axis-line", ideal=True)
    with pytest.raises(ValueError, match="residual_frame"):
        ResidualWrapper(env, "pd", residual_frame="path")
