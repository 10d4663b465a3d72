"""The annealed learning rate against its closed form."""

import math

import pytest

from agents.rl.schedule import AnnealedRate


def test_the_rate_is_geometric_in_the_fraction_of_the_run():
    r = AnnealedRate(3e-4, 3e-5)
    assert r(1.0) == 3e-4  # before any fraction is set: the start rate
    for f in (0.0, 0.25, 0.5, 1.0):
        assert r.at(f) == pytest.approx(3e-4 * math.exp(f * math.log(0.1)), rel=1e-12)
        assert r(0.123) == r.value  # sb3's progress argument is not used
    assert r.at(2.0) == pytest.approx(3e-5) and r.at(-1.0) == pytest.approx(3e-4)


def test_no_final_rate_is_a_constant_and_bad_rates_are_refused():
    r = AnnealedRate(1e-3, None)
    assert r.at(0.7) == 1e-3
    with pytest.raises(ValueError, match="learning_rate_final"):
        AnnealedRate(1e-3, 2e-3)
    with pytest.raises(ValueError, match="learning_rate"):
        AnnealedRate(0.0, None)
