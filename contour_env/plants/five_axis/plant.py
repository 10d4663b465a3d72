"""Batched compiled step of the five-axis plant and the plant object around it.

Per env, over one servo period T with the command held (zero-order hold): the command is
delayed one period (``computation_delay``), saturated at the drive limits, lagged by the
first-order current loop, and the coupled joint dynamics

    M(ξ) ξ̈ + C(ξ, ξ̇) ξ̇ + g(ξ) + f_friction(ξ̇) = τ      (eq. 4 plus friction)

are integrated with ``rk4_substeps`` fixed classical Runge–Kutta steps on the state
(ξ, ξ̇, τ_applied). This is a different plant family from the decoupled per-axis drives of
:mod:`contour_env.plants.kernel` (one step signature, its own kernel).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from ..kernel import delayed_saturated
from .dynamics import (
    I_E4,
    I_G,
    I_H4,
    I_J3,
    I_J4R,
    I_J4Z,
    I_M1,
    I_M2,
    I_M3,
    I_M4,
    I_M5,
    I_R3,
    IP_SIZE,
    gravity,
)
from .params import (
    J_FC,
    J_FS,
    J_LIMIT,
    J_TC,
    J_VEPS,
    J_VISC,
    J_VS,
    JP_SIZE,
    FiveAxisParams,
    five_axis_params,
)

NS = 15  # RK4 state: ξ (5), ξ̇ (5), applied torque τ (5)


@njit(cache=True, inline="always")
def joint_friction(v, jp, p, j):
    """b v + (f_c + (f_s − f_c) e^{−(v/v_s)²}) tanh(v / v_ε) of joint j (N or N·m)."""
    f = jp[p, j, J_VISC] * v
    fs = jp[p, j, J_FS]
    if fs != 0.0:
        fc = jp[p, j, J_FC]
        r = v / jp[p, j, J_VS]
        f += (fc + (fs - fc) * math.exp(-(r * r))) * math.tanh(v / jp[p, j, J_VEPS])
    return f


@njit(cache=True, inline="always")
def _drive(y, u, jp, p, j, dy):
    # applied drive force of joint j minus its friction; sets the rates dξ_j and dτ_j
    tc = jp[p, j, J_TC]
    if tc > 0.0:
        tau = y[10 + j]
        dy[10 + j] = (u[j] - tau) / tc
    else:
        tau = u[j]
        dy[10 + j] = 0.0
    dy[j] = y[5 + j]
    return tau - joint_friction(y[5 + j], jp, p, j)


@njit(cache=True)
def _deriv(y, u, ip, jp, p, dy):
    """dy = d/dt (ξ, ξ̇, τ) at state y (15,) with the held, saturated command u (5,).

    The closed forms of dynamics.py specialised to the machine's sparsity (checked against
    the general Christoffel form by the tests): only A and C enter M and g; z is decoupled;
    of C(ξ, ξ̇) ξ̇ only these centrifugal/Coriolis terms survive

        h_x = m4 e4 cos C Ċ²
        h_y = ∂M_yA/∂A Ȧ² + 2 m4 e4 sin A cos C Ȧ Ċ + m4 e4 cos A sin C Ċ²
        h_A = 2 m4 e4² sin C cos C Ȧ Ċ + m4 e4 h4 sin C Ċ²
        h_C = −m4 e4² sin C cos C Ȧ²

    and M's (x, y, A, C) block is solved by its closed-form Cholesky factor.
    """
    sa, ca = math.sin(y[3]), math.cos(y[3])
    sc, cc = math.sin(y[4]), math.cos(y[4])
    wa, wc = y[8], y[9]
    m3, m4 = ip[p, I_M3], ip[p, I_M4]
    r3, h4, e4, grav = ip[p, I_R3], ip[p, I_H4], ip[p, I_E4], ip[p, I_G]
    me4 = m4 * e4
    # mass matrix entries (dynamics.mass_matrix_into)
    m00 = ip[p, I_M2] + m3 + m4
    m11 = ip[p, I_M1] + ip[p, I_M2] + m3 + m4
    m33 = ip[p, I_J3] + ip[p, I_J4R] + m3 * r3 * r3 + m4 * h4 * h4 + me4 * e4 * sc * sc
    m44 = ip[p, I_J4Z] + me4 * e4
    m04 = me4 * sc
    m13 = (m3 * r3 + m4 * h4) * ca + me4 * sa * sc
    m14 = -me4 * ca * cc
    m34 = -me4 * h4 * cc
    # bias h = C ξ̇ + g; f_j = τ_j − friction_j − h_j
    scc = sc * cc
    h0 = me4 * cc * wc * wc
    h1 = (
        (-(m3 * r3 + m4 * h4) * sa + me4 * ca * sc) * wa * wa
        + 2.0 * me4 * sa * cc * wa * wc
        + me4 * ca * sc * wc * wc
    )
    h2 = grav * ip[p, I_M5]
    h3 = 2.0 * me4 * e4 * scc * wa * wc + me4 * h4 * sc * wc * wc
    h3 -= grav * ((m3 * r3 + m4 * h4) * sa - me4 * ca * sc)
    h4b = -me4 * e4 * scc * wa * wa + grav * me4 * sa * cc
    f0 = _drive(y, u, jp, p, 0, dy) - h0
    f1 = _drive(y, u, jp, p, 1, dy) - h1
    f2 = _drive(y, u, jp, p, 2, dy) - h2
    f3 = _drive(y, u, jp, p, 3, dy) - h3
    f4 = _drive(y, u, jp, p, 4, dy) - h4b
    # Cholesky of the (x, y, A, C) block: L[x] = (l00), L[y] = (0, l11),
    # L[A] = (0, l21, l22), L[C] = (l30, l31, l32, l33)
    l00 = math.sqrt(m00)
    l30 = m04 / l00
    l11 = math.sqrt(m11)
    l21 = m13 / l11
    l31 = m14 / l11
    l22 = math.sqrt(m33 - l21 * l21)
    l32 = (m34 - l31 * l21) / l22
    l33 = math.sqrt(m44 - l30 * l30 - l31 * l31 - l32 * l32)
    z0 = f0 / l00
    z1 = f1 / l11
    z2 = (f3 - l21 * z1) / l22
    z3 = (f4 - l30 * z0 - l31 * z1 - l32 * z2) / l33
    a_c = z3 / l33
    a_a = (z2 - l32 * a_c) / l22
    dy[5] = (z0 - l30 * a_c) / l00
    dy[6] = (z1 - l21 * a_a - l31 * a_c) / l11
    dy[7] = f2 / ip[p, I_M5]
    dy[8] = a_a
    dy[9] = a_c


@njit(cache=True)
def five_axis_step_batch(
    q, qd, tau, u_pending, command, t0, T, n_sub, delay, ip, jp, pidx, applied_out
):
    """Advance every env of the batch by one servo period T (s), in place.

    q, qd, tau, u_pending (B, 5): joints (m, rad), joint rates, applied (lagged) torque and
    the delayed command (N, N·m); command (B, 5): the command computed at this sample. With
    ``delay`` the command applied over this period is u_pending and command is stored.
    ip (P, IP_SIZE) and jp (P, 5, JP_SIZE): inertial and per-joint parameter sets, pidx (B,)
    int64 the set of each env. applied_out (B, 5) receives the saturated applied command.
    t0 (s) is the period's start time (the model is time-invariant; kept for the common step
    signature). n_sub fixed RK4 substeps of T / n_sub.
    """
    n_env = q.shape[0]
    y = np.empty(NS)
    yt = np.empty(NS)
    k = np.empty((4, NS))
    u = np.empty(5)
    h = T / n_sub
    for b in range(n_env):
        p = pidx[b]
        for j in range(5):
            uj = delayed_saturated(delay, u_pending, command, b, j, jp[p, j, J_LIMIT])
            u[j] = uj
            applied_out[b, j] = uj
            y[j] = q[b, j]
            y[5 + j] = qd[b, j]
            y[10 + j] = tau[b, j]
        for _ in range(n_sub):
            _deriv(y, u, ip, jp, p, k[0])
            for r in range(NS):
                yt[r] = y[r] + 0.5 * h * k[0, r]
            _deriv(yt, u, ip, jp, p, k[1])
            for r in range(NS):
                yt[r] = y[r] + 0.5 * h * k[1, r]
            _deriv(yt, u, ip, jp, p, k[2])
            for r in range(NS):
                yt[r] = y[r] + h * k[2, r]
            _deriv(yt, u, ip, jp, p, k[3])
            for r in range(NS):
                y[r] += (h / 6.0) * (k[0, r] + 2.0 * k[1, r] + 2.0 * k[2, r] + k[3, r])
        for j in range(5):
            q[b, j] = y[j]
            qd[b, j] = y[5 + j]
            # without a current loop the applied torque is the held command itself
            tau[b, j] = y[10 + j] if jp[p, j, J_TC] > 0.0 else u[j]


@dataclass(frozen=True)
class FiveAxisState:
    """Batch state (B, 5) each: joints q (m, rad), rates qd, applied torque tau (N, N·m, the
    current-loop state) and u_pending (the command waiting out the computation delay)."""

    q: np.ndarray
    qd: np.ndarray
    tau: np.ndarray
    u_pending: np.ndarray

    def copy(self) -> FiveAxisState:
        return FiveAxisState(self.q.copy(), self.qd.copy(), self.tau.copy(), self.u_pending.copy())


@dataclass(frozen=True)
class PackedFiveAxis:
    """Parameter sets for the compiled step: ip (P, IP_SIZE), jp (P, 5, JP_SIZE), pidx (B,)."""

    ip: np.ndarray
    jp: np.ndarray
    pidx: np.ndarray

    @property
    def n_envs(self) -> int:
        return self.pidx.shape[0]


def pack_five_axis(params_list: list[FiveAxisParams]) -> PackedFiveAxis:
    """Pack one FiveAxisParams per env (same servo period and substeps required)."""
    first = params_list[0]
    for p in params_list[1:]:
        if p.servo_period_s != first.servo_period_s or p.rk4_substeps != first.rk4_substeps:
            raise ValueError(
                "params: every env of a batch needs the same servo period and substeps"
            )
    index: dict[int, int] = {}
    distinct: list[FiveAxisParams] = []
    pidx = np.empty(len(params_list), dtype=np.int64)
    for b, p in enumerate(params_list):
        if id(p) not in index:
            index[id(p)] = len(distinct)
            distinct.append(p)
        pidx[b] = index[id(p)]
    ip = np.stack([p.inertia.packed() for p in distinct])
    jp = np.stack([p.packed_joints() for p in distinct])
    assert ip.shape[1] == IP_SIZE and jp.shape[2] == JP_SIZE
    return PackedFiveAxis(ip, jp, pidx)


class FiveAxisPlant:
    """The five-axis A–C table machine as a plant: ``M ξ̈ + C ξ̇ + g + f_friction = τ``.

    Parameters
    ----------
    plant : str or FiveAxisParams
        ``"nxv560a"`` (the named set) or custom FiveAxisParams (then true = nominal).
    ideal : bool
        True: the true plant is the paper's model (no friction, delay, lag or mismatch).

    Attributes
    ----------
    params : FiveAxisParams   the simulated (true) plant.
    nominal : FiveAxisParams  the model controllers are given.
    """

    n_axes = 5
    axis_names = ("x", "y", "z", "A", "C")

    def __init__(self, plant="nxv560a", *, ideal: bool = False):
        if isinstance(plant, FiveAxisParams):
            self.params = self.nominal = plant
        elif isinstance(plant, str):
            self.params, self.nominal = five_axis_params(plant, ideal=ideal)
        else:
            raise ValueError(
                f"plant: expected a five-axis plant name or FiveAxisParams, got {plant!r}"
            )
        self.packed = pack_five_axis([self.params])

    @property
    def servo_period_s(self) -> float:
        return self.params.servo_period_s

    @property
    def name(self) -> str:
        return self.params.name

    @property
    def geometry(self):
        return self.params.geometry

    def initial_state(self, q0) -> FiveAxisState:
        """At rest at joints q0 (B, 5) or (5,) within the travel, the drives holding the
        gravity load (applied and pending torque = g(q0)), so the machine does not sag."""
        q0 = np.atleast_2d(self.params.geometry.check_joint(q0, name="q0")).copy()
        hold = gravity(q0, self.params.inertia)
        return FiveAxisState(q0, np.zeros_like(q0), hold.copy(), hold.copy())

    def packed_batch(self, n_env: int) -> PackedFiveAxis:
        """n_env identical envs sharing one parameter set."""
        return PackedFiveAxis(self.packed.ip, self.packed.jp, np.zeros(n_env, dtype=np.int64))

    def step(
        self,
        state: FiveAxisState,
        command,
        time_s: float,
        packed: PackedFiveAxis | None = None,
    ) -> tuple[FiveAxisState, np.ndarray]:
        """Advance by one servo period from ``time_s``. Pure: returns (new state, applied).

        command (B, 5) in N (x, y, z) and N·m (A, C), saturated at ``drive_limit_N_Nm``;
        ``applied`` is the command after delay and saturation.
        """
        command = np.asarray(command, dtype=np.float64)
        if command.ndim == 1:
            command = command[None, :]
        if command.shape != state.q.shape:
            raise ValueError(f"command: expected shape {state.q.shape}, got {command.shape}")
        if not np.all(np.isfinite(command)):
            raise ValueError("command: must be finite (got NaN or inf)")
        if not math.isfinite(time_s):
            raise ValueError(f"time_s: must be finite, got {time_s}")
        if packed is None:
            packed = self.packed_batch(command.shape[0])
        if packed.n_envs != command.shape[0]:
            raise ValueError(
                f"packed: built for {packed.n_envs} envs, command has {command.shape[0]}"
            )
        new = state.copy()
        applied = np.empty_like(command)
        five_axis_step_batch(
            new.q,
            new.qd,
            new.tau,
            new.u_pending,
            np.ascontiguousarray(command),
            float(time_s),
            self.servo_period_s,
            self.params.rk4_substeps,
            self.params.computation_delay,
            packed.ip,
            packed.jp,
            packed.pidx,
            applied,
        )
        return new, applied

    def measure(self, state: FiveAxisState) -> np.ndarray:
        """Encoder reading of the joints (B, 5): rounded to the resolution (0: exact)."""
        res = self.params.encoder_resolution_m_rad
        safe = np.where(res > 0, res, 1.0)
        return np.where(res > 0, np.round(state.q / safe) * safe, state.q)
