"""contour_env.plants.randomize: feed-drive variations, and a clear refusal on the five-axis
plant (issue 49, item 8: it was an AttributeError on 'mass_kg')."""

from __future__ import annotations

import numpy as np
import pytest

from contour_env.plants import Plant
from contour_env.plants.five_axis import five_axis_params
from contour_env.plants.randomize import RANDOMIZED_FIELDS, randomized


def test_variations_scale_each_field_within_the_fraction_and_keep_static_above_coulomb():
    p = Plant("friction-table").params
    out = randomized(p, 0.2, 16, seed=3)
    assert len(out) == 16
    for q in out:
        for key in RANDOMIZED_FIELDS[:3]:
            ratio = getattr(q, key) / getattr(p, key)
            assert np.all((ratio >= 0.8 - 1e-12) & (ratio <= 1.2 + 1e-12))
        assert np.all(q.static_N >= q.coulomb_N)
    again = randomized(p, 0.2, 16, seed=3)
    np.testing.assert_array_equal(out[5].mass_kg, again[5].mass_kg)


def test_the_five_axis_plant_is_refused_with_the_reason():
    params = five_axis_params("nxv560a")[0]
    with pytest.raises(ValueError, match=r"^randomize: plant variations are defined for the "
                       r"feed-drive plants .* got FiveAxisParams"):  # fmt: skip
        randomized(params, 0.1, 2)


def test_compare_randomize_on_a_five_axis_case_says_why_not(capsys):
    from contour_env.app.cli import main

    code = main(["compare", "--case", "five-axis-line", "--controllers", "pid", "--randomize",
                 "0.1", "--episodes", "2"])  # fmt: skip
    errors = [x for x in capsys.readouterr().err.splitlines() if x.startswith("error:")]
    assert code == 2 and len(errors) == 1
    assert "not implemented for the five-axis plant" in errors[0]
