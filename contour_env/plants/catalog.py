"""Named plants: the papers' parameters (the *nominal* model controllers are given) and, per
plant, the documented set of effects the textbook model leaves out (the *true* plant).

``make_plant(name, ideal=False)`` returns a :class:`~contour_env.plants.model.Plant` with both.
With ``ideal=True`` the true plant equals the paper's model (textbook checks).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field, replace

import numpy as np

from .file_schema import params_from_mapping
from .from_file import is_plant_file, load_plant_file
from .params import PER_AXIS_FIELDS, PlantParams

# HSM2 x axis: rotary servo + leadscrew. Lee 2012 gives J, B in rotary units only; the lead
# ℓ = 4.4 mm/rad (≈ 27.6 mm/rev) reproduces the RMS torques of its Table 3 on cases I–III
# (REFERENCE §1): m_eq = J/ℓ², b_eq = B/ℓ², F = T/ℓ.
HSM2_LEAD_M_PER_RAD = 4.4e-3
HSM2_J_KGM2 = 0.05916
HSM2_B_NMS = 0.01725
HSM2_TORQUE_LIMIT_NM = 60.0


@dataclass(frozen=True)
class Effects:
    """What a real servo has that the textbook model does not (all switchable).

    computation_delay : command applied one servo period after it is computed.
    current_loop_time_constant_s : first-order force (current) loop lag, s, per axis.
    added_friction : extra Stribeck friction (coulomb_N, static_N, stribeck_velocity_m_s per
        axis) where the paper's model has none; None keeps the paper's friction.
    added_ripple : (amplitude_N, period_m) per axis, or None.
    mismatch : true = nominal × factor for these per-axis fields (e.g. mass_kg: [1.08, 0.94]).
    structural_mode_hz : axial two-mass mode frequency per axis (only with structural_mode=True).
    structural_damping_ratio : damping ratio of that mode.
    """

    computation_delay: bool = True
    current_loop_time_constant_s: tuple = ()
    added_friction: dict | None = None
    added_ripple: dict | None = None
    mismatch: dict = field(default_factory=dict)
    structural_mode_hz: tuple = ()
    structural_damping_ratio: float = 0.05

    def describe(self) -> dict:
        return {
            "computation_delay": self.computation_delay,
            "current_loop_time_constant_s": list(self.current_loop_time_constant_s),
            "added_friction": self.added_friction,
            "added_ripple": self.added_ripple,
            "mismatch": {k: list(v) for k, v in self.mismatch.items()},
            "structural_mode_hz": list(self.structural_mode_hz),
        }


def _hsm2() -> tuple[PlantParams, Effects]:
    lead = HSM2_LEAD_M_PER_RAD
    p = PlantParams(
        name="hsm2",
        axis_names=("x", "y"),
        mass_kg=[HSM2_J_KGM2 / lead**2, 1144.0],
        viscous_Ns_m=[HSM2_B_NMS / lead**2, 967.0],
        coulomb_N=0.0,
        static_N=0.0,
        stribeck_velocity_m_s=0.005,
        ripple_amplitude_N=0.0,
        ripple_period_m=0.048,
        disturbance_amplitude_N=0.0,
        disturbance_frequency_hz=0.0,
        force_limit_N=[HSM2_TORQUE_LIMIT_NM / lead, 6000.0],
        encoder_resolution_m=[2e-6, 1e-6],
        servo_period_s=1e-3,
        notes=(
            "Lee, Dixon & Ziegert 2012 HSM2: x rotary servo + leadscrew (J = 0.05916 kg m², "
            f"B = 0.01725 N m s/rad, lead {lead * 1e3:.1f} mm/rad, torque limit "
            f"{HSM2_TORQUE_LIMIT_NM:.0f} N m), y twin linear motors (m = 1144 kg, b = 967 N s/m, "
            "6 kN); 1 ms servo; encoders 2 µm / 1 µm."
        ),
    )
    eff = Effects(
        computation_delay=True,
        current_loop_time_constant_s=(0.5e-3, 0.5e-3),
        # hydrostatic guideways: small friction from the leadscrew nut, bearings and seals
        added_friction=dict(
            coulomb_N=[40.0, 15.0], static_N=[60.0, 20.0], stribeck_velocity_m_s=[0.005, 0.005]
        ),
        added_ripple=dict(amplitude_N=[0.0, 20.0], period_m=[0.048, 0.048]),
        mismatch=dict(mass_kg=(1.08, 0.94), viscous_Ns_m=(0.90, 1.10)),
        # not in the paper (ours): x, the leadscrew's axial mode; y, a twin-linear-motor
        # gantry of 1.1 t has no screw, its first mode is the gantry (table/tool point) against
        # the motor carriages that carry the read heads. 45 Hz so that the PD Lee ran on the
        # real machine at 1 ms (≈ 85 rad/s on this model, from Table 2's PD figures) is stable
        # with the mode, as it was on the machine; a 150 Hz mode is destabilised by the
        # one-period delay for any PD above ≈ 50 rad/s (agents.margins, structural_mode=True).
        structural_mode_hz=(60.0, 45.0),
    )
    return p, eff


def _jee() -> tuple[PlantParams, Effects]:
    K = np.array([121.0, 118.0, 83.0])
    tau = np.array([0.025, 0.03, 0.01])
    v_max = 1.0  # velocity-command limit, m/s
    p = PlantParams(
        name="jee-triaxial",
        axis_names=("x", "y", "z"),
        mass_kg=tau / K,
        viscous_Ns_m=1.0 / K,
        coulomb_N=0.0,
        static_N=0.0,
        stribeck_velocity_m_s=0.002,
        ripple_amplitude_N=0.0,
        ripple_period_m=0.03,
        disturbance_amplitude_N=0.0,
        disturbance_frequency_hz=0.0,
        force_limit_N=v_max / K,
        encoder_resolution_m=0.5e-6,
        servo_period_s=1e-3,
        input_kind="velocity-command",
        notes=(
            "Jee & Lee 2007 Table 1: velocity-loop-closed drives G(s) = K/(s(τs+1)), "
            "K = 121/118/83 1/s, τ = 25/30/10 ms, BLU 0.5 µm, T = 1 ms; common form m = τ/K, "
            "b = 1/K, so ẋ → K u at steady state (u in K-normalised velocity-command units, "
            "|K u| ≤ 1 m/s)."
        ),
    )
    eff = Effects(
        computation_delay=True,
        current_loop_time_constant_s=(),
        # residual friction behind the velocity loop, as the velocity drop it causes (2 mm/s)
        added_friction=dict(
            coulomb_N=list(0.002 / K), static_N=list(0.003 / K), stribeck_velocity_m_s=[0.002] * 3
        ),
        added_ripple=None,
        mismatch=dict(mass_kg=(1.10, 0.92, 1.05), viscous_Ns_m=(0.95, 1.05, 0.97)),
        structural_mode_hz=(),
    )
    return p, eff


def _linear_motor() -> tuple[PlantParams, Effects]:
    p = PlantParams(
        name="linear-motor",
        axis_names=("x", "y", "z"),
        mass_kg=6.2152,
        viscous_Ns_m=1.349e-10,
        coulomb_N=10.0,
        static_N=20.0,
        stribeck_velocity_m_s=0.1,
        ripple_amplitude_N=4.0,
        ripple_period_m=0.032,
        disturbance_amplitude_N=0.0,
        disturbance_frequency_hz=0.0,
        force_limit_N=300.0,
        encoder_resolution_m=0.1e-6,
        servo_period_s=1e-4,
        friction_substeps=10,
        notes=(
            "Chen & Lee 2020: m = 6.2152 kg, b = 1.349e-10 N s/m, Stribeck friction f_s = 20 N, "
            "f_c = 10 N, v_s = 0.1 m/s (standard (f_s − f_c) form), T = 0.1 ms. Force ripple "
            "(not given in the paper, chosen): 4 N amplitude, 32 mm period (a magnet pole "
            "pitch); force limit 300 N and 0.1 µm linear scale chosen."
        ),
    )
    eff = Effects(
        computation_delay=True,
        current_loop_time_constant_s=(0.1e-3,) * 3,
        added_friction=None,  # the paper's model already has Stribeck friction
        added_ripple=None,  # and force ripple
        mismatch=dict(mass_kg=(1.10, 0.93, 1.05), viscous_Ns_m=(1.0, 1.0, 1.0)),
        structural_mode_hz=(400.0, 400.0, 400.0),
    )
    return p, eff


def _friction_table() -> tuple[PlantParams, Effects]:
    p = PlantParams(
        name="friction-table",
        axis_names=("x", "y"),
        mass_kg=[42.0, 36.0],
        viscous_Ns_m=[60.0, 50.0],
        coulomb_N=[25.0, 20.0],
        static_N=[35.0, 28.0],
        stribeck_velocity_m_s=[0.002, 0.002],
        ripple_amplitude_N=0.0,
        ripple_period_m=0.01,
        disturbance_amplitude_N=[8.0, 6.0],
        disturbance_frequency_hz=[1.5, 2.3],
        force_limit_N=1500.0,
        encoder_resolution_m=1e-7,
        servo_period_s=1e-3,
        notes=(
            "Biaxial ball-screw table in the style of Simba et al. 2018 (M ẍ + f_r + d = f; their "
            "numbers are not in the available pages, these are ours): equivalent masses 42/36 kg, "
            "viscous 60/50 N s/m, Coulomb 25/20 N, static 35/28 N, Stribeck velocity 2 mm/s, "
            "bounded disturbance 8/6 N at 1.5/2.3 Hz (phase fixed, or drawn per episode with the "
            "env's disturbance_phase='random'), 1.5 kN limit, 0.1 µm "
            "position resolution (a 2^17 counts/rev rotary encoder on a 10 mm lead screw gives "
            "0.076 µm), T = 1 ms."
        ),
    )
    eff = Effects(
        computation_delay=True,
        current_loop_time_constant_s=(0.5e-3, 0.5e-3),
        added_friction=None,
        added_ripple=None,
        mismatch=dict(mass_kg=(1.10, 0.90), viscous_Ns_m=(0.85, 1.15)),
        structural_mode_hz=(45.0, 55.0),
    )
    return p, eff


PLANTS = {
    "hsm2": _hsm2,
    "jee-triaxial": _jee,
    "linear-motor": _linear_motor,
    "friction-table": _friction_table,
}
PLANT_ALIASES = {"jee": "jee-triaxial", "lm": "linear-motor", "table": "friction-table"}


def plant_names() -> list[str]:
    return list(PLANTS)


def nominal_params(name: str) -> tuple[PlantParams, Effects]:
    """The paper's parameters of a named plant and its documented realistic effects."""
    key = PLANT_ALIASES.get(name, name)
    if key not in PLANTS:
        raise ValueError(f"plant: unknown plant {name!r}; known plants: {', '.join(PLANTS)}")
    return PLANTS[key]()


def apply_effects(
    nominal: PlantParams, eff: Effects, *, structural_mode: bool = False
) -> PlantParams:
    """The true plant: nominal parameters with the effects switched on."""
    n = nominal.n_axes
    changes: dict = {"computation_delay": eff.computation_delay}
    if eff.current_loop_time_constant_s:
        changes["current_loop_time_constant_s"] = np.asarray(eff.current_loop_time_constant_s)
    if eff.added_friction:
        changes["coulomb_N"] = nominal.coulomb_N + np.asarray(eff.added_friction["coulomb_N"])
        changes["static_N"] = nominal.static_N + np.asarray(eff.added_friction["static_N"])
        changes["stribeck_velocity_m_s"] = np.asarray(eff.added_friction["stribeck_velocity_m_s"])
    if eff.added_ripple:
        changes["ripple_amplitude_N"] = np.asarray(eff.added_ripple["amplitude_N"])
        changes["ripple_period_m"] = np.asarray(eff.added_ripple["period_m"])
    for key, factor in eff.mismatch.items():
        changes[key] = getattr(nominal, key) * np.asarray(factor, dtype=np.float64)
    true = nominal.replace(**changes)
    if structural_mode:
        if not eff.structural_mode_hz:
            raise ValueError(f"structural_mode: plant {nominal.name!r} has no structural mode data")
        f_hz = np.asarray(eff.structural_mode_hz, dtype=np.float64)
        frac = np.full(n, 0.5)
        m = true.mass_kg
        reduced = frac * m * (1 - frac) * m / m  # m_load m_motor / (m_load + m_motor)
        k = reduced * (2 * np.pi * f_hz) ** 2
        c = 2 * eff.structural_damping_ratio * np.sqrt(k * reduced)
        true = true.replace(
            structural_stiffness_N_m=k, structural_damping_Ns_m=c, load_mass_fraction=frac
        )
    return true


def resolve_plant(plant, *, ideal: bool = False, structural_mode: bool = False, true_scale=None):
    """Name, mapping or JSON file of parameters (``"plant.json"``, an ``os.PathLike``;
    :mod:`contour_env.plants.from_file`) → (true params, nominal params, effects description).

    ``true_scale`` (named plants only): per-axis factors true = nominal × factor that replace
    the realistic mismatch of those fields (e.g. a payload, ``{"mass_kg": (1.3, 1.3)}``, as
    the ``hsm2-payload`` case uses); every other effect is kept. With ``ideal=True`` they are
    applied to the paper's model (a payload is part of the machine, not an unmodelled effect).
    """
    if is_plant_file(plant):  # a JSON file of parameters (contour_env.plants.from_file)
        if true_scale:
            raise ValueError("true_scale: only for a named plant (custom parameters are the truth)")
        name = os.fspath(plant)
        p = params_from_mapping(load_plant_file(name), name)
        return p, p, {"ideal": True, "custom": True}
    if true_scale and not isinstance(plant, str):
        raise ValueError("true_scale: only for a named plant (custom parameters are the truth)")
    if isinstance(plant, PlantParams):
        return plant, plant, {"ideal": True}
    if isinstance(plant, Mapping):
        p = params_from_mapping(plant)
        return p, p, {"ideal": True, "custom": True}
    if not isinstance(plant, str):
        raise ValueError(
            f"plant: expected a plant name ({', '.join(PLANTS)}) or a mapping of parameters, "
            f"got {type(plant).__name__}"
        )
    nominal, eff = nominal_params(plant)
    scale = {
        k: tuple(float(x) for x in np.broadcast_to(np.asarray(v, dtype=float), nominal.n_axes))
        for k, v in (true_scale or {}).items()
    }
    unknown = sorted(set(scale) - set(PER_AXIS_FIELDS))
    if unknown:
        raise ValueError(f"true_scale: unknown per-axis parameter(s) {unknown}")
    if ideal:
        if structural_mode:
            raise ValueError("structural_mode: not available with ideal=True")
        if scale:
            return nominal.scaled(scale), nominal, {"ideal": True, "true_scale": _lists(scale)}
        return nominal, nominal, {"ideal": True}
    if scale:
        eff = replace(eff, mismatch={**eff.mismatch, **scale})
    true = apply_effects(nominal, eff, structural_mode=structural_mode)
    desc = eff.describe()
    if scale:
        desc["true_scale"] = _lists(scale)
    desc["ideal"] = False
    desc["structural_mode"] = bool(structural_mode)
    return true, nominal, desc


def _lists(scale: dict) -> dict:
    return {k: list(v) for k, v in scale.items()}
