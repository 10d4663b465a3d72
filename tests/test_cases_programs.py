"""Real part programs through the whole setup (contour_env.cases): the shop-style corpus on
every plant, Z on a 2-axis plant, the look-ahead planner from G-code, the corner-blend case."""

from __future__ import annotations

import math
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from agents import make_controller
from contour_env import ENV_ID
from contour_env.cases import CASES, build_setup
from contour_env.evaluation import run_episode
from contour_env.metrics import score

CORPUS = sorted((Path(__file__).resolve().parent / "data" / "gcode").iterdir())
PLANTS = ("hsm2", "friction-table", "jee-triaxial", "linear-motor")


@pytest.mark.parametrize("plant", PLANTS)
@pytest.mark.parametrize("program", CORPUS, ids=lambda p: p.name)
def test_every_corpus_program_sets_up_on_every_plant(program, plant):
    setup = build_setup(plant=plant, path=str(program))
    ref = setup.reference
    assert setup.path.dim <= setup.plant.n_axes
    if setup.plant.n_axes == 2:  # the reference table is 3-D; z stays 0 for an XY machine
        assert np.all(ref.position[:, 2] == 0.0)
    assert np.all(np.isfinite(ref.position)) and np.all(np.isfinite(ref.velocity))
    # the reference follows the program's path from start to end
    assert ref.arc_length[-1] == pytest.approx(setup.path.total_length, rel=1e-9, abs=1e-12)
    assert setup.program_summary  # the reader reports what it did with the setup words
    if setup.plant.n_axes == 2 and "Z motion" in setup.program_summary:
        assert setup.path.dim == 2


def _episode(plant, program, controller="pd"):
    env = gym.make(ENV_ID, plant=plant, path=str(program))
    return score(run_episode(env, make_controller(controller).bind(env), seed=0))


# every program runs a whole episode on every plant with a 1 ms servo period; the linear
# motor's 0.1 ms period makes its episodes ten times longer, so in the suite it runs two short
# programs, one with Z motion and R arcs, one with G18/G19 arcs (the set-up test above covers
# all of them on it)
LM_RUNS = ("grbl_compact.gcode", "side_fillets_g18_g19.nc")
RUNS = [(p, plant) for p in CORPUS for plant in PLANTS[:3]] + [
    (p, "linear-motor") for p in CORPUS if p.name in LM_RUNS
]


@pytest.mark.parametrize("program, plant", RUNS, ids=lambda x: getattr(x, "name", x))
def test_corpus_programs_run_to_completion_with_pd(program, plant):
    m = _episode(plant, program)
    assert m["completed"], m["incomplete_reason"]
    assert m["max_contour_error_um"] < 2000


def test_z_on_a_two_axis_plant_becomes_pauses_or_is_refused_with_strict():
    text = "G21 G90 G17\nG1 X10 F600\nG1 Z-2\nG1 X20\nG0 Z5\nM30\n"
    setup = build_setup(plant="hsm2", path=text)
    assert setup.path.dim == 2
    assert setup.path.total_length == pytest.approx(0.02)
    assert "Z motion" in setup.program_summary
    # the Z-only moves are pauses of their duration (2 mm at 10 mm/s; the rapid 7 mm at the
    # rapid feed, the highest F = 10 mm/s): the run lasts at least the cut plus the pauses
    cut_only = build_setup(plant="hsm2", path="G21 G90 G17\nG1 X10 F600\nG1 X20\nM30\n")
    assert setup.profile.duration >= cut_only.profile.duration + 0.2 + 0.7 - 1e-9
    with pytest.raises(ValueError, match=r"Z motion on 2 lines \(3, 5\)"):
        build_setup(plant="hsm2", path=text, strict=True)
    with pytest.raises(ValueError, match=r"lines \(3, 5\)"):
        gym.make(ENV_ID, plant="friction-table", path=text, strict=True)
    # a 3-axis plant follows Z
    assert build_setup(plant="linear-motor", path=text).path.dim == 3


def _bends(n=100, leg_mm=5.0, bend_deg=1.0, mode="G64"):
    lines = ["G21 G90 G17", mode, "G1 X0 Y0 F6000"]
    x = y = 0.0
    heading = 0.0
    for _ in range(n):
        x += leg_mm * math.cos(heading)
        y += leg_mm * math.sin(heading)
        lines.append(f"G1 X{x:.4f} Y{y:.4f}")
        heading += math.radians(bend_deg)
    lines.append("M30")
    return "\n".join(lines) + "\n"


def test_a_cam_polyline_with_1_degree_bends_runs_near_its_programmed_feed_in_g64():
    setup = build_setup(plant="hsm2", path=_bends(mode="G64"))
    F = 0.1  # F6000 mm/min
    a = setup.max_accel_m_s2
    bound = 1.2 * (setup.path.total_length / F + 2 * F / a)
    assert setup.profile.duration <= bound
    # and in G61 the tool stops at each bend: far slower, speed ~0 at every junction
    g61 = build_setup(plant="hsm2", path=_bends(mode="G61"))
    assert g61.profile.duration > 2 * bound
    s_joints = g61.path.seg_s0[1:]
    ref = g61.reference
    at = np.searchsorted(ref.arc_length, s_joints)
    assert np.all(ref.feedrate[np.clip(at, 0, ref.n_steps - 1)] < 0.01 * F)


def test_cli_run_prints_the_program_summary(capsys):
    from contour_env.app.cli import main

    program = CORPUS[0]
    assert main(["run", "--plant", "hsm2", "--gcode", str(program), "--controller", "pd"]) == 0
    out = capsys.readouterr().out
    assert "program: " in out and "ignored" in out


def test_corner_blend_is_a_named_case_with_random_phase_and_noise_by_default():
    spec = CASES["corner-blend"]
    assert spec.plant == "friction-table"
    env = gym.make(ENV_ID, case="corner-blend")
    cfg = env.unwrapped.config
    assert cfg.disturbance_phase == "random" and cfg.measurement_noise_std_m > 0
    # an explicit setting wins over the case's
    env2 = gym.make(ENV_ID, case="corner-blend", disturbance_phase="fixed")
    assert env2.unwrapped.config.disturbance_phase == "fixed"
    setup = env.unwrapped.setup
    # continuous path: faster than the same program in exact stop, no leg along an axis
    legs = np.diff(
        setup.path.evaluate(np.r_[setup.path.seg_s0, setup.path.total_length])["position"], axis=0
    )
    assert np.all(np.abs(legs[:, :2]) > 1e-3)
    assert "G64" in setup.program_summary
    text = Path(__file__).resolve().parent.parent / "contour_env" / "data" / "corner_blend.nc"
    g61 = build_setup(
        plant="friction-table",
        path=text.read_text().replace("G64 P0.01", "G61"),
        max_accel_m_s2=spec.max_accel_m_s2,
        max_jerk_m_s3=spec.max_jerk_m_s3,
    )
    assert setup.profile.duration < g61.profile.duration
    # the notes quote facts computed from the program
    assert "corners of 15/45/60/90/120°" in spec.notes and "10 µm path tolerance" in spec.notes


@pytest.mark.parametrize("controller", ["pd", "ccc", "adaptive-ccc"])
def test_corner_blend_runs_with_the_classical_controllers(controller):
    env = gym.make(ENV_ID, case="corner-blend")
    m = score(run_episode(env, make_controller(controller).bind(env), seed=0))
    assert m["completed"], m["incomplete_reason"]
