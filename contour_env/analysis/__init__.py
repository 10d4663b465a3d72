"""Analytical checks of the plants and controllers against the papers.

``jee``: Jee & Lee 2007's discrete-time axis model (eq. 9), the Jury stability range of the
P axial gain (eqs. 16–17) confirmed by simulation, and the steady-state contour and tracking
error on a circle (eqs. 20–31) predicted and simulated.
"""

from .jee import (
    DEFAULT_FEEDRATES_M_S,
    AxisModel,
    axial_gain_limit,
    axis_models,
    discretize_axis,
    format_stability_report,
    jury_conditions,
    jury_stable,
    simulate_circle,
    simulate_step_response,
    stability_report,
    steady_state_prediction,
)

__all__ = [
    "DEFAULT_FEEDRATES_M_S",
    "AxisModel",
    "axial_gain_limit",
    "axis_models",
    "discretize_axis",
    "format_stability_report",
    "jury_conditions",
    "jury_stable",
    "simulate_circle",
    "simulate_step_response",
    "stability_report",
    "steady_state_prediction",
]
