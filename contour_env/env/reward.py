"""The reward: what a step of the env pays, for both plant families (compiled, inlined into
the kernels' step; the weights are :class:`~contour_env.env.core.EnvConfig`'s).

A running step pays minus the weighted true contour error, lag and effort::

    r = −(w_contour · ε + w_lag · |e_t|) / ε_scale − w_effort · Σ aᵢ² / A

with ε the distance from the tool to the path (m; on the five-axis machine ε + L·θ, the
tool-tip contour error plus the orientation error θ through the lever L, and e_t the tool
tip's tracking error), e_t the tracking error along the path tangent (m), a the action in
[−1, 1] per axis and A the axis count. Doing nothing does not win: the contour error of a
machine that does not follow the path grows until a guard ends the episode.

A step that a guard ends (contour error, tracking error, non-finite state) pays the guard
penalty P for itself and for every step the early end skips (feed-drive kernel: at least one
step, should a caller step past the end), so ending an episode early never pays more than
running it: :func:`guard_reward`.

The functions take scalars, not the configuration arrays, so that each kernel's expression —
and its floating-point order, which the recorded results depend on to the bit — stays as the
kernel had it.
"""

from __future__ import annotations

from numba import njit


@njit(cache=True, inline="always")
def feed_drive_reward(w_contour, w_lag, w_effort, inv_scale, inv_axes, contour, lag, effort):
    """r = −(w_contour ε + w_lag |lag|) / ε_scale − w_effort Σa² / A for a running step of the
    feed-drive plants (``inv_scale`` = 1 / ε_scale, ``inv_axes`` = 1 / A, ``effort`` Σa²)."""
    return -(w_contour * contour + w_lag * abs(lag)) * inv_scale - w_effort * effort * inv_axes


@njit(cache=True, inline="always")
def five_axis_reward(w_contour, w_lag, w_effort, inv_scale, contour, lever, orient, track, effort):
    """r = −(w_contour (ε + L θ) + w_lag e_tip) / ε_scale − w_effort Σa² / 5 for a running step
    of the five-axis machine (ε m, θ rad, L m, e_tip the tool tip's tracking error m)."""
    return (
        -(w_contour * (contour + lever * orient) + w_lag * track) * inv_scale
        - w_effort * effort / 5.0
    )


@njit(cache=True, inline="always")
def guard_reward(penalty, steps_charged):
    """−P · n for a step a guard ends, n the steps it is charged for (itself and the ones the
    early end skips)."""
    return -penalty * steps_charged
