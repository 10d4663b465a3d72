"""Analytical checks of the plants and controllers against the papers.

``jee``: Jee & Lee 2007's discrete-time axis model (eq. 9), the Jury stability range of the
P axial gain (eqs. 16–17) confirmed by simulation, and the steady-state contour and tracking
error on a circle (eqs. 20–31) predicted and simulated.

``jee_design``: the same with the cross-coupling controller (eqs. 8, 16, 21, 32): stable
regions of (C_P, C_I) and (C_P, C_D) (Figs. 4a/4b) and the steady state with cross-coupling
predicted (eq. 21 and the controller law) and simulated, on the paper's ideal model and the
realistic one (computation delay). The design chart (Fig. 5), the recommended gains, the
report and the plot run the package's controllers: they are in the application,
:mod:`contour_env.app.jee_chart`.
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
from .jee_design import (
    cross_coupling_region,
    simulate_cc_circle,
    steady_state_cc_circle,
    steady_state_cc_matched,
)

__all__ = [
    "DEFAULT_FEEDRATES_M_S",
    "AxisModel",
    "axial_gain_limit",
    "axis_models",
    "cross_coupling_region",
    "discretize_axis",
    "format_stability_report",
    "jury_conditions",
    "jury_stable",
    "simulate_cc_circle",
    "simulate_circle",
    "simulate_step_response",
    "stability_report",
    "steady_state_cc_circle",
    "steady_state_cc_matched",
    "steady_state_prediction",
]
