"""Feed-drive plant parameters: the per-axis model of REFERENCE §1 and the effects a textbook
model leaves out (delay, current-loop lag, friction, ripple, nominal/true mismatch, two-mass mode).

Per axis i (SI units):

    m_i ẍ_i + b_i ẋ_i + f_friction,i(ẋ_i) + f_ripple,i(x_i) + d_i(t) = sat(u_i)

    f_friction(v) = (f_c + (f_s − f_c) exp(−(v / v_s)²)) sgn(v)      (Stribeck, Chen & Lee 2020)
    f_ripple(x)   = A_r sin(2π x / P_r)                               (position-periodic)
    d(t)          = A_d sin(2π f_d t + φ_i)                           (bounded disturbance)
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace

import numpy as np

from .gains import check_controller_gains

INPUT_KINDS = ("force", "velocity-command")


def _axis_array(
    name: str, value, n_axes: int, *, positive=False, nonneg=False, member: str = "axis"
) -> np.ndarray:
    """``value`` (a number, or one per axis) as a finite float (n_axes,) array, > 0 or >= 0
    everywhere when asked; ``member`` names an entry in messages ("axis"; "joint" for the
    five-axis plant)."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(
            f"{name}: expected a number or {n_axes} per-{member} numbers, got {value!r}"
        ) from None
    if arr.ndim == 0:
        arr = np.full(n_axes, float(arr))
    if arr.shape != (n_axes,):
        raise ValueError(
            f"{name}: expected a scalar or {n_axes} per-{member} values, got shape {arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: values must be finite, got {arr.tolist()}")
    if positive and np.any(arr <= 0):
        raise ValueError(f"{name}: must be > 0 on every {member}, got {arr.tolist()}")
    if nonneg and np.any(arr < 0):
        raise ValueError(f"{name}: must be >= 0 on every {member}, got {arr.tolist()}")
    return arr


@dataclass(frozen=True)
class PlantParams:
    """Physical parameters of an n-axis feed drive, one value per axis (SI units).

    Attributes
    ----------
    name : str
        Plant name (catalogue key or ``"custom"``).
    axis_names : tuple of str
        e.g. ``("x", "y")``; its length is the number of axes (2 or 3).
    mass_kg : (n,) float > 0
        Moving mass m (for a rotary axis: J/ℓ²; for a velocity-command drive: τ/K).
    viscous_Ns_m : (n,) float >= 0
        Viscous friction b (rotary: B/ℓ²; velocity-command drive: 1/K).
    coulomb_N, static_N : (n,) float >= 0
        Coulomb and static (breakaway) friction; static >= coulomb. Zero: no friction.
    stribeck_velocity_m_s : (n,) float > 0
        Stribeck velocity v_s.
    ripple_amplitude_N : (n,) float >= 0, ripple_period_m : (n,) float > 0
        Position-periodic force ripple.
    disturbance_amplitude_N : (n,) float >= 0, disturbance_frequency_hz : (n,) float >= 0
        Deterministic bounded disturbance d(t) = A sin(2π f t + φ_i), φ_i = i·π/2.
    force_limit_N : (n,) float > 0
        Actuator saturation |sat(u)| <= limit. The env's action 1.0 equals this limit.
    encoder_resolution_m : (n,) float >= 0
        Quantisation step of the position measurement (0: ideal measurement).
    servo_period_s : float > 0
        Controller sampling period T; the plant input is held over T (zero-order hold).
    input_kind : "force" or "velocity-command"
        What the actuator command is (Jee 2007's drives take a velocity command; with
        m = τ/K, b = 1/K the same equation holds with u in K-normalised units).
    current_loop_time_constant_s : (n,) float >= 0
        First-order lag between command and applied force (0: none).
    computation_delay : bool
        Command computed at sample k is applied from sample k+1 (one servo period).
    structural_stiffness_N_m : (n,) float >= 0
        Axial two-mass model: 0 disables it; >0 splits the mass into a drive (motor) side
        and a load (table/tool point) side joined by this stiffness. The encoder then reads
        the drive side (semi-closed loop: a rotary encoder on a ball screw, or the read head
        on a direct drive's carriage), while the contour error is that of the load side.
    structural_damping_Ns_m : (n,) float >= 0, load_mass_fraction : (n,) float in (0, 1)
        Damping of that spring and the share of ``mass_kg`` on the load side.
    friction_substeps : int >= 1
        Substeps per servo period used near velocity reversals (stick–slip treatment).
    notes : str
        Where the numbers come from.
    controller_gains : dict, optional
        Controller defaults tuned for this plant (``contour-env tune``;
        :mod:`contour_env.plants.gains`), e.g. ``{"pd": {"bandwidth_rad_s": 80.0}}``.
    travel_m : (n,) float > 0, optional; feed_range_m_s : (lo, hi) m/s, 0 < lo < hi, optional;
    max_acceleration_m_s2 : float > 0, optional
        The parts the machine runs (``contour-env identify`` writes them into a plant file from
        the trace): half the stroke per axis, the programmed feeds, the feed profile's
        acceleration limit. Only training on a plant file reads them
        (:func:`agents.rl.families.plant_ranges`); None on the named plants, whose training
        ranges are tabulated.

    Custom parameters (a mapping, the env's ``plant_params``) must lie in the physically
    meaningful ranges of :data:`PARAM_RANGES` (mass 1e-6..1e6 kg, force limit 1e-6..1e7 N,
    servo period 1e-6..0.1 s, ...); see :func:`check_param_ranges`.
    """

    name: str
    axis_names: tuple
    mass_kg: np.ndarray
    viscous_Ns_m: np.ndarray
    coulomb_N: np.ndarray
    static_N: np.ndarray
    stribeck_velocity_m_s: np.ndarray
    ripple_amplitude_N: np.ndarray
    ripple_period_m: np.ndarray
    disturbance_amplitude_N: np.ndarray
    disturbance_frequency_hz: np.ndarray
    force_limit_N: np.ndarray
    encoder_resolution_m: np.ndarray
    servo_period_s: float
    input_kind: str = "force"
    current_loop_time_constant_s: np.ndarray = field(default=None)
    computation_delay: bool = False
    structural_stiffness_N_m: np.ndarray = field(default=None)
    structural_damping_Ns_m: np.ndarray = field(default=None)
    load_mass_fraction: np.ndarray = field(default=None)
    friction_substeps: int = 20
    notes: str = ""
    controller_gains: dict = field(default=None)
    travel_m: np.ndarray | None = None
    feed_range_m_s: tuple | None = None
    max_acceleration_m_s2: float | None = None

    def __post_init__(self):
        if isinstance(self.axis_names, str) or not isinstance(self.axis_names, (tuple, list)):
            raise ValueError(
                f"axis_names (axes): a list of 2 or 3 axis names such as ['x', 'y'], "
                f"got {self.axis_names!r}"
            )
        n = len(self.axis_names)
        if n not in (2, 3):
            raise ValueError(f"axis_names: a plant has 2 or 3 axes, got {n}")
        s = object.__setattr__
        s(self, "axis_names", tuple(str(a) for a in self.axis_names))
        zeros = np.zeros(n)
        spec = {
            "mass_kg": dict(positive=True),
            "viscous_Ns_m": dict(nonneg=True),
            "coulomb_N": dict(nonneg=True),
            "static_N": dict(nonneg=True),
            "stribeck_velocity_m_s": dict(positive=True),
            "ripple_amplitude_N": dict(nonneg=True),
            "ripple_period_m": dict(positive=True),
            "disturbance_amplitude_N": dict(nonneg=True),
            "disturbance_frequency_hz": dict(nonneg=True),
            "force_limit_N": dict(positive=True),
            "encoder_resolution_m": dict(nonneg=True),
            "current_loop_time_constant_s": dict(nonneg=True),
            "structural_stiffness_N_m": dict(nonneg=True),
            "structural_damping_Ns_m": dict(nonneg=True),
            "load_mass_fraction": dict(positive=True),
        }
        defaults = {
            "current_loop_time_constant_s": zeros,
            "structural_stiffness_N_m": zeros,
            "structural_damping_Ns_m": zeros,
            "load_mass_fraction": np.full(n, 0.5),
        }
        for key, kw in spec.items():
            value = getattr(self, key)
            if value is None:
                value = defaults[key]
            s(self, key, _axis_array(key, value, n, **kw))
        if np.any(self.static_N < self.coulomb_N):
            raise ValueError(
                f"static_N must be >= coulomb_N on every axis, got static {self.static_N.tolist()} "
                f"and coulomb {self.coulomb_N.tolist()}"
            )
        if np.any(self.load_mass_fraction >= 1.0):
            raise ValueError("load_mass_fraction: must be in (0, 1)")
        if isinstance(self.servo_period_s, bool) or not isinstance(
            self.servo_period_s, (int, float, np.integer, np.floating)
        ):
            raise ValueError(
                f"servo_period_s: must be a number > 0 (seconds), got {self.servo_period_s!r}"
            )
        if not (math.isfinite(self.servo_period_s) and self.servo_period_s > 0):
            raise ValueError(f"servo_period_s: must be > 0 (seconds), got {self.servo_period_s}")
        s(self, "servo_period_s", float(self.servo_period_s))
        if self.input_kind not in INPUT_KINDS:
            raise ValueError(f"input_kind: must be one of {INPUT_KINDS}, got {self.input_kind!r}")
        fs = self.friction_substeps
        if isinstance(fs, bool) or not isinstance(fs, (int, np.integer)) or fs < 1:
            raise ValueError(f"friction_substeps: must be an integer >= 1, got {fs!r}")
        if not isinstance(self.computation_delay, (bool, np.bool_)):
            raise ValueError(
                f"computation_delay: must be True or False, got {self.computation_delay!r}"
            )
        s(self, "computation_delay", bool(self.computation_delay))
        s(self, "controller_gains", check_controller_gains(self.controller_gains))
        self._check_workspace(n)
        s(self, "friction_substeps", int(self.friction_substeps))
        for arr_name in spec:
            getattr(self, arr_name).setflags(write=False)

    def _check_workspace(self, n: int) -> None:
        s = object.__setattr__
        if self.travel_m is not None:
            s(self, "travel_m", _axis_array("travel_m", self.travel_m, n, positive=True))
            self.travel_m.setflags(write=False)
        if self.feed_range_m_s is not None:
            fr = _axis_array("feed_range_m_s", self.feed_range_m_s, 2, positive=True, member="end")
            if not fr[0] < fr[1]:
                raise ValueError(f"feed_range_m_s: [low, high] with low < high, got {fr.tolist()}")
            s(self, "feed_range_m_s", (float(fr[0]), float(fr[1])))
        v = self.max_acceleration_m_s2
        if v is not None:
            ok = isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)
            if not (ok and math.isfinite(v) and v > 0):
                raise ValueError(f"max_acceleration_m_s2: must be a number > 0, got {v!r}")
            s(self, "max_acceleration_m_s2", float(v))

    @property
    def n_axes(self) -> int:
        return len(self.axis_names)

    @property
    def has_friction(self) -> bool:
        return bool(np.any(self.static_N > 0) or np.any(self.coulomb_N > 0))

    @property
    def has_structural_mode(self) -> bool:
        return bool(np.any(self.structural_stiffness_N_m > 0))

    def replace(self, **changes) -> PlantParams:
        """A copy with some fields changed (validated again)."""
        return replace(self, **changes)

    def scaled(self, factors: Mapping[str, float | np.ndarray]) -> PlantParams:
        """A copy with fields multiplied by factors (scalar or per axis), e.g. for mismatch."""
        changes = {}
        for key, f in factors.items():
            if key not in PER_AXIS_FIELDS:
                raise ValueError(
                    f"scaled: unknown per-axis parameter {key!r}; known: {PER_AXIS_FIELDS}"
                )
            changes[key] = getattr(self, key) * np.asarray(f, dtype=np.float64)
        return self.replace(**changes)

    def to_dict(self) -> dict:
        out = {}
        for f in fields(self):
            v = getattr(self, f.name)
            out[f.name] = v.tolist() if isinstance(v, np.ndarray) else v
        out["axis_names"] = list(self.axis_names)
        return out


PER_AXIS_FIELDS = (
    "mass_kg",
    "viscous_Ns_m",
    "coulomb_N",
    "static_N",
    "stribeck_velocity_m_s",
    "ripple_amplitude_N",
    "ripple_period_m",
    "disturbance_amplitude_N",
    "disturbance_frequency_hz",
    "force_limit_N",
    "encoder_resolution_m",
    "current_loop_time_constant_s",
    "structural_stiffness_N_m",
    "structural_damping_Ns_m",
    "load_mass_fraction",
)

# Physically meaningful ranges [low, high] (SI units, inclusive) of custom parameters: from a
# 0.1 g velocity-command drive to a 1000 t gantry. Every named plant lies inside them. Outside,
# the dynamics overflow float64 within a step (e.g. force_limit 1e308 N or mass 1e-300 kg), so
# custom parameters (a mapping, ``plant_params``) are checked against them by
# :func:`check_param_ranges`.
PARAM_RANGES = {
    "mass_kg": (1e-6, 1e6),
    "viscous_Ns_m": (0.0, 1e7),
    "coulomb_N": (0.0, 1e6),
    "static_N": (0.0, 1e6),
    "stribeck_velocity_m_s": (1e-6, 10.0),
    "ripple_amplitude_N": (0.0, 1e6),
    "ripple_period_m": (1e-6, 10.0),
    "disturbance_amplitude_N": (0.0, 1e6),
    "disturbance_frequency_hz": (0.0, 1e4),
    "force_limit_N": (1e-6, 1e7),
    "encoder_resolution_m": (0.0, 1e-3),
    "current_loop_time_constant_s": (0.0, 1.0),
    "structural_stiffness_N_m": (0.0, 1e12),
    "structural_damping_Ns_m": (0.0, 1e9),
    "load_mass_fraction": (0.01, 0.99),
    "servo_period_s": (1e-6, 0.1),
    "friction_substeps": (1, 1000),
}


def check_param_ranges(params: PlantParams, label: str = "plant") -> PlantParams:
    """Raise ValueError naming the parameter and its allowed range if a value of ``params`` is
    outside :data:`PARAM_RANGES`; returns ``params``."""
    for key, (lo, hi) in PARAM_RANGES.items():
        arr = np.asarray(getattr(params, key), dtype=np.float64)
        if np.any(arr < lo) or np.any(arr > hi):
            raise ValueError(
                f"{label}: {key} must be in [{lo:g}, {hi:g}] on every axis, got {arr.tolist()}"
            )
    return params


# Keys accepted by ``params_from_mapping`` (plain names users type) -> field names.
MAPPING_KEYS = {
    "mass": "mass_kg",
    "viscous": "viscous_Ns_m",
    "coulomb": "coulomb_N",
    "static": "static_N",
    "stribeck_velocity": "stribeck_velocity_m_s",
    "ripple_amplitude": "ripple_amplitude_N",
    "ripple_period": "ripple_period_m",
    "disturbance_amplitude": "disturbance_amplitude_N",
    "disturbance_frequency": "disturbance_frequency_hz",
    "force_limit": "force_limit_N",
    "encoder_resolution": "encoder_resolution_m",
    "servo_period": "servo_period_s",
    "current_loop_time_constant": "current_loop_time_constant_s",
    "structural_stiffness": "structural_stiffness_N_m",
    "structural_damping": "structural_damping_Ns_m",
}
# the keys describing what the machine's trace covered -> field names
WORKSPACE_FIELDS = {
    "travel": "travel_m",
    "feed_range": "feed_range_m_s",
    "max_acceleration": "max_acceleration_m_s2",
}


def one_params_per_env(plant_params, cls, n_envs: int) -> list:
    """``plant_params`` as a list of n_envs items (each to be a ``cls``, checked by the
    caller); ValueError naming the parameter for a single item, a string or a wrong count."""
    name = cls.__name__
    if isinstance(plant_params, (cls, str, bytes)) or not hasattr(plant_params, "__len__"):
        raise ValueError(
            f"plant_params: a list of one {name} per env ({n_envs}), got "
            f"{type(plant_params).__name__}"
        )
    plant_params = list(plant_params)
    if len(plant_params) != n_envs:
        raise ValueError(f"plant_params: one {name} per env ({n_envs}), got {len(plant_params)}")
    return plant_params
