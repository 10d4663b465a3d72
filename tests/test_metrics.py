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
