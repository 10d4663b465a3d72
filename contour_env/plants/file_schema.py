"""What a plant file (``plant.json``, or the mapping given as ``plant=``) may hold: each key,
its unit and its range (:data:`PLANT_KEYS`, checked by :func:`check_plant_mapping` through
:func:`contour_env.schema.check_object`; the table in docs/FILES.md is generated from it).

The ranges of the physical parameters are :data:`contour_env.plants.params.PARAM_RANGES`.
``travel``, ``feed_range`` and ``max_acceleration`` describe what the machine's trace covered
(``contour-env identify`` writes them): ``contour-env train --plant plant.json`` draws its
training parts within them (:func:`agents.rl.families.plant_ranges`).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..schema import FileFormatError, Key, check_object
from .params import (
    INPUT_KINDS,
    MAPPING_KEYS,
    PARAM_RANGES,
    WORKSPACE_FIELDS,
    PlantParams,
    check_param_ranges,
)

_DOCS = {
    "mass": ("kg", "moving mass m per axis (rotary: J/ℓ²; velocity-command drive: τ/K)"),
    "viscous": ("N s/m", "viscous friction b"),
    "coulomb": ("N", "Coulomb friction level"),
    "static": ("N", "static (break-away) friction, ≥ coulomb (default: coulomb)"),
    "stribeck_velocity": ("m/s", "Stribeck velocity v_s (default 0.01)"),
    "ripple_amplitude": ("N", "position-periodic force ripple amplitude"),
    "ripple_period": ("m", "its period in position (default 0.03)"),
    "disturbance_amplitude": ("N", "periodic disturbance amplitude A"),
    "disturbance_frequency": ("Hz", "its frequency"),
    "force_limit": ("N", "actuator saturation; the env's action 1.0 is this force"),
    "encoder_resolution": ("m", "encoder count (0: ideal measurement)"),
    "servo_period": ("s", "the servo period T (one number)"),
    "current_loop_time_constant": ("s", "first-order current-loop lag (0: none)"),
    "structural_stiffness": ("N/m", "two-mass axial stiffness (0: rigid axis)"),
    "structural_damping": ("N s/m", "two-mass damping"),
}

TRAVEL_RANGE_M = (0.0, 10.0)
MAX_FEED_RANGE_M_S = (0.0, 10.0)
MAX_ACCEL_RANGE_M_S2 = (0.0, 1000.0)


def _physical_keys() -> list:
    keys = []
    for plain, field_name in MAPPING_KEYS.items():
        unit, doc = _DOCS[plain]
        lo, hi = PARAM_RANGES[field_name]
        keys.append(
            Key(
                plain,
                "number",
                unit,
                lo,
                hi,
                per_axis=plain != "servo_period",
                required=plain in ("mass", "force_limit", "servo_period"),
                doc=doc,
            )
        )
    return keys


PLANT_KEYS = (
    Key("name", "string", doc='the plant\'s name (default "custom"; agents are bound to it)'),
    Key("axes", "strings", doc='2 or 3 axis names (default ["x", "y"])'),
    *_physical_keys(),
    Key("computation_delay", "bool", doc="command applied one servo period after it is computed"),
    Key(
        "load_mass_fraction",
        "number",
        "",
        *PARAM_RANGES["load_mass_fraction"],
        per_axis=True,
        doc="share of the mass on the load side of the two-mass model (default 0.5)",
    ),
    Key("input_kind", "choice", choices=INPUT_KINDS, doc="what the command is (default force)"),
    Key(
        "friction_substeps",
        "integer",
        "",
        *PARAM_RANGES["friction_substeps"],
        doc="substeps per servo period near velocity reversals (default 20)",
    ),
    Key("notes", "string", doc="where the numbers come from"),
    Key(
        "controller_gains",
        "object",
        nullable=True,
        doc="default gains tuned for the plant (`contour-env tune`): "
        '{"pd": {"bandwidth_rad_s": ω}, "ccc": {"W_p": …, "W_i": …, "W_d": …}}',
    ),
    Key(
        "travel",
        "number",
        "m",
        *TRAVEL_RANGE_M,
        lo_open=True,
        per_axis=True,
        nullable=True,
        doc="half the stroke each axis may use about its centre (identify: from the trace); "
        "training parts are drawn within it",
    ),
    Key(
        "feed_range",
        "numbers",
        "m/s",
        *MAX_FEED_RANGE_M_S,
        lo_open=True,
        nullable=True,
        doc="[low, high] programmed feeds of the machine's parts (identify: 1/100 and 1/10 of "
        "the trace's top speed); the training feeds",
    ),
    Key(
        "max_acceleration",
        "number",
        "m/s²",
        *MAX_ACCEL_RANGE_M_S2,
        lo_open=True,
        nullable=True,
        doc="the feed profile's acceleration limit of training parts (identify: 1/10 of the "
        "trace's 99th-percentile acceleration)",
    ),
)
# the full field names of PlantParams are accepted for the physical keys (mass_kg = mass …)
FIELD_ALIASES = {
    field_name: plain for plain, field_name in {**MAPPING_KEYS, **WORKSPACE_FIELDS}.items()
}
WORKSPACE_KEYS = ("travel", "feed_range", "max_acceleration")


def check_plant_mapping(mapping, file: str = "plant") -> dict:
    """``mapping`` (a plant file's content) checked against :data:`PLANT_KEYS`, with the
    full field names (``mass_kg``, …) renamed to the plain ones; FileFormatError naming
    ``file``, the key, the value and the allowed range otherwise. Returns the renamed copy."""
    if not hasattr(mapping, "items"):
        check_object(mapping, PLANT_KEYS, file)  # raises: not a JSON object
    out: dict = {}
    for key, value in mapping.items():
        plain = FIELD_ALIASES.get(key, "axes" if key == "axis_names" else key)
        if plain in out:
            raise FileFormatError(f"{file}: {plain!r} given twice (as {plain!r} and {key!r})")
        out[plain] = value
    axes = out.get("axes")
    n_axes = None
    if isinstance(axes, (list, tuple)):
        if not 2 <= len(axes) <= 3 or not all(isinstance(a, str) for a in axes):
            raise FileFormatError(
                f'{file}: axes: must be a list of 2 or 3 axis names such as ["x", "y"], got '
                f"{list(axes)!r}"
            )
        if len(set(axes)) != len(axes):
            raise FileFormatError(f"{file}: axes: names must differ, got {list(axes)!r}")
        n_axes = len(axes)
    elif axes is None and "axes" not in out:
        n_axes = 2
    check_object(out, PLANT_KEYS, file, n_axes=n_axes)
    return out


def params_from_mapping(mapping: Mapping, file: str = "plant") -> PlantParams:
    """Build custom plant parameters from a plain mapping (a plant file's content).

    Keys (per-axis values are lists, scalars apply to every axis), SI units:
    ``axes`` (list of names, default ``["x", "y"]``), ``mass`` (kg, required), ``viscous``
    (N s/m), ``coulomb`` / ``static`` (N), ``stribeck_velocity`` (m/s), ``ripple_amplitude``
    (N), ``ripple_period`` (m), ``disturbance_amplitude`` (N), ``disturbance_frequency`` (Hz),
    ``force_limit`` (N, required), ``encoder_resolution`` (m), ``servo_period`` (s, required),
    ``current_loop_time_constant`` (s), ``computation_delay`` (bool), ``structural_stiffness``
    (N/m), ``structural_damping`` (N s/m), ``load_mass_fraction``, ``input_kind``,
    ``friction_substeps``, ``name``, ``notes``, ``controller_gains`` (tuned controller defaults,
    :mod:`contour_env.plants.gains`), ``travel`` (m), ``feed_range`` (m/s),
    ``max_acceleration`` (m/s²). The full field names of :class:`PlantParams` work too.
    Every key is checked against :data:`PLANT_KEYS` (its range of
    :data:`contour_env.plants.params.PARAM_RANGES`): a ``FileFormatError`` (ValueError)
    naming ``file``, the key, the value and the range otherwise.
    """
    plain = check_plant_mapping(mapping, file)
    kw: dict = {}
    for key, value in plain.items():
        if key == "axes":
            kw["axis_names"] = tuple(value)
        elif value is None:
            continue  # a nullable key not given
        else:
            kw[MAPPING_KEYS.get(key, WORKSPACE_FIELDS.get(key, key))] = value
    kw.setdefault("axis_names", ("x", "y"))
    n = len(kw["axis_names"])
    kw.setdefault("name", "custom")
    for key, default in (
        ("viscous_Ns_m", 0.0),
        ("coulomb_N", 0.0),
        ("static_N", None),
        ("stribeck_velocity_m_s", 0.01),
        ("ripple_amplitude_N", 0.0),
        ("ripple_period_m", 0.03),
        ("disturbance_amplitude_N", 0.0),
        ("disturbance_frequency_hz", 0.0),
        ("encoder_resolution_m", 0.0),
    ):
        if key not in kw:
            kw[key] = kw["coulomb_N"] if key == "static_N" else np.full(n, default)
    try:
        return check_param_ranges(PlantParams(**kw), file)
    except FileFormatError:
        raise
    except ValueError as exc:
        raise FileFormatError(f"{file}: {exc}") from None
