"""The plant object: true parameters, the nominal model controllers are given, and the packed
arrays the compiled step reads. Its :meth:`Plant.step` is a pure function of (state, command).
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from .catalog import resolve_plant
from .discretize import continuous_model, discretize, state_size
from .kernel import (
    NL_AD,
    NL_FC,
    NL_FD,
    NL_FMAX,
    NL_FS,
    NL_INV_RES,
    NL_KR,
    NL_MASS,
    NL_PHASE,
    NL_PR,
    NL_RES,
    NL_SIZE,
    NL_VS,
    NL_WD,
    n_sub_levels,
    plant_step_batch,
    sub_level_lengths,
)
from .kernel import NL_AR as _NL_AR
from .params import PlantParams


@dataclass(frozen=True)
class PlantState:
    """Batch state: z (B, A, ns) linear states (position index 0, velocity index 1, SI);
    stuck (B, A) 1.0 while held by static friction; u_pending (B, A) the delayed command."""

    z: np.ndarray
    stuck: np.ndarray
    u_pending: np.ndarray

    @property
    def position(self) -> np.ndarray:
        return self.z[:, :, 0]

    @property
    def velocity(self) -> np.ndarray:
        return self.z[:, :, 1]

    def copy(self) -> PlantState:
        return PlantState(self.z.copy(), self.stuck.copy(), self.u_pending.copy())


@dataclass(frozen=True)
class PackedPlant:
    """Per-(parameter set, axis) arrays for the compiled kernel (see contour_env.plants.kernel)
    and the env → parameter-set map ``pidx`` (B,) int64."""

    mat_T: np.ndarray
    mat_h: np.ndarray
    cont: np.ndarray
    nl: np.ndarray
    pidx: np.ndarray

    @property
    def n_envs(self) -> int:
        return self.pidx.shape[0]

    def __iter__(self):
        """The arrays in field order, as the compiled plant step takes them
        (``plant_step_batch(..., *packed, ...)``; the env's ``PlantArrays`` record has the
        same fields in the same order)."""
        return (getattr(self, f.name) for f in fields(self))


def pack_params(params_list: list[PlantParams]) -> PackedPlant:
    """Discretise and pack one PlantParams per env (identical structure required)."""
    first = params_list[0]
    ns = state_size(first)
    T = first.servo_period_s
    n_sub = first.friction_substeps
    for p in params_list[1:]:
        if state_size(p) != ns or p.n_axes != first.n_axes or p.servo_period_s != T:
            raise ValueError(
                "params: every env of a batch needs the same axes, state layout and servo period"
            )
    # discretise only the distinct parameter sets (a batch of identical envs costs one expm and
    # shares one set of arrays, which then stays in cache)
    index: dict[int, int] = {}
    distinct: list[PlantParams] = []
    pidx = np.empty(len(params_list), dtype=np.int64)
    for b, p in enumerate(params_list):
        if id(p) not in index:
            index[id(p)] = len(distinct)
            distinct.append(p)
        pidx[b] = index[id(p)]
    n_sets, n_axes = len(distinct), first.n_axes
    mat_T = np.empty((n_sets, n_axes, ns, ns + 3))
    n_levels = n_sub_levels(n_sub)
    mat_h = np.empty((n_sets * n_levels, n_axes, ns, ns + 3))
    cont = np.empty((n_sets, n_axes, ns + 2))
    nl = np.zeros((n_sets, n_axes, NL_SIZE))
    for q, p in enumerate(distinct):
        A, Bu, Bw = continuous_model(p)
        steps = [(mat_T, q, T)] + [
            (mat_h, q * n_levels + level, h) for level, h in enumerate(sub_level_lengths(T, n_sub))
        ]
        for out, row, h in steps:
            Phi, Gu, Ga, Gb = discretize(A, Bu, Bw, h)
            out[row] = np.concatenate([Phi, Gu[..., None], Ga[..., None], Gb[..., None]], axis=-1)
        cont[q] = np.concatenate([A[:, 1, :], Bu[:, 1:2], Bw[:, 1:2]], axis=1)
        v = nl[q]
        v[:, NL_FC] = p.coulomb_N
        v[:, NL_FS] = p.static_N
        v[:, NL_VS] = p.stribeck_velocity_m_s
        v[:, _NL_AR] = p.ripple_amplitude_N
        v[:, NL_PR] = p.ripple_period_m
        v[:, NL_AD] = p.disturbance_amplitude_N
        v[:, NL_FD] = p.disturbance_frequency_hz
        v[:, NL_PHASE] = np.arange(n_axes) * (np.pi / 2)
        v[:, NL_FMAX] = p.force_limit_N
        v[:, NL_RES] = p.encoder_resolution_m
        v[:, NL_MASS] = p.mass_kg
        period = np.asarray(p.ripple_period_m, dtype=float)
        res = np.asarray(p.encoder_resolution_m, dtype=float)
        v[:, NL_KR] = np.where(period > 0, 2.0 * np.pi / np.where(period > 0, period, 1.0), 0.0)
        v[:, NL_WD] = 2.0 * np.pi * np.asarray(p.disturbance_frequency_hz, dtype=float)
        v[:, NL_INV_RES] = np.where(res > 0, 1.0 / np.where(res > 0, res, 1.0), 0.0)
    return PackedPlant(mat_T, mat_h, cont, nl, pidx)


class Plant:
    """An n-axis feed drive: ``m ẍ + b ẋ + f_friction(ẋ) + f_ripple(x) + d(t) = sat(u)``.

    Parameters
    ----------
    plant : str, mapping or PlantParams
        A named plant (``hsm2``, ``jee-triaxial``, ``linear-motor``, ``friction-table``), a
        plain mapping of custom parameters (see :func:`params_from_mapping`) or PlantParams.
    ideal : bool
        True: the true plant is the paper's model (no delay, lag, added friction or ripple,
        mismatch). False (default): the documented realistic effects of the named plant.
    structural_mode : bool
        Add the axial two-mass (ball-screw) mode of the named plant.
    true_scale : mapping, optional
        Named plants: per-axis factors true = nominal × factor replacing the realistic
        mismatch of those fields (a payload: ``{"mass_kg": (1.3, 1.3)}``); see
        :func:`~contour_env.plants.catalog.resolve_plant`.

    Attributes
    ----------
    params : PlantParams   the true plant that is simulated.
    nominal : PlantParams  the model controllers are given.
    effects : dict         what is switched on (for reports).
    """

    def __init__(
        self,
        plant="hsm2",
        *,
        ideal: bool = False,
        structural_mode: bool = False,
        true_scale=None,
    ):
        self.params, self.nominal, self.effects = resolve_plant(
            plant, ideal=ideal, structural_mode=structural_mode, true_scale=true_scale
        )
        self.packed = pack_params([self.params])

    @property
    def n_axes(self) -> int:
        return self.params.n_axes

    @property
    def servo_period_s(self) -> float:
        return self.params.servo_period_s

    @property
    def name(self) -> str:
        return self.params.name

    def initial_state(self, position: np.ndarray) -> PlantState:
        """At rest at ``position`` (B, A) metres; stuck where there is static friction."""
        position = np.atleast_2d(np.asarray(position, dtype=np.float64))
        n_env, n_axes = position.shape
        if n_axes != self.n_axes:
            raise ValueError(f"position: expected {self.n_axes} axes, got {n_axes}")
        ns = state_size(self.params)
        z = np.zeros((n_env, n_axes, ns))
        z[:, :, 0] = position
        if self.params.has_structural_mode:
            z[:, :, 2] = position
        stuck = np.broadcast_to(
            (self.params.static_N > 0).astype(np.float64), (n_env, n_axes)
        ).copy()
        return PlantState(z, stuck, np.zeros((n_env, n_axes)))

    def packed_batch(self, n_env: int) -> PackedPlant:
        """n_env identical envs sharing one parameter set."""
        p = self.packed
        return PackedPlant(p.mat_T, p.mat_h, p.cont, p.nl, np.zeros(n_env, dtype=np.int64))

    def step(
        self,
        state: PlantState,
        command: np.ndarray,
        time_s: float,
        packed: PackedPlant | None = None,
    ) -> tuple[PlantState, np.ndarray]:
        """Advance by one servo period from ``time_s``. Pure: returns (new state, applied).

        command (B, A) in N (velocity-command units for ``jee-triaxial``); it is saturated at
        ``params.force_limit_N``. ``applied`` is the command after delay and saturation.
        """
        command = np.asarray(command, dtype=np.float64)
        if command.ndim == 1:
            command = command[None, :]
        if command.shape != state.stuck.shape:
            raise ValueError(f"command: expected shape {state.stuck.shape}, got {command.shape}")
        if not np.all(np.isfinite(command)):
            raise ValueError("command: must be finite (got NaN or inf)")
        new = state.copy()
        if packed is None:
            packed = self.packed_batch(command.shape[0])
        if packed.n_envs != command.shape[0]:
            raise ValueError(
                f"packed: built for {packed.n_envs} envs, command has {command.shape[0]}"
            )
        applied = np.empty_like(command)
        plant_step_batch(
            new.z,
            new.stuck,
            new.u_pending,
            np.ascontiguousarray(command),
            float(time_s),
            self.servo_period_s,
            self.params.friction_substeps,
            self.params.computation_delay,
            *packed,
            applied,
            np.zeros_like(command),
        )
        return new, applied


def quantize(position: np.ndarray, resolution: np.ndarray) -> np.ndarray:
    """Encoder reading: position rounded to the nearest count (resolution 0: exact)."""
    res = np.asarray(resolution, dtype=np.float64)
    safe = np.where(res > 0, res, 1.0)
    return np.where(res > 0, np.round(position / safe) * safe, position)
