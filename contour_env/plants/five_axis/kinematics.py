"""Kinematics of the A–C tilting-table five-axis machine (Chen, Khong & Hsieh 2022, eqs. 1–3).

Machine joints ξ_m = q = (x, y, z, A, C) in (m, m, m, rad, rad), ISO 841 signs: x, y, z are
the motion of the tool relative to the table (the table moves by (−x, −y), the spindle head
by +z). The workpiece frame is fixed to the C table: its origin is the C-table face centre,
``d4_m`` along the C axis from the rotation centre (the A axis at height d1 + d2). Tool tip
p_w (3,) m and unit tool vector o_w (3,) (from the tip towards the spindle) are in the
workpiece frame. With R_A, R_C the rotations about x by A and about z by C:

    p_w = R_C^T R_A^T (x, y, z + D_all)^T − d4 e_z,    D_all = d_z − d1 − d2 − d_tool
    o_w = R_C^T R_A^T e_z = (sin A sin C, sin A cos C, cos A)

This is the mirror image of the paper's eq. 1, not eq. 1 itself. In the paper's angles
θ_A, θ_C, eq. 1 is p_w = R_C R_A (x, y, z + D_all)^T − d4 e_z (R_A, R_C at θ_A, θ_C),
O_w = (sin θ_A sin θ_C, −sin θ_A cos θ_C, cos θ_A). Its extracted text lost the minus signs;
they are restored where two terms have no operator between them, which makes eq. 1's
x_w, y_w, z_w that rigid-body map term by term, with ∂p_w/∂z = O_w, and agrees with the
printed ε₃ = (x_w − x_c) cos θ_C + (y_w − y_c) sin θ_C (§4). The two differ by a relabelling
of the rotation directions (A → −A, C → −C), exactly:

    forward(x, y, z, A, C) = paper's eq. 1 at (x, y, z, θ_A = −A, θ_C = −C)

It is harmless: the joint references come from this module's own inverse, and a formula of
the paper in θ_A, θ_C (ε₃ above) holds here with θ_A = −A, θ_C = −C.

Inverse (eq. 2, in these angles) on the branch s = ±1 (default −1: the travel −120°…+30° is
mostly negative; it is eq. 2's own branch θ_A = arccos(O_wz) ≥ 0): A = s·arccos(o_z)
(computed as s·atan2(hypot(o_x, o_y), o_z), well conditioned near A = 0),
C = atan2(s·o_x, s·o_y) unwrapped to the nearest of ``c_ref`` (continuous paths),
(x, y, z) = R_A R_C (p_w + d4 e_z) − D_all e_z.

Singularity: at A = 0 the tool vector is e_z for every C (C undefined). Where
hypot(o_x, o_y) <= SINGULAR_TOL the inverse keeps C = c_ref (0 without one), so a path
through the vertical tool keeps C still; the tip position is still exact for that C.

Arrays carry a leading batch shape ``(...)``: q (..., 5), tip and tool (..., 3).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# below this horizontal tool-vector component C is undefined and kept at c_ref; at a
# sin A of 1e-9, a rounding error of 1e-16 in o_w moves C by 1e-7 rad (0.02″)
SINGULAR_TOL = 1e-9

JOINT_NAMES = ("x", "y", "z", "A", "C")
_UNITS = ("m", "m", "m", "deg", "deg")


def _travel(name: str, value) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in value)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected (min, max), got {value!r}") from None
    if math.isnan(lo) or math.isnan(hi) or not lo < hi:
        raise ValueError(f"{name}: expected min < max, got ({lo}, {hi})")
    return lo, hi


@dataclass(frozen=True)
class FiveAxisGeometry:
    """Offsets of eq. 1 and the joint travel of an NXV560A-class A–C table machine (SI).

    d1_m, d2_m : float >= 0
        Height of the A axis above the machine z reference is d1 + d2 (y/x slides and the
        trunnion supports; paper Fig. 1). Defaults 0.20 + 0.15 m.
    d4_m : float
        C-table face (workpiece origin) along the C axis from the A axis; default 0.05 m
        (the face a little above the trunnion axis, as on compact trunnion tables).
    dtool_m : float > 0
        Tool plus holder length; default 0.15 m.
    dz_m : float
        Spindle gauge line above the z reference at z = 0; default 0.55 m = d1 + d2 + d4 +
        d_tool, so that at A = C = 0 the joints equal the workpiece coordinates (z = 0: tool
        tip on the table-face centre).
    x_travel_m, y_travel_m, z_travel_m : (min, max)
        Linear travel 560 × 450 × 460 mm (class of the NXV560A), centred.
    a_travel_rad : (min, max)
        Trunnion tilt −120°…+30°.
    c_travel_rad : (min, max)
        C is a continuous rotary table: (−inf, inf) by default.
    """

    d1_m: float = 0.20
    d2_m: float = 0.15
    d4_m: float = 0.05
    dtool_m: float = 0.15
    dz_m: float = 0.55
    x_travel_m: tuple = (-0.28, 0.28)
    y_travel_m: tuple = (-0.225, 0.225)
    z_travel_m: tuple = (-0.23, 0.23)
    a_travel_rad: tuple = (math.radians(-120.0), math.radians(30.0))
    c_travel_rad: tuple = (-math.inf, math.inf)

    def __post_init__(self):
        for name in ("d1_m", "d2_m", "d4_m", "dtool_m", "dz_m"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.number)):
                raise ValueError(f"{name}: expected a number (m), got {value!r}")
            if not math.isfinite(value) or abs(value) > 10.0:
                raise ValueError(f"{name}: expected a finite length within ±10 m, got {value}")
            object.__setattr__(self, name, float(value))
        for name in ("d1_m", "d2_m"):
            if getattr(self, name) < 0:
                raise ValueError(f"{name}: must be >= 0 m, got {getattr(self, name)}")
        if self.dtool_m <= 0:
            raise ValueError(f"dtool_m: must be > 0 m, got {self.dtool_m}")
        for name in ("x_travel_m", "y_travel_m", "z_travel_m", "a_travel_rad", "c_travel_rad"):
            object.__setattr__(self, name, _travel(name, getattr(self, name)))
        lo, hi = self.a_travel_rad
        if lo < -math.pi or hi > math.pi:
            raise ValueError(f"a_travel_rad: must lie within [-pi, pi], got ({lo}, {hi})")

    @property
    def tip_offset_m(self) -> float:
        """D_all = d_z − d1 − d2 − d_tool: tool tip above the A axis at z = 0 (eq. 1)."""
        return self.dz_m - self.d1_m - self.d2_m - self.dtool_m

    def travel(self) -> np.ndarray:
        """(5, 2) array of (min, max) per joint, SI (m, rad)."""
        return np.array(
            [
                self.x_travel_m,
                self.y_travel_m,
                self.z_travel_m,
                self.a_travel_rad,
                self.c_travel_rad,
            ]
        )

    def check_joint(self, q, name: str = "q") -> np.ndarray:
        """Return q (..., 5) as float64; ValueError naming the axis, its travel and the value
        if q has the wrong shape, is not finite or lies outside the travel."""
        q = _as_array(q, name, 5)
        travel = self.travel()
        for j, axis in enumerate(JOINT_NAMES):
            col = q[..., j]
            bad = (col < travel[j, 0]) | (col > travel[j, 1])
            if np.any(bad):
                value = col[bad].flat[0]
                lo, hi = travel[j]
                if _UNITS[j] == "deg":
                    value, lo, hi = math.degrees(value), math.degrees(lo), math.degrees(hi)
                raise ValueError(
                    f"{name}: joint {axis} (index {j}) travel {lo:.6g}…{hi:.6g} {_UNITS[j]}, "
                    f"got {value:.6g} {_UNITS[j]}"
                )
        return q


def _as_array(value, name: str, last: int) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected a numeric array (..., {last}), got {value!r}") from None
    if arr.ndim == 0 or arr.shape[-1] != last:
        raise ValueError(f"{name}: expected shape (..., {last}), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: must be finite (got NaN or inf)")
    return arr


def forward(q, geom: FiveAxisGeometry) -> tuple[np.ndarray, np.ndarray]:
    """Tool tip p_w (..., 3) m and unit tool vector o_w (..., 3) of joints q (..., 5) (eq. 1
    mirrored: the paper's eq. 1 at θ_A = −A, θ_C = −C; see the module docstring).

    No travel check (a simulated machine may overshoot); shape and finiteness are checked.
    """
    q = _as_array(q, "q", 5)
    sa, ca = np.sin(q[..., 3]), np.cos(q[..., 3])
    sc, cc = np.sin(q[..., 4]), np.cos(q[..., 4])
    x, y = q[..., 0], q[..., 1]
    zt = q[..., 2] + geom.tip_offset_m
    # w = R_A^T (x, y, z + D): rotation of the tip into the cradle frame
    wy = ca * y + sa * zt
    wz = -sa * y + ca * zt
    tip = np.stack([cc * x + sc * wy, -sc * x + cc * wy, wz - geom.d4_m], axis=-1)
    tool = np.stack([sa * sc, sa * cc, ca], axis=-1)
    return tip, tool


def inverse(tip, tool, geom: FiveAxisGeometry, c_ref=None, a_branch: int = -1, check=True):
    """Joints q (..., 5) placing the tool tip at ``tip`` (..., 3) m with unit tool vector
    ``tool`` (..., 3) (eq. 2).

    a_branch : −1 (default) gives A = −arccos(o_z) ∈ [−π, 0]; +1 gives A = +arccos(o_z)
        (the other branch: same tip and tool with C + π).
    c_ref : None, float or (...) array, rad
        C is unwrapped to within π of c_ref (pass the previous C of a path so it never jumps
        by 2π), and kept at c_ref at the singular pose A = 0 (hypot(o_x, o_y) <= SINGULAR_TOL).
        None: C ∈ (−π, π], and 0 at the singular pose.
    check : also check the result against the travel (ValueError naming the joint).
    """
    tip = _as_array(tip, "tip", 3)
    tool = _as_array(tool, "tool", 3)
    if a_branch not in (-1, 1):
        raise ValueError(f"a_branch: must be -1 or +1, got {a_branch!r}")
    norm = np.linalg.norm(tool, axis=-1)
    if np.any(np.abs(norm - 1.0) > 1e-9):
        raise ValueError(
            f"tool: must be unit vectors (|o_w| = 1 within 1e-9), got norms within "
            f"{norm.min():.12g}…{norm.max():.12g}"
        )
    tip, tool = np.broadcast_arrays(tip, tool)
    shape = tip.shape[:-1]
    if c_ref is None:
        cref = np.zeros(shape)
    else:
        cref = np.broadcast_to(np.asarray(c_ref, dtype=np.float64), shape)
        if not np.all(np.isfinite(cref)):
            raise ValueError("c_ref: must be finite (got NaN or inf)")
    horiz = np.hypot(tool[..., 0], tool[..., 1])
    # = ±arccos(o_z) (eq. 2), written with atan2: well conditioned near A = 0 as well
    a = a_branch * np.arctan2(horiz, tool[..., 2])
    singular = horiz <= SINGULAR_TOL
    c = np.arctan2(a_branch * tool[..., 0], a_branch * tool[..., 1])
    if c_ref is not None:
        c = c + 2.0 * np.pi * np.round((cref - c) / (2.0 * np.pi))
    c = np.where(singular, cref, c)
    sa, ca, sc, cc = np.sin(a), np.cos(a), np.sin(c), np.cos(c)
    px, py, pz = tip[..., 0], tip[..., 1], tip[..., 2] + geom.d4_m
    # R_C (p_w + d4 e_z), then R_A
    uy = sc * px + cc * py
    q = np.stack(
        [
            cc * px - sc * py,
            ca * uy - sa * pz,
            sa * uy + ca * pz - geom.tip_offset_m,
            a,
            c,
        ],
        axis=-1,
    )
    if check:
        geom.check_joint(q, name="inverse(tip, tool)")
    return q


def tool_towards(tip, xc) -> np.ndarray:
    """Unit tool vector of the paper's test paths (eq. 3): o_w = (p_w − X_c) / ‖p_w − X_c‖.

    The tool axis passes through the fixed point X_c (below the part in both test paths) and
    the vector points from X_c through the tip, i.e. from the tip towards the spindle (the
    convention of o_w = e_z at A = 0). tip (..., 3), xc (3,) or (..., 3), m.
    """
    tip = _as_array(tip, "tip", 3)
    xc = _as_array(xc, "xc", 3)
    d = tip - xc
    n = np.linalg.norm(d, axis=-1, keepdims=True)
    if np.any(n <= 1e-12):
        raise ValueError("xc: the fixed point X_c coincides with a tool tip (tool undefined)")
    return d / n
