"""agents.repeated_batch.error_growing: a jump, or a sustained rise made of small steps."""

import pytest

from agents.repeated_batch import (
    GROWTH_ALLOWANCE_UM,
    GROWTH_TOLERANCE,
    SUSTAINED_RISE_STEPS,
    error_growing,
)


def flags(history):
    return [error_growing(history[: i + 1]) for i in range(len(history))]


def test_a_staircase_of_small_steps_is_flagged_once_it_adds_up():
    # + 3 % per trial: every step is within the 5 % + 0.05 µm a single jump may take
    stairs = [10.0 * 1.03**i for i in range(8)]
    assert all(
        b <= GROWTH_TOLERANCE * a + GROWTH_ALLOWANCE_UM
        for a, b in zip(stairs[:-1], stairs[1:], strict=True)
    )
    got = flags(stairs)
    assert got[:SUSTAINED_RISE_STEPS] == [False] * SUSTAINED_RISE_STEPS
    assert all(got[SUSTAINED_RISE_STEPS:])  # from the 4th trial on: 1.03³ = 1.093 > 1.05


def test_a_staircase_with_flat_treads_is_flagged_too():
    # equal values are "not lower": a rise in steps with a pause still adds up
    assert flags([5.0, 5.2, 5.2, 5.45, 5.45, 5.7])[-1]


def test_a_jump_is_flagged_at_once_and_a_failed_trial_always():
    assert flags([10.0, 11.0]) == [False, True]
    assert error_growing([10.0, None])
    assert not error_growing([None, 10.0])  # nothing to compare with
    assert not error_growing([])


@pytest.mark.parametrize(
    "history",
    [
        [100.0, 40.0, 12.0, 5.0, 2.0, 1.1, 1.0],  # learning
        [1.00, 1.02, 0.99, 1.03, 1.01, 1.04, 1.02],  # noise at the converged floor
        [10.0, 10.2, 10.4, 10.3, 10.5, 10.7, 10.6],  # a fall in every window of 3 changes
        [0.20, 0.21, 0.22, 0.23, 0.24],  # below the 0.05 µm allowance
    ],
)
def test_learning_and_noise_are_not_growth(history):
    assert not any(flags(history))


def test_an_earlier_failed_trial_does_not_start_a_rise():
    assert not error_growing([None, 10.0, 10.3, 10.6])
    assert error_growing([None, 10.0, 10.3, 10.6, 10.9])
