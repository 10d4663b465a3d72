"""Parameters of the five-axis plant: geometry, rigid-body inertia, per-joint drives and
friction, and the named NXV560A-class set (paper's model and the realistic true plant).

Per joint j (SI: N and m for x, y, z; N·m and rad for A, C), added to eq. 4's left side:

    f_j(v) = b_j v + (f_c + (f_s − f_c) e^{−(v/v_s)²}) tanh(v / v_ε)

the Stribeck law of the other plants with sgn(v) smoothed over v_ε (documented
approximation: a coupled five-body stick–slip treatment is not attempted). The applied
torque is the saturated command, held over the servo period, delayed by one period with
``computation_delay`` and lagged by a first-order current loop.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace

import numpy as np

from ..params import _axis_array
from .dynamics import IP_SIZE, mass_matrix_into
from .kinematics import FiveAxisGeometry

JOINT_FIELDS = (
    "viscous_Ns_m_Nms_rad",
    "coulomb_N_Nm",
    "static_N_Nm",
    "stribeck_velocity_m_s_rad_s",
    "friction_smoothing_m_s_rad_s",
    "drive_limit_N_Nm",
    "encoder_resolution_m_rad",
    "current_loop_time_constant_s",
)
# indices into the per-joint packed vector (FiveAxisParams.packed_joints())
J_VISC, J_FC, J_FS, J_VS, J_VEPS, J_LIMIT, J_RES, J_TC = range(8)
JP_SIZE = 8

# RK4 is accurate (not merely stable: h λ <= 2.78 on the real axis) across the smoothed
# friction's steepest slope if h · f_s / (v_ε · M_eff) <= this bound; at 0.35 the realistic
# set tracks DOP853 to 3e-8 rad over a forced 0.2 s run (at 0.7: 8e-7 rad)
FRICTION_STABILITY_BOUND = 0.4


@dataclass(frozen=True)
class FiveAxisInertia:
    """Rigid bodies of an NXV560A-class A–C table machine (values and reasons: docs/FIVE_AXIS.md).

    Masses include the moving parts of the drive carried by the body (paper §2: m1 = m_y +
    m_motor,x, ...). Offsets are from the A axis, along the cradle's / the table's z axis.
    """

    y_saddle_mass_kg: float = 400.0
    x_table_mass_kg: float = 350.0
    cradle_mass_kg: float = 180.0
    cradle_com_offset_m: float = -0.06
    cradle_inertia_kgm2: float = 4.0
    table_mass_kg: float = 100.0
    table_com_height_m: float = 0.03
    table_com_eccentricity_m: float = 0.005
    table_radial_inertia_kgm2: float = 1.1
    table_axial_inertia_kgm2: float = 2.0
    spindle_head_mass_kg: float = 450.0
    gravity_m_s2: float = 9.81

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.number)):
                raise ValueError(f"{f.name}: expected a number, got {value!r}")
            value = float(value)
            if not math.isfinite(value):
                raise ValueError(f"{f.name}: must be finite, got {value}")
            if f.name.endswith("_kg") and not 1e-3 <= value <= 1e5:
                raise ValueError(f"{f.name}: must lie in 1e-3..1e5 kg, got {value}")
            if f.name.endswith("_kgm2") and not 0.0 <= value <= 1e4:
                raise ValueError(f"{f.name}: must lie in 0..1e4 kg m², got {value}")
            if f.name.endswith("_m") and abs(value) > 2.0:
                raise ValueError(f"{f.name}: must lie within ±2 m, got {value}")
            if f.name == "gravity_m_s2" and not 0.0 <= value <= 20.0:
                raise ValueError(f"gravity_m_s2: must lie in 0..20 m/s², got {value}")
            object.__setattr__(self, f.name, value)

    def packed(self) -> np.ndarray:
        """The (IP_SIZE,) vector of dynamics.I_* indices."""
        v = np.array(
            [
                self.y_saddle_mass_kg,
                self.x_table_mass_kg,
                self.cradle_mass_kg,
                self.cradle_com_offset_m,
                self.cradle_inertia_kgm2,
                self.table_mass_kg,
                self.table_com_height_m,
                self.table_com_eccentricity_m,
                self.table_radial_inertia_kgm2,
                self.table_axial_inertia_kgm2,
                self.spindle_head_mass_kg,
                self.gravity_m_s2,
            ]
        )
        assert v.shape == (IP_SIZE,)
        return v


def _joint_array(name: str, value, *, positive=False) -> np.ndarray:
    """``value`` (a number, or one per joint) as a read-only (5,) array, >= 0 (> 0 when
    ``positive``)."""
    arr = _axis_array(name, value, 5, positive=positive, nonneg=True, member="joint")
    arr.setflags(write=False)
    return arr


# eq=False: the per-joint fields are arrays (== would be ambiguous); identity instead
@dataclass(frozen=True, eq=False)
class FiveAxisParams:
    """The five-axis plant (SI; per-joint arrays in joint order x, y, z, A, C: N, m, s for
    the linear joints and N·m, rad, s for the rotary ones).

    Attributes
    ----------
    name : str
    geometry : FiveAxisGeometry       offsets and travel (eq. 1).
    inertia : FiveAxisInertia         rigid bodies (eq. 4).
    viscous_Ns_m_Nms_rad : (5,) >= 0  viscous friction b.
    coulomb_N_Nm, static_N_Nm : (5,) >= 0, static >= coulomb   Stribeck friction levels.
    stribeck_velocity_m_s_rad_s : (5,) > 0
    friction_smoothing_m_s_rad_s : (5,) > 0
        v_ε of tanh(v / v_ε), the smoothed sgn(v); bounded below by RK4 stability (the
        friction slope f_s / v_ε over the substep, see FRICTION_STABILITY_BOUND).
    drive_limit_N_Nm : (5,) > 0       saturation of the applied force / torque.
    encoder_resolution_m_rad : (5,) >= 0   quantisation of the measured joints (0: exact).
    current_loop_time_constant_s : (5,) >= 0   first-order torque lag (0: none).
    servo_period_s : float > 0        controller period T (zero-order hold); paper: 1 ms.
    computation_delay : bool          command applied one period after it is computed.
    rk4_substeps : int >= 1           fixed RK4 steps per servo period.
    notes : str                       where the numbers come from.
    """

    name: str = "custom"
    geometry: FiveAxisGeometry = field(default_factory=FiveAxisGeometry)
    inertia: FiveAxisInertia = field(default_factory=FiveAxisInertia)
    viscous_Ns_m_Nms_rad: np.ndarray = 0.0
    coulomb_N_Nm: np.ndarray = 0.0
    static_N_Nm: np.ndarray = 0.0
    stribeck_velocity_m_s_rad_s: np.ndarray = 0.01
    friction_smoothing_m_s_rad_s: np.ndarray = 1e-3
    drive_limit_N_Nm: np.ndarray = 1e9
    encoder_resolution_m_rad: np.ndarray = 0.0
    current_loop_time_constant_s: np.ndarray = 0.0
    servo_period_s: float = 1e-3
    computation_delay: bool = False
    rk4_substeps: int = 10
    notes: str = ""

    def __post_init__(self):
        if not isinstance(self.geometry, FiveAxisGeometry):
            raise ValueError(f"geometry: expected FiveAxisGeometry, got {self.geometry!r}")
        if not isinstance(self.inertia, FiveAxisInertia):
            raise ValueError(f"inertia: expected FiveAxisInertia, got {self.inertia!r}")
        positive = {
            "stribeck_velocity_m_s_rad_s",
            "friction_smoothing_m_s_rad_s",
            "drive_limit_N_Nm",
        }
        for name in JOINT_FIELDS:
            object.__setattr__(
                self, name, _joint_array(name, getattr(self, name), positive=name in positive)
            )
        if np.any(self.static_N_Nm < self.coulomb_N_Nm):
            raise ValueError(
                f"static_N_Nm must be >= coulomb_N_Nm on every joint, got static "
                f"{self.static_N_Nm.tolist()} and coulomb {self.coulomb_N_Nm.tolist()}"
            )
        T = self.servo_period_s
        if isinstance(T, bool) or not isinstance(T, (int, float, np.number)):
            raise ValueError(f"servo_period_s: must be a number in 1e-6..0.1 s, got {T!r}")
        if not (math.isfinite(T) and 1e-6 <= T <= 0.1):
            raise ValueError(f"servo_period_s: must lie in 1e-6..0.1 s, got {T}")
        object.__setattr__(self, "servo_period_s", float(T))
        n = self.rk4_substeps
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 1 <= n <= 1000:
            raise ValueError(f"rk4_substeps: must be an integer in 1..1000, got {n!r}")
        object.__setattr__(self, "rk4_substeps", int(n))
        if not isinstance(self.computation_delay, (bool, np.bool_)):
            raise ValueError(
                f"computation_delay: must be True or False, got {self.computation_delay!r}"
            )
        object.__setattr__(self, "computation_delay", bool(self.computation_delay))
        self._check_friction_stiffness()

    def _check_friction_stiffness(self):
        # the smallest effective inertia 1 / (M⁻¹)_jj over the A, C travel (grid) bounds the
        # friction slope
        h = self.servo_period_s / self.rk4_substeps
        ip = self.inertia.packed()
        m = np.empty((5, 5))
        lo, hi = self.geometry.a_travel_rad
        diag_min = np.full(5, np.inf)
        for a in np.linspace(lo, hi, 13):
            for c in np.linspace(0.0, 2 * np.pi, 13):
                mass_matrix_into(np.array([0.0, 0.0, 0.0, a, c]), ip, m)
                diag_min = np.minimum(diag_min, 1.0 / np.diag(np.linalg.inv(m)))
        ratio = h * self.static_N_Nm / (self.friction_smoothing_m_s_rad_s * diag_min)
        if np.any(ratio > FRICTION_STABILITY_BOUND):
            j = int(np.argmax(ratio))
            need = h * self.static_N_Nm[j] / (FRICTION_STABILITY_BOUND * diag_min[j])
            raise ValueError(
                f"friction_smoothing_m_s_rad_s: joint {j} needs v_ε >= {need:.3g} for the RK4 "
                f"substep {h:.3g} s (or more rk4_substeps), got "
                f"{self.friction_smoothing_m_s_rad_s[j]:.3g}"
            )

    @property
    def has_friction(self) -> bool:
        return bool(np.any(self.static_N_Nm > 0) or np.any(self.viscous_Ns_m_Nms_rad > 0))

    def packed_joints(self) -> np.ndarray:
        """(5, JP_SIZE) per-joint vector of the J_* indices."""
        v = np.empty((5, JP_SIZE))
        v[:, J_VISC] = self.viscous_Ns_m_Nms_rad
        v[:, J_FC] = self.coulomb_N_Nm
        v[:, J_FS] = self.static_N_Nm
        v[:, J_VS] = self.stribeck_velocity_m_s_rad_s
        v[:, J_VEPS] = self.friction_smoothing_m_s_rad_s
        v[:, J_LIMIT] = self.drive_limit_N_Nm
        v[:, J_RES] = self.encoder_resolution_m_rad
        v[:, J_TC] = self.current_loop_time_constant_s
        return v


NXV560A_NOTES = (
    "NXV560A-class A–C trunnion machine (Chen, Khong & Hsieh 2022 give the kinematics but no "
    "masses, inertias or offsets; every value is chosen for the class and justified in "
    "docs/FIVE_AXIS.md): saddle 400 kg, x table 350 kg, cradle 180 kg with its centre of mass "
    "60 mm below the A axis and 4 kg m², C table + fixture + workpiece 100 kg (Ø 400 mm, "
    "2.0 kg m² axial), 5 mm fixture eccentricity, spindle head 450 kg (gravity on z, no "
    "counterbalance); drives 8/10/12 kN, 1500/600 N m; 0.1 µm linear scales, 2^23-count "
    "rotary encoders; 1 ms servo."
)


def _nxv560a_nominal() -> FiveAxisParams:
    return FiveAxisParams(
        name="nxv560a",
        drive_limit_N_Nm=[8000.0, 10000.0, 12000.0, 1500.0, 600.0],
        encoder_resolution_m_rad=[1e-7, 1e-7, 1e-7, 2 * np.pi / 2**23, 2 * np.pi / 2**23],
        servo_period_s=1e-3,
        notes=NXV560A_NOTES,
    )


# the realistic effects of the true plant (docs/FIVE_AXIS.md)
NXV560A_TRUE_EFFECTS = dict(
    viscous_Ns_m_Nms_rad=[1500.0, 1800.0, 1500.0, 40.0, 15.0],
    coulomb_N_Nm=[150.0, 200.0, 180.0, 30.0, 10.0],
    static_N_Nm=[200.0, 260.0, 240.0, 40.0, 15.0],
    stribeck_velocity_m_s_rad_s=[2e-3, 2e-3, 2e-3, 5e-3, 5e-3],
    friction_smoothing_m_s_rad_s=[1e-4, 1e-4, 1e-4, 1e-3, 1e-3],
    current_loop_time_constant_s=[5e-4, 5e-4, 5e-4, 8e-4, 8e-4],
    computation_delay=True,
    # the smoothed friction's slope needs 50 µs substeps (FRICTION_STABILITY_BOUND)
    rk4_substeps=20,
)
# true = nominal × factor: a workpiece 20 % heavier than the model's, cradle 5 % off
NXV560A_TRUE_INERTIA_SCALE = dict(
    table_mass_kg=1.2,
    table_axial_inertia_kgm2=1.2,
    table_radial_inertia_kgm2=1.2,
    cradle_inertia_kgm2=1.05,
)

FIVE_AXIS_PLANTS = ("nxv560a",)


def five_axis_params(name: str = "nxv560a", *, ideal: bool = False):
    """(true, nominal) FiveAxisParams of a named five-axis plant.

    nominal is the paper's model (no friction, delay or lag: ξ̈ = f + G u exactly); with
    ``ideal=True`` the true plant is the nominal one, otherwise it adds the documented
    friction, current-loop lag, one-period computation delay and inertia mismatch.
    """
    if name not in FIVE_AXIS_PLANTS:
        raise ValueError(f"plant: unknown five-axis plant {name!r}; known: {FIVE_AXIS_PLANTS}")
    nominal = _nxv560a_nominal()
    if ideal:
        return nominal, nominal
    inertia = replace(
        nominal.inertia,
        **{k: getattr(nominal.inertia, k) * f for k, f in NXV560A_TRUE_INERTIA_SCALE.items()},
    )
    true = replace(nominal, inertia=inertia, **NXV560A_TRUE_EFFECTS)
    return true, nominal
