"""The one scoring function, against hand-computed values."""

import numpy as np
import pytest

from contour_env.metrics import EpisodeRecord, score


def _record(eps, te, force, limit=(10.0, 10.0), reason=None):
    n = len(eps)
    force = np.asarray(force, dtype=float)
    return EpisodeRecord(
        time=np.arange(1, n + 1) * 1e-3,
        contour_error=np.asarray(eps, dtype=float),
        tracking_error=np.asarray(te, dtype=float),
        force=force,
        saturated=np.abs(force) >= np.asarray(limit),
        position=np.zeros((n, 2)),
        reference=np.zeros((n, 2)),
        force_limit=np.asarray(limit),
        termination_reason=reason,
    )


def test_score_matches_hand_computation():
    eps = [1e-6, 3e-6, 2e-6, 4e-6]
    te = [[1e-6, -2e-6], [3e-6, 0.0], [-1e-6, 1e-6], [0.0, 5e-6]]
    force = [[1.0, -2.0], [10.0, 0.0], [-3.0, 4.0], [0.0, 0.0]]
    m = score(_record(eps, te, force))
    assert m["max_contour_error_um"] == pytest.approx(4.0)
    assert m["rms_contour_error_um"] == pytest.approx(np.sqrt((1 + 9 + 4 + 16) / 4))
    assert m["mean_abs_contour_error_um"] == pytest.approx(2.5)
    assert m["max_tracking_error_um"] == pytest.approx([3.0, 5.0])
    assert m["rms_tracking_error_um"] == pytest.approx(
        [np.sqrt((1 + 9 + 1 + 0) / 4), np.sqrt((4 + 0 + 1 + 25) / 4)]
    )
    assert m["rms_effort"] == pytest.approx([np.sqrt((1 + 100 + 9) / 4), np.sqrt((4 + 16) / 4)])
    assert m["peak_effort"] == pytest.approx([10.0, 4.0])
    assert m["saturation_fraction"] == pytest.approx(0.25)
    assert m["n_steps"] == 4 and m["completed"] is True


def test_total_contour_error_of_chen_and_lee_by_hand():
    """Chen & Lee 2020's total contour error (§4.2, Tables 1–2): Σ_k |ε_k|, µm, only when a run
    asks for it; over the cutting steps where the record has rapids."""
    eps = [1e-6, -3e-6, 2.5e-6, 0.0, 4e-6]
    te = np.zeros((5, 2))
    force = np.zeros((5, 2))
    record = _record(eps, te, force)
    assert "total_contour_error_um" not in score(record)
    m = score(record, metrics=("total",))
    assert m["total_contour_error_um"] == pytest.approx(1.0 + 3.0 + 2.5 + 0.0 + 4.0)
    assert score(record, metrics="total") == m
    record.rapid = np.array([False, True, False, False, True])
    assert score(record, metrics=("total",))["total_contour_error_um"] == pytest.approx(3.5)
    with pytest.raises(ValueError, match="metrics: unknown metric 'sum'; known: total"):
        score(record, metrics=("sum",))


def test_diverged_samples_are_none_not_nan():
    m = score(
        _record([1e-6, np.inf], [[0, 0], [np.nan, 0]], [[0, 0], [0, 0]], reason="non_finite_state")
    )
    assert m["max_contour_error_um"] is None
    assert m["max_tracking_error_um"][0] is None and m["max_tracking_error_um"][1] == 0.0
    assert m["completed"] is False and m["termination_reason"] == "non_finite_state"


def test_empty_record_is_an_error():
    with pytest.raises(ValueError, match="no steps"):
        score(_record([], np.zeros((0, 2)), np.zeros((0, 2))))


def _record_with_encoder(eps, resolution_m):
    n = len(eps)
    rec = _record(eps, np.zeros((n, 2)), np.ones((n, 2)))
    rec.encoder_resolution_m = np.asarray(resolution_m, dtype=float)
    return rec


def test_contour_error_below_one_encoder_count_is_flagged():
    # coarsest axis count 2 µm: RMS 1.5 µm and max 1.9 µm are below it
    m = score(_record_with_encoder([1.0e-6, 1.9e-6, 1.5e-6, 1.4e-6], [2e-6, 1e-6]))
    assert m["encoder_resolution_um"] == pytest.approx(2.0)
    assert m["below_resolution"] is True and m["max_below_resolution"] is True
    # RMS below, max above one count
    m = score(_record_with_encoder([0.5e-6, 0.5e-6, 0.5e-6, 3e-6], [2e-6, 1e-6]))
    assert m["below_resolution"] is True and m["max_below_resolution"] is False
    # both above; an ideal encoder (0) never flags; an unknown one gives None
    m = score(_record_with_encoder([5e-6, 6e-6], [0.1e-6, 0.1e-6]))
    assert m["encoder_resolution_um"] == pytest.approx(0.1)
    assert m["below_resolution"] is False and m["max_below_resolution"] is False
    m = score(_record_with_encoder([1e-9, 1e-9], [0.0, 0.0]))
    assert m["encoder_resolution_um"] == 0.0 and m["below_resolution"] is False
    m = score(_record([1e-9], [[0.0, 0.0]], [[0.0, 0.0]]))
    assert m["encoder_resolution_um"] is None and m["below_resolution"] is None


def test_run_episode_records_the_plants_encoder():
    import gymnasium as gym

    from contour_env import ENV_ID
    from contour_env.evaluation import run_episode

    env = gym.make(ENV_ID, case="sharp-corner")  # friction-table: 0.1 µm counts
    rec = run_episode(env, None, seed=0)
    np.testing.assert_allclose(
        rec.encoder_resolution_m, env.unwrapped.core.setup.plant.params.encoder_resolution_m
    )
    assert score(rec)["encoder_resolution_um"] == pytest.approx(0.1)


def _comparison(rows):
    base = {
        "stable": True,
        "termination_reason": None,
        "n_steps": 10,
        "rms_effort": [1.0, 2.0],
        "encoder_resolution_um": 0.1,
    }
    return {"case": "c", "plant": "p", "results": [{**base, **r} for r in rows]}


def test_compare_table_marks_errors_below_one_count_and_prints_3_significant_digits():
    from agents.compare import format_table

    text = format_table(
        _comparison(
            [
                {"controller": "pd", "max_contour_error_um": 200.0, "rms_contour_error_um": 100.0},
                {"controller": "ccc", "max_contour_error_um": 0.09, "rms_contour_error_um": 0.05},
                {"controller": "x", "max_contour_error_um": 2e5, "rms_contour_error_um": 1e5},
            ]
        )
    )
    lines = text.splitlines()
    assert "RMS/PD" in lines[1]
    ccc = next(line for line in lines if line.startswith("ccc"))
    assert ccc.count("≤0.1 (enc)") == 2 and "0.05" not in ccc.split("[")[0]
    assert "5.00e-04" in ccc  # 3 significant digits, not 0.00
    x = next(line for line in lines if line.startswith("x "))
    assert " 1000 " in x  # a 1000× ratio, 3 significant digits
    pd = next(line for line in lines if line.startswith("pd"))
    assert "100.00" in pd and "1.00" in pd


def test_compare_table_without_pd_takes_the_first_row_as_reference():
    from agents.compare import format_table

    text = format_table(
        _comparison(
            [
                {
                    "controller": "ccc:wp=3e4",
                    "max_contour_error_um": 9.0,
                    "rms_contour_error_um": 4.0,
                },
                {
                    "controller": "adaptive-ccc",
                    "max_contour_error_um": 5.0,
                    "rms_contour_error_um": 1.0,
                },
            ]
        )
    )
    lines = text.splitlines()
    assert "RMS/ccc:wp=3e4" in lines[1] and "RMS/PD" not in text
    assert lines[2].split("[")[0].split()[-1] == "1.00"
    assert lines[3].split("[")[0].split()[-1] == "0.250"


# --- completed: only a run that followed the program; the cut scope of G-code rapids ---------


def _te_record(te, reason=None, planned=None):
    n = len(te)
    rec = _record(np.zeros(n), te, np.zeros((n, 2)), reason=reason)
    rec.n_steps_planned = planned
    return rec


def test_completed_only_for_a_run_that_followed_the_program():
    ok = _te_record([[1e-4, 0.0], [5e-3, 5e-3], [2e-4, -1e-4]])
    assert ok.completed and ok.incomplete_reason is None
    assert score(ok)["completed"] is True and score(ok)["incomplete_reason"] is None
    # a tool that stood still on a closed path: back at its start at the end, 20 mm away midway
    still = _te_record([[0.0, 0.0], [0.02, 0.0], [0.0, 0.0]])
    m = score(still)
    assert m["completed"] is False and m["termination_reason"] is None
    assert "did not follow" in m["incomplete_reason"] and "20 mm" in m["incomplete_reason"]
    late = _te_record([[1e-4, 0.0], [2e-3, 0.0]])  # never off by 10 mm, but 2 mm short at the end
    assert not late.completed and "did not reach the end" in late.incomplete_reason
    short = _te_record([[0.0, 0.0]] * 3, planned=5)
    assert not short.completed and short.incomplete_reason == "stopped after 3 of 5 steps"
    assert _te_record([[0.0, 0.0]] * 5, planned=5).completed
    stopped = _te_record([[0.0, 0.0]], reason="tracking_error_limit")
    assert score(stopped)["incomplete_reason"] == "terminated: tracking_error_limit"
    assert not _te_record([[0.0, 0.0], [np.nan, 0.0], [0.0, 0.0]]).completed


def test_cut_scope_takes_the_headline_over_cutting_steps_by_hand():
    eps = np.array([9.0, 1.0, 3.0, 2.0, 7.0]) * 1e-6
    rapid = np.array([True, False, False, False, True])
    rec = _record(eps, np.zeros((5, 2)), np.zeros((5, 2)))
    assert score(rec)["scope"] == "all" and score(rec)["rapid_max_contour_error_um"] is None
    assert score(rec)["max_contour_error_um"] == pytest.approx(9.0)
    rec.rapid = rapid
    m = score(rec)
    assert m["scope"] == "cut"
    assert m["max_contour_error_um"] == pytest.approx(3.0)
    assert m["rms_contour_error_um"] == pytest.approx(np.sqrt((1 + 9 + 4) / 3))
    assert m["mean_abs_contour_error_um"] == pytest.approx(2.0)
    assert m["rapid_max_contour_error_um"] == pytest.approx(9.0)
    assert m["rapid_rms_contour_error_um"] == pytest.approx(np.sqrt((81 + 49) / 2))
    rec.rapid = rapid[:4]
    with pytest.raises(ValueError, match="rapid"):
        score(rec)


def test_gcode_rapids_are_scored_apart_from_the_cutting_moves():
    from pathlib import Path

    import gymnasium as gym

    from agents import make_controller
    from contour_env import ENV_ID
    from contour_env.evaluation import run_episode

    # G00 to the start of the cut, two G01 lines, G00 back to the origin
    program = Path(__file__).resolve().parent / "data" / "rapids.nc"
    env = gym.make(ENV_ID, plant="friction-table", path=str(program))
    setup = env.unwrapped.setup
    np.testing.assert_array_equal(setup.segment_is_rapid, [True, False, False, True])
    # each step by the reference's arc length: rapid inside the first 5 mm and the last
    # segment (from 25 mm on), cutting in between, the junctions counting as cutting
    s = setup.reference.arc_length
    expected = (s < 0.005) | (s > 0.025)
    np.testing.assert_array_equal(setup.step_is_rapid, expected)
    assert setup.step_is_rapid[0] and setup.step_is_rapid[-1]  # start and final settle

    rec = run_episode(env, make_controller("pd"))
    n = len(rec.contour_error)
    np.testing.assert_array_equal(rec.rapid, setup.step_is_rapid[1 : n + 1])
    m = score(rec)
    assert m["completed"] and m["scope"] == "cut"
    cut, fast = rec.contour_error[~rec.rapid] * 1e6, rec.contour_error[rec.rapid] * 1e6
    assert 0 < cut.size < n and fast.size > 0
    assert m["max_contour_error_um"] == pytest.approx(np.max(cut), rel=1e-12)
    assert m["rms_contour_error_um"] == pytest.approx(np.sqrt(np.mean(cut**2)), rel=1e-12)
    assert m["mean_abs_contour_error_um"] == pytest.approx(np.mean(cut), rel=1e-12)
    assert m["rapid_max_contour_error_um"] == pytest.approx(np.max(fast), rel=1e-12)
    assert m["rapid_rms_contour_error_um"] == pytest.approx(np.sqrt(np.mean(fast**2)), rel=1e-12)
    # a path without rapids keeps the whole-episode scope
    assert score(run_episode(gym.make(ENV_ID, case="sharp-corner"), None))["scope"] == "all"
