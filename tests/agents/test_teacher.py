"""The teacher (agents.teacher): ILC in the agent's action space on top of its base, its table
replayed by the agent's own wrapper to the bit, and the student's data (agents.rl.teacher_data)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import contour_env  # noqa: F401
from agents.registry import make_controller
from agents.rl import TrainConfig
from agents.rl.teacher_data import collect, replay, teacher_parts
from agents.teacher import IMPROVEMENT, ResidualTeacher, check_teacher
from contour_env import ENV_ID
from contour_env.evaluation import evaluate

# a 90° corner turned 20° off the axes, blended (G64), on the friction table: 2 s of motion
CORNER = "G21 G90 G17 G64 P0.02\nG01 X9.397 Y3.420 F1200\nG01 X5.977 Y12.817\n"


def _cfg(**kw):
    base = dict(plant="friction-table", path_variety=("families",), base="ccc", seed=0)
    base.update(kw)
    return TrainConfig(**base)


@pytest.fixture(scope="module")
def lesson():
    cfg = _cfg()
    law = cfg.wrapper_kwargs()
    base = law.pop("base")
    teacher = ResidualTeacher(base, law, max_trials=12, patience=12, vary_seed=False)
    task = {"plant": "friction-table", "path": CORNER}
    return cfg, task, teacher, teacher.teach(task, seed=5)


def test_the_base_is_trial_zero_and_an_all_zero_table_is_the_base_to_the_bit(lesson):
    cfg, task, teacher, les = lesson
    base = evaluate(gym.make(ENV_ID, **task), make_controller("ccc"), seed=5)
    # trial 0 ran the base alone through the residual law's compiled loop
    assert les.history[0][0] == pytest.approx(base["rms_contour_error_um"], rel=0, abs=0)
    assert les.history[0][1] == pytest.approx(base["max_contour_error_um"], rel=0, abs=0)


def test_ilc_lowers_both_rms_and_max_on_a_part_it_repeats(lesson):
    _, _, _, les = lesson
    assert les.completed and les.kept > 0
    assert les.rms_um < 0.8 * les.base_rms_um
    assert les.max_um < les.base_max_um
    # J of the kept trial is within the 1 % improvement step of the lowest of all trials
    J = [r / les.base_rms_um + m / les.base_max_um for r, m in les.history]
    assert J[les.kept] * (1 - IMPROVEMENT) <= min(J) <= J[les.kept]


def test_the_table_is_within_the_agent_bound_and_zero_at_rest(lesson):
    cfg, task, teacher, les = lesson
    P, g = les.actions[:, :2], les.actions[:, 2]
    assert np.all(np.linalg.norm(P, axis=1) <= 1.0 + 1e-12)
    assert set(np.unique(g)) <= {0.0, 1.0}
    core = gym.make(ENV_ID, **task).unwrapped.core
    still = core.scal[: len(P), 0] <= 0  # the reference at rest (the settle at the end)
    assert still.any()
    np.testing.assert_array_equal(P[still], 0.0)


def test_the_replay_through_the_wrapper_is_the_teacher_trial(lesson):
    cfg, task, teacher, les = lesson
    out = replay(task, cfg, les.actions, les.seeds[les.kept])
    assert out["rms_um"] == les.rms_um
    assert len(out["rewards"]) == les.actions.shape[0]
    np.testing.assert_array_equal(out["labels"], les.actions.astype(np.float32))
    # the state observation: no previous-action field (obs_dim − n)
    w = teacher.wrapper(task)
    assert out["obs"].shape[1] == w.observation_space.shape[0]


def test_collect_labels_every_coverage_replay_with_the_kept_table(gcode):
    cfg = TrainConfig(plant="friction-table", gcode=(gcode,), base="ccc", teacher_parts=2,
                      teacher_trials=4, seed=1)  # fmt: skip
    data = collect(cfg, 2)
    assert data.summary()["completed"] == 2
    assert data.obs.shape[0] == data.labels.shape[0] == data.rewards.shape[0]
    for p in np.unique(data.part):
        rows = data.part == p
        n_replays = len({tuple(r) for r in [data.labels[rows][0]]})
        assert n_replays == 1
    assert np.all(np.isfinite(data.rewards)) and np.all(data.rewards <= 0)
    env = data.envelope
    assert env is not None and env.hi[0] == pytest.approx(0.02, rel=1e-6)  # F1200 mm/min


def test_teacher_parts_are_the_training_tasks_then_sampled_ones(gcode):
    cfg = TrainConfig(plant="friction-table", gcode=(gcode,), base="ccc", seed=0,
                      randomize_feedrate=0.2)  # fmt: skip
    parts = teacher_parts(cfg, 3)
    assert len(parts) == 3 and parts[0][1] == 0
    assert all(p[0]["path"] == gcode for p in parts)
    assert len({p[0]["feedrate_m_s"] for p in parts[1:]}) == 2  # drawn feeds
    # never a validation seed: the sampler's seeds are below 2**31
    assert all(0 <= s < 2**31 for _, s in parts)


def test_a_fixed_task_is_taught_once_and_generated_parts_fill_the_rest():
    """One case, nothing randomised: the case once, then family parts of training seeds (a
    second copy of the case would teach nothing new)."""
    from agents.rl.families import VALIDATION_SEED_BASE

    cfg = TrainConfig(cases=("sharp-corner",), base="ccc", seed=0)
    parts = teacher_parts(cfg, 6)
    assert parts[0][0]["case"] == "sharp-corner"
    rest = [p for p, _ in parts[1:]]
    assert all("case" not in p and p["plant"] == "friction-table" for p in rest)
    assert len({p["feedrate_m_s"] for p in rest}) == 5  # five distinct parts
    assert all(0 <= s < VALIDATION_SEED_BASE for _, s in parts[1:])


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"gains": (0.1, 0.3)}, r"gains: three learning gains in \(0, 2\]"),
        ({"gains": (0.1, 0.3, 3.0)}, r"gains: three learning gains in \(0, 2\]"),
        ({"max_trials": 0}, r"max_trials: must be an integer >= 1"),
        ({"patience": 1.5}, r"patience: must be an integer >= 1"),
    ],
)
def test_bad_teacher_arguments_are_clear_errors(kwargs, match):
    with pytest.raises(ValueError, match=match):
        ResidualTeacher("ccc", {}, **kwargs)


def test_teacher_names_are_checked():
    assert check_teacher("none") == "none"
    with pytest.raises(ValueError, match="teacher: must be one of ilc-contour, none"):
        check_teacher("dagger")
    with pytest.raises(ValueError, match="teacher: must be one of"):
        _cfg(teacher="ilc")


def test_the_compiled_replay_gives_the_wrappers_transitions(lesson):
    from agents.rl.teacher_data import replay_python

    cfg, task, teacher, les = lesson
    fast = replay(task, cfg, les.actions, les.seeds[les.kept])
    slow = replay_python(task, cfg, les.actions, les.seeds[les.kept])
    assert fast["rms_um"] == slow["rms_um"]
    for key in ("obs", "next_obs", "actions", "labels", "dones", "weight"):
        np.testing.assert_array_equal(fast[key], slow[key], err_msg=key)
    np.testing.assert_allclose(fast["rewards"], slow["rewards"], rtol=1e-12, atol=1e-12)
