"""The held-out evaluation suite (tests/data/heldout): every program parses and runs with PD on
every plant that takes it, and the training code refuses to open any of them."""

from __future__ import annotations

import dataclasses
import os
import shutil
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from agents import make_controller
from agents.rl import TrainConfig
from agents.rl.heldout import HELDOUT_DIR, refuse_heldout
from agents.rl.tasks import TaskSampler
from contour_env import ENV_ID
from contour_env.app.cli import main
from contour_env.cases import build_setup
from contour_env.evaluation import run_episode
from contour_env.metrics import score

SUITE = sorted(p for p in HELDOUT_DIR.iterdir() if p.is_file())
# 3-D parts (simultaneous XYZ moves, arcs in the ZX plane): for 3-axis plants only
THREE_D = {"helical_bore_3d.ngc", "boss_crown_3d.nc"}
PLANTS = ("hsm2", "friction-table", "jee-triaxial", "linear-motor")
TWO_AXIS = ("hsm2", "friction-table")
RUNS = [
    (p, plant) for p in SUITE for plant in PLANTS if p.name not in THREE_D or plant not in TWO_AXIS
]
SHORT = "G21 G90 G17 G64 P0.01\nG1 X3 Y1 F600\nG1 X5 Y4\n"


def test_the_suite_is_ten_to_twelve_programs_in_shop_formats():
    assert HELDOUT_DIR == Path(__file__).resolve().parents[1] / "data" / "heldout"
    assert 10 <= len(SUITE) <= 12
    assert {p.suffix for p in SUITE} >= {".nc", ".ngc", ".gcode", ".tap"}
    assert THREE_D <= {p.name for p in SUITE}


@pytest.mark.parametrize("program, plant", RUNS, ids=lambda x: getattr(x, "name", x))
def test_every_heldout_program_runs_with_pd_on_every_plant_that_takes_it(program, plant):
    setup = build_setup(plant=plant, path=str(program))
    assert setup.program_summary
    if program.name in THREE_D:
        assert setup.path.dim == 3
    env = gym.make(ENV_ID, plant=plant, path=str(program))
    m = score(run_episode(env, make_controller("pd").bind(env), seed=0))
    assert m["completed"], m["incomplete_reason"]
    assert np.isfinite(m["rms_contour_error_um"]) and m["max_contour_error_um"] < 500


@pytest.mark.parametrize("plant", TWO_AXIS)
@pytest.mark.parametrize("name", sorted(THREE_D))
def test_three_d_programs_are_refused_on_two_axis_plants_in_strict_mode(name, plant):
    with pytest.raises(ValueError, match="Z motion"):
        build_setup(plant=plant, path=str(HELDOUT_DIR / name), strict=True)


@pytest.fixture(scope="module")
def gcode(tmp_path_factory):
    p = tmp_path_factory.mktemp("gcode") / "short.nc"
    p.write_text(SHORT)
    return str(p)


@pytest.mark.parametrize("program", SUITE[:3], ids=lambda p: p.name)
def test_training_configuration_refuses_heldout_programs(program):
    with pytest.raises(ValueError, match=r"gcode: .* is in the held-out evaluation suite"):
        TrainConfig(plant="friction-table", gcode=(str(program),))


def test_the_guard_sees_through_relative_paths_links_and_copies(tmp_path, gcode):
    program = SUITE[0]
    # a path with ".." that ends in the suite
    sneaky = HELDOUT_DIR / ".." / "heldout" / program.name
    with pytest.raises(ValueError, match="held-out evaluation suite"):
        refuse_heldout(sneaky)
    rel = os.path.relpath(program, Path.cwd())
    with pytest.raises(ValueError, match="held-out evaluation suite"):
        TrainConfig(plant="hsm2", gcode=(rel,))
    # a symbolic link to a program of the suite
    link = tmp_path / "link.nc"
    link.symlink_to(program)
    with pytest.raises(ValueError, match="held-out evaluation suite"):
        TrainConfig(plant="hsm2", gcode=(str(link),))
    # a copy elsewhere: the same bytes
    copy = tmp_path / "renamed.nc"
    shutil.copyfile(program, copy)
    with pytest.raises(ValueError, match="a copy of a program of the held-out"):
        TrainConfig(plant="hsm2", gcode=(str(copy),))
    # a folder of the suite as a whole
    with pytest.raises(ValueError, match="held-out evaluation suite"):
        refuse_heldout(HELDOUT_DIR)
    # any other program is fine
    refuse_heldout(gcode)
    assert TrainConfig(plant="friction-table", gcode=(gcode,)).gcode == (gcode,)


def test_task_sampler_refuses_heldout_programs_even_past_the_configuration(gcode):
    cfg = TrainConfig(plant="friction-table", gcode=(gcode,), validation_paths=1)
    # a configuration changed after its checks (e.g. a hand-edited config.json loaded
    # without them): the sampler checks again before reading any program
    bad = dataclasses.replace(cfg)
    object.__setattr__(bad, "gcode", (str(SUITE[1]),))
    with pytest.raises(ValueError, match="held-out evaluation suite"):
        TaskSampler(bad, 0)


def test_cli_train_refuses_heldout_programs(capsys, tmp_path):
    rc = main(
        [
            "train", "--plant", "friction-table", "--gcode", str(SUITE[0]), "--timesteps",
            "10", "--out", str(tmp_path / "run"), "--no-progress",
        ]
    )  # fmt: skip
    assert rc == 2
    err = capsys.readouterr().err
    assert "held-out evaluation suite" in err and SUITE[0].name in err
    assert not (tmp_path / "run").exists()


OWN_BASE = {"friction-table": "ccc", "linear-motor": "ccc", "hsm2": "adaptive-ccc"}


@pytest.mark.parametrize("plant", sorted(OWN_BASE))
def test_each_plant_has_a_fast_part_and_a_rotated_one_its_base_completes(plant):
    """Issue 48: per plant a part at >= 5x the top training feed and one whose corners are turned
    off the axes, both completed by the plant's base controller."""
    from agents.rl.families import PLANT_RANGES

    own = sorted((HELDOUT_DIR / plant).iterdir())
    assert len(own) == 2
    top = PLANT_RANGES[plant].feed_m_s[1]
    fast = [p for p in own if p.name.startswith("fast_")]
    rotated = [p for p in own if p.name == "rotated_corners.nc"]
    assert len(fast) == 1 and len(rotated) == 1
    for program in own:
        env = gym.make(ENV_ID, plant=plant, path=str(program))
        core = env.unwrapped.core
        m = score(run_episode(env, make_controller(OWN_BASE[plant]).bind(env), seed=0))
        assert m["completed"], (program.name, m["incomplete_reason"])
        feed = core.scal[:, 0].max()
        if program in fast:
            assert feed >= 5 * top - 1e-9
        else:
            assert PLANT_RANGES[plant].feed_m_s[0] <= feed <= top
            # every straight leg of the square is at least 15 deg off both axes
            ref = core.ref_pav[:, 1, :2]
            moving = np.linalg.norm(ref, axis=1) > 0.5 * feed
            ang = np.degrees(np.arctan2(np.abs(ref[moving, 1]), np.abs(ref[moving, 0])))
            assert np.all((ang > 15) & (ang < 75))
