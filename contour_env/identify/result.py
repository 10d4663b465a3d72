"""The result of :mod:`contour_env.identify`: :class:`AxisFit` per axis, the
:class:`Identification`, and the identified plant as a mapping and a plant file."""

from __future__ import annotations

import os
from dataclasses import dataclass, field

from .trace import Trace

PARAM_NAMES = ("mass", "viscous", "coulomb", "static", "stribeck_velocity", "current_loop_lag")
UNITS = {
    "mass": "kg",
    "viscous": "N s/m",
    "coulomb": "N",
    "static": "N",
    "stribeck_velocity": "m/s",
    "current_loop_lag": "s",
}


@dataclass
class AxisFit:
    """The identified model of one axis: ``values`` {name: value} (SI; names of
    :data:`PARAM_NAMES`), ``ci95`` {name: half-width or None when not determined},
    ``fitted`` (names fitted; the others fixed), ``delay_periods``, the cost of every delay
    searched on the screening windows (``delay_costs``; None where the regression found no
    positive mass) and of those fitted in full (``delay_full_costs``), ``force_limit_N``,
    ``encoder_resolution_m``, the normalised errors ``fit_error`` / ``holdout_error``
    ({"position", "velocity"}), the periodic forces found (``periodic``: "disturbance" and
    "ripple", each None or amplitude, frequency or period, phase), and the held-out (else the
    fitted) windows' measured and simulated signals for the plot (``plot``)."""

    axis: str
    values: dict
    ci95: dict
    fitted: tuple
    delay_periods: int
    delay_costs: dict
    delay_full_costs: dict
    force_limit_N: float
    encoder_resolution_m: float
    fit_error: dict
    holdout_error: dict
    n_windows: int
    window_steps: int
    periodic: dict = field(default_factory=dict)
    plot: dict = field(default_factory=dict, repr=False)
    # share of the fit's cost the friction curve removed (None: friction not asked for); below
    # 20 % friction is not identified (``fitted`` without it, its values 0)
    friction_cost_reduction: float | None = None

    def report(self) -> dict:
        return {
            "axis": self.axis,
            "parameters": {
                k: {"value": self.values[k], "ci95": self.ci95.get(k), "unit": UNITS[k]}
                for k in PARAM_NAMES
            },
            "fitted": list(self.fitted),
            "delay_periods": self.delay_periods,
            "delay_screening_costs": {str(k): v for k, v in self.delay_costs.items()},
            "delay_full_costs": {str(k): v for k, v in self.delay_full_costs.items()},
            "force_limit_N": self.force_limit_N,
            "encoder_resolution_m": self.encoder_resolution_m,
            "fit_error": self.fit_error,
            "holdout_error": self.holdout_error,
            "periodic": self.periodic,
            "friction_cost_reduction": self.friction_cost_reduction,
            "windows": self.n_windows,
            "window_steps": self.window_steps,
        }


@dataclass
class Identification:
    """The result of :func:`identify`: the trace, one :class:`AxisFit` per axis, settings and
    warnings."""

    trace: Trace
    axes: list
    settings: dict
    warnings: list = field(default_factory=list)
    # {axis: reason} of the axes fitted poorly (contour_env.identify.poor_fits)
    poor_fit: dict = field(default_factory=dict)

    def report(self) -> dict:
        return {
            "trace": self.trace.source,
            "rows": self.trace.n_rows,
            "servo_period_s": self.trace.servo_period_s,
            "settings": self.settings,
            "axes": [a.report() for a in self.axes],
            "warnings": list(self.warnings),
            "poor_fit": dict(self.poor_fit),
            "plant": plant_mapping(self),
        }


def plant_mapping(ident: Identification, *, name: str = "identified", input_kind="force") -> dict:
    """The identified plant as a mapping of parameters (``params_from_mapping``'s keys): what
    ``plant.json`` holds, loadable as ``plant=`` of ``gym.make`` and ``--plant`` of the CLI."""
    fits = ident.axes
    lag = [f.values["current_loop_lag"] for f in fits]
    T = ident.trace.servo_period_s
    # a lag under 2 % of the period is no lag the trace can tell from none
    lag = [x if x >= 0.02 * T else 0.0 for x in lag]
    delayed = sum(f.delay_periods >= 1 for f in fits) * 2 >= len(fits)
    static = [max(f.values["static"], f.values["coulomb"]) for f in fits]
    dist = [f.periodic.get("disturbance") for f in fits]
    rip = [f.periodic.get("ripple") for f in fits]
    return {
        "name": name,
        "axes": [f.axis for f in fits],
        "mass": [f.values["mass"] for f in fits],
        "viscous": [f.values["viscous"] for f in fits],
        "coulomb": [f.values["coulomb"] for f in fits],
        "static": static,
        "stribeck_velocity": [f.values["stribeck_velocity"] for f in fits],
        "current_loop_time_constant": lag,
        "computation_delay": bool(delayed),
        "disturbance_amplitude": [d["amplitude_N"] if d else 0.0 for d in dist],
        "disturbance_frequency": [d["frequency_hz"] if d else 0.0 for d in dist],
        "ripple_amplitude": [r["amplitude_N"] if r else 0.0 for r in rip],
        "ripple_period": [r["period_m"] if r else 0.03 for r in rip],
        "force_limit": [f.force_limit_N for f in fits],
        "encoder_resolution": [f.encoder_resolution_m for f in fits],
        "servo_period": float(f"{T:.12g}"),
        "input_kind": input_kind,
        **workspace_of(ident.trace),
        "notes": (
            f"identified by contour-env identify from {os.path.basename(ident.trace.source)} "
            f"({ident.trace.n_rows} samples); delays {[f.delay_periods for f in fits]} servo "
            "periods; periodic forces (disturbance, ripple) with their amplitude and frequency "
            "only, at the model's fixed phase; no structural mode (not identified)"
            + "".join(f"; POOR FIT, {why}" for why in ident.poor_fit.values())
        ),
    }


# the parts a machine runs lie well inside what its excitation reached: the training feeds
# are 1/100 … 1/10 of the trace's top speed and the parts' acceleration 1/10 of its 99th
# percentile (on the friction table's excitation: 5.8–58 mm/s and 0.8 m/s², against the
# named cases' 5–40 mm/s and 0.5 m/s²); edit them in plant.json to match your parts
FEED_FRACTIONS = (0.01, 0.1)
ACCEL_FRACTION = 0.1
SMOOTH_S = 0.02  # the speed and acceleration are read over 20 ms (the encoder's noise is not)


def workspace_of(trace: Trace) -> dict:
    """``travel`` (half the stroke per axis, m), ``feed_range`` (m/s) and ``max_acceleration``
    (m/s²) of the parts a machine with this trace runs, the keys of a plant file that
    ``contour-env train --plant`` draws its training parts within (see FEED_FRACTIONS)."""
    import numpy as np

    T = trace.servo_period_s
    y = trace.position
    travel = [max(float(np.ptp(y[:, j])) / 2.0, 1e-4) for j in range(y.shape[1])]
    k = max(1, int(round(SMOOTH_S / T)))
    box = np.ones(k) / k
    v = np.column_stack(
        [np.convolve(np.diff(y[:, j]) / T, box, "valid") for j in range(y.shape[1])]
    )
    speed = np.linalg.norm(v, axis=1)
    top = float(np.max(speed)) if speed.size else 0.0
    acc = np.abs(np.diff(v, axis=0)) / T
    a99 = float(np.percentile(acc, 99)) if acc.size else 0.0
    top = min(max(top, 1e-3), 10.0)
    return {
        "travel": [min(t, 10.0) for t in travel],
        "feed_range": [FEED_FRACTIONS[0] * top, FEED_FRACTIONS[1] * top],
        "max_acceleration": min(max(ACCEL_FRACTION * a99, 1e-3), 1000.0),
    }


def write_plant(path, ident: Identification, **kw):
    """Write :func:`plant_mapping` as JSON, atomically; it is checked by loading it first."""
    from ..io import atomic_write_json
    from ..plants.file_schema import params_from_mapping

    mapping = plant_mapping(ident, **kw)
    params_from_mapping(mapping)
    return atomic_write_json(path, mapping)
