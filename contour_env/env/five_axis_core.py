"""Batch state of the five-axis env: the :class:`EnvCore` interface over the five-axis
machine (Chen, Khong & Hsieh 2022), stepped by :mod:`contour_env.env.five_axis_kernel`.

``ContouringEnv`` / ``ContouringVectorEnv`` wrap a FiveAxisCore exactly as they wrap an
EnvCore (``make_core`` chooses by the plant); what differs is documented here.

## Action

(B, 5) in [−1, 1]: each joint's command as a fraction of its drive limit
(``plant.params.force_limit_N`` = ``drive_limit_N_Nm``: 8, 10, 12 kN and 1500, 600 N·m on
x, y, z, A, C), clipped, delayed one period and saturated by the plant.

## Observation (22 values, float32, clipped to ±obs_clip), from the *measured* joints

| index | field (unit before scaling) | scale |
|---|---|---|
| 0 .. 4 | ξ_d − ξ_m: joint errors x, y, z, A, C (m, rad) | / error_obs_scale_m |
| 5 .. 9 | ξ̇_d − ξ̇_m: joint-rate errors (m/s, rad/s; backward diff.) | / verr scale (*) |
| 10 .. 12 | p_d − p(ξ_m): tool-tip error in the workpiece frame (m) | / error_obs_scale_m |
| 13 .. 15 | (o_d − o(ξ_m)) · L: tool-vector error times the lever L (m) | / error_obs_scale_m |
| 16 | reference tip feed ṡ (m/s) | / the case's peak feed |
| 17 .. 21 | previous action | – |

(*) velocity_error_obs_scale_m_s. Rotary joints use the same numbers in rad and rad/s.

## Reward and guards

The task-space error of a step is e_task = ε + L · θ: ε the true tool-tip contour error (m,
the distance from the tip to the reference tip path) and θ the orientation error (rad, the
angle between the tool vector and the reference tool vector at the nearest path point),
weighted by the lever L = ``geometry.dtool_m`` (0.15 m, tool plus holder): L · θ is how far
a tool tilted by θ about its tip moves its holder end, so 1″ of orientation error counts
as 0.73 µm. While running:

    r = −(w_contour · (ε + L θ) + w_lag · ‖p_d − p‖) / contour_error_scale_m − w_effort ‖a‖² / 5

with p_d − p the true tool-tip tracking error (m). Guards (``termination_reason``), in this
order: ε + L θ > ``abort_contour_error_m`` (``"contour_error_limit"``); ‖p_d − p‖ >
``abort_tracking_error_m`` (``"tracking_error_limit"``); a non-finite state
(``"non_finite_state"``). A terminated step earns −P · (n_steps − k), P =
``config.guard_penalty``, as in ContouringEnv: no running step costs more than P, so ending
early never pays and a machine that stands still (its spindle head sags under gravity and
the reference tip leaves it) scores about −P per remaining step, far below PD.

## Info

The keys of ContouringEnv (``position`` = true joints, ``measured_position``, ``velocity``,
``reference`` = ξ_d, ``tracking_error`` = ξ_d − ξ, ``force`` = applied drive command (N,
N·m), ``saturated``, ``time``, ``step``, ``termination_reason``), with ``contour_error`` the
true tool-tip contour error ε (m), and ``tool_tip`` (m, workpiece frame), ``tool_vector``
(unit), ``orientation_error`` θ (rad), ``reference_tool_tip`` p_d (m). No
``contour_error_estimate``.

Not on the five-axis plant (ValueError): ``measurement_noise_std_m``,
``disturbance_force_N`` (> 0) and ``plant_params`` other than FiveAxisParams.
"""

from __future__ import annotations

import math

import numpy as np

from ..plants.five_axis import FiveAxisParams, gravity, pack_five_axis
from ..plants.params import one_params_per_env
from . import five_axis_kernel as K5
from .core import record_from
from .layout import REASON_BY_STATUS, TERMINATION_REASONS, StepOutputs, zero_outputs

# half-width of the nearest-point search (reference samples) around the last nearest one;
# the tip moves about one sample per step, so 64 samples leave a wide margin while it lags
SEARCH_HALF_WINDOW = 64

_REASON_BY_STATUS = np.array(REASON_BY_STATUS)  # indexed by status code, batched info

# per-env info arrays: key → (trailing shape, dtype)
_INFO_FIELDS = {
    "time": ((), np.float64),
    "step": ((), np.int64),
    "position": ((5,), np.float64),
    "measured_position": ((5,), np.float64),
    "velocity": ((5,), np.float64),
    "reference": ((5,), np.float64),
    "contour_error": ((), np.float64),
    "orientation_error": ((), np.float64),
    "tracking_error": ((5,), np.float64),
    "force": ((5,), np.float64),
    "saturated": ((5,), np.bool_),
    "tool_tip": ((3,), np.float64),
    "tool_vector": ((3,), np.float64),
    "reference_tool_tip": ((3,), np.float64),
}
_SCALARS = ("time", "contour_error", "orientation_error")


class _StepThreads:
    """The five-axis step runs on the calling thread (``num_threads`` is accepted and kept
    for the common interface; the results do not depend on it)."""

    def __init__(self, num_threads):
        if not (
            num_threads is None
            or num_threads == "auto"
            or (
                isinstance(num_threads, (int, np.integer))
                and not isinstance(num_threads, bool)
                and num_threads >= 1
            )
        ):
            raise ValueError(
                f"num_threads: must be an integer >= 1, None or 'auto', got {num_threads!r}"
            )
        self.requested = "auto" if num_threads in (None, "auto") else int(num_threads)


class FiveAxisCore:
    """A batch of ``n_envs`` five-axis envs on one setup (module docstring)."""

    def __init__(self, setup, config, n_envs: int = 1, plant_params=None, num_threads=None):
        if not isinstance(n_envs, (int, np.integer)) or isinstance(n_envs, bool) or n_envs < 1:
            raise ValueError(f"num_envs: must be an integer >= 1, got {n_envs!r}")
        for name in ("measurement_noise_std_m", "disturbance_force_N"):
            if getattr(config, name) != 0:
                raise ValueError(f"{name}: not available on the five-axis plant (must be 0)")
        self.setup = setup
        self.config = config
        self.n_envs = B = int(n_envs)
        self.threads = _StepThreads(num_threads)
        machine = setup.plant
        true = machine.plant.params
        ref = setup.reference
        self.dim = 5
        self.T = float(machine.servo_period_s)
        self.n_steps = ref.n_steps
        if not math.isfinite(config.guard_penalty * ref.n_steps):
            raise ValueError(
                f"w_contour, w_lag, w_effort, contour_error_scale_m: the guard penalty P = "
                f"{config.guard_penalty:g} times the {ref.n_steps} steps must be finite"
            )
        if plant_params is None:
            self.packed = machine.plant.packed_batch(B)
        else:
            self.packed = pack_five_axis(_checked_five_axis_params(plant_params, true, B))
        self.force_limit = np.array(true.drive_limit_N_Nm, dtype=np.float64)
        self.resolution = np.array(true.encoder_resolution_m_rad, dtype=np.float64)
        # reference tables (contiguous, float64)
        self.ref_q = np.ascontiguousarray(ref.joints)
        self.ref_qd = np.ascontiguousarray(ref.joint_rate)
        self.ref_qdd = np.ascontiguousarray(ref.joint_accel)
        self.ref_tip = np.ascontiguousarray(ref.tip_m)
        self.ref_tool = np.ascontiguousarray(ref.tool)
        self.ref_feed = np.ascontiguousarray(ref.feedrate_m_s)
        # the layout run_episode and the renderer read for every plant: (n, 3, 5) = ξ_d, ξ̇_d, ξ̈_d
        self.ref_pav = np.ascontiguousarray(np.stack([self.ref_q, self.ref_qd, self.ref_qdd], 1))
        geom = machine.geometry
        self.lever_m = float(geom.dtool_m)
        cfg = np.zeros(K5.F_SIZE)
        cfg[K5.F_T] = self.T
        cfg[K5.F_ERR_SCALE] = config.error_obs_scale_m
        cfg[K5.F_VERR_SCALE] = config.velocity_error_obs_scale_m_s
        cfg[K5.F_FEED_SCALE] = max(float(np.max(np.abs(self.ref_feed))), 1e-12)
        cfg[K5.F_LEVER] = self.lever_m
        cfg[K5.F_EPS_SCALE] = config.contour_error_scale_m
        cfg[K5.F_W_CONTOUR] = config.w_contour
        cfg[K5.F_W_LAG] = config.w_lag
        cfg[K5.F_W_EFFORT] = config.w_effort
        cfg[K5.F_ABORT_CONTOUR] = config.abort_contour_error_m
        cfg[K5.F_ABORT_TRACK] = config.abort_tracking_error_m
        cfg[K5.F_GUARD_PENALTY] = config.guard_penalty
        cfg[K5.F_OBS_CLIP] = config.obs_clip
        cfg[K5.F_D4] = geom.d4_m
        cfg[K5.F_TIP_OFFSET] = geom.tip_offset_m
        self.cfg = cfg
        self.icfg = np.array(
            [self.n_steps, true.rk4_substeps, int(true.computation_delay), SEARCH_HALF_WINDOW],
            dtype=np.int64,
        )
        # the drives hold gravity at the start pose (FiveAxisPlant.initial_state)
        self.q0_hold = gravity(self.ref_q[0][None, :], true.inertia)[0].copy()
        self.obs_dim = K5.OBS_DIM
        self.q = np.zeros((B, 5))
        self.qd = np.zeros((B, 5))
        self.tau = np.zeros((B, 5))
        self.u_pending = np.zeros((B, 5))
        self.meas = np.zeros((B, 5))
        self.mprev = np.zeros((B, 5))
        self.mvel = np.zeros((B, 5))
        self.applied = np.zeros((B, 5))
        self.k = np.zeros(B, dtype=np.int64)
        self.near = np.zeros(B, dtype=np.int64)
        self.eps = np.zeros(B)
        self.orient = np.zeros(B)
        self.tip = np.zeros((B, 3))
        self.tool = np.zeros((B, 3))
        self.status = np.zeros(B, dtype=np.int64)
        self.action = np.zeros((B, 5))
        self.seed = np.zeros(B, dtype=np.uint64)
        self.obs, self.reward, self.terminated, self.truncated = zero_outputs(B, self.obs_dim)
        self.all_active = np.ones(B, dtype=bool)
        self._all_envs = np.arange(B, dtype=np.int64)
        self._fresh_info = None
        self._records = None  # built by records()

    # --- the per-plant layout readers of every core use (run_episode, render) --------------
    @property
    def z(self) -> np.ndarray:
        """(B, 5, 2): true joints and rates (the EnvCore state layout's first two columns)."""
        return np.stack([self.q, self.qd], axis=-1)

    @property
    def ax(self) -> np.ndarray:
        """(AX_SIZE, B, 5) per-joint readouts in the EnvCore rows that readers use
        (AX_APPLIED, AX_MEAS, AX_VEL, AX_REF, AX_SAT); a new array at every read."""
        from . import kernel as K

        out = np.zeros((K.AX_SIZE, self.n_envs, 5))
        out[K.AX_APPLIED] = self.applied
        out[K.AX_MEAS] = self.meas
        out[K.AX_VEL] = self.mvel
        out[K.AX_REF] = self.ref_q[np.minimum(self.k, self.n_steps - 1)]
        out[K.AX_SAT] = np.abs(self.applied) >= self.force_limit * (1 - 1e-12)
        return out

    @property
    def num_threads(self):
        return self.threads.requested

    @num_threads.setter
    def num_threads(self, value) -> None:
        self.threads = _StepThreads(value)

    # --- episode control -------------------------------------------------------------------
    def _env_indices(self, envs) -> np.ndarray:
        envs = np.ascontiguousarray(envs, dtype=np.int64).reshape(-1)
        if envs.size and (envs.min() < 0 or envs.max() >= self.n_envs):
            raise ValueError(f"envs: indices must be in [0, {self.n_envs}), got {envs.tolist()}")
        return envs

    def records(self) -> tuple:
        """The kernel's records (path, env state, plant arrays, outputs: the named tuples of
        :mod:`contour_env.env.five_axis_kernel`), each field this core's attribute of that
        name (the plant's parameter sets from ``packed``). Built once: the core never
        replaces those arrays, except the outputs in :meth:`renew_outputs`, which builds that
        record again."""
        if self._records is None:
            self._set_records(
                (
                    record_from(K5.FiveAxisPath, self),
                    record_from(K5.FiveAxisEnvState, self),
                    record_from(K5.FiveAxisPlantArrays, self, self.packed),
                    record_from(StepOutputs, self),
                )
            )
        return self._records

    def _set_records(self, records: tuple) -> None:
        self._records = records
        self._flat_arrays = tuple(a for record in records for a in record)

    def _flat(self) -> tuple:
        # the records' arrays in their declared order, as the kernel's entry points take them
        if self._records is None:
            self.records()
        return self._flat_arrays

    def reset_env(self, b: int, noise_seed: int) -> None:
        self.reset_envs(np.array([b], dtype=np.int64), [noise_seed])

    def reset_envs(self, envs, noise_seeds) -> None:
        """Reset the envs ``envs`` at rest on the start of the reference. The seeds are kept
        (the five-axis env has no random element: every episode is the same)."""
        envs = self._env_indices(envs)
        noise_seeds = list(noise_seeds)
        if len(noise_seeds) != envs.size:
            raise ValueError(f"noise_seeds: one per env ({envs.size}), got {len(noise_seeds)}")
        self.seed[envs] = np.array([int(s) % (1 << 64) for s in noise_seeds], dtype=np.uint64)
        K5.reset_envs(envs, self.cfg, self.icfg, *self._flat())

    def step(
        self,
        action: np.ndarray,
        active: np.ndarray,
        info_arrays=None,
        fresh_outputs=False,
        carry_inactive=True,
    ) -> int:
        """Advance the active envs with ``action`` (B, 5) in [-1, 1]; raises on NaN/inf.
        Returns the number of stepped envs whose episode has now ended. ``info_arrays``
        (:meth:`new_info_arrays`) are filled for the stepped envs; with ``fresh_outputs``
        obs, reward, terminated and truncated are new arrays (as EnvCore.step; they are copies
        here, so every row carries over whatever ``carry_inactive`` says)."""
        action = np.ascontiguousarray(action, dtype=np.float64)
        if action.shape != (self.n_envs, 5):
            raise ValueError(f"action: expected shape ({self.n_envs}, 5), got {action.shape}")
        active = np.ascontiguousarray(active, dtype=np.bool_)
        self.refuse_nonfinite(action, active)
        if fresh_outputs:
            self.renew_outputs()
        _, _, n_ended = K5.env_step(self.cfg, self.icfg, action, active, *self._flat())
        if info_arrays is not None:
            self.fill_info(info_arrays, np.flatnonzero(active))
        return int(n_ended)

    def refuse_nonfinite(self, action: np.ndarray, rows: np.ndarray) -> None:
        """The ValueError of :meth:`step` if the action (B, 5) of an env in ``rows`` (a boolean
        mask) is not finite; for envs whose action is not used (the vector env's autoreset)."""
        bad_rows = rows & ~np.all(np.isfinite(action), axis=1)
        if bad_rows.any():
            b = int(np.argmax(bad_rows))
            raise ValueError(
                f"action: must be finite, got {action[b].tolist()} (env {b}); the action is "
                "the per-joint command in [-1, 1] of the drive limit"
            )

    def renew_outputs(self) -> None:
        """New obs, reward, terminated and truncated arrays (copies): arrays handed out
        earlier are never written again."""
        self.obs = self.obs.copy()
        self.reward = self.reward.copy()
        self.terminated = self.terminated.copy()
        self.truncated = self.truncated.copy()
        if self._records is not None:  # the outputs record holds the new arrays
            self._set_records((*self._records[:3], record_from(StepOutputs, self)))

    # --- info ------------------------------------------------------------------------------
    def new_info_arrays(self) -> dict:
        """Fresh arrays (leading axis B) for :meth:`step` / :meth:`fill_info` to fill."""
        B = self.n_envs
        arrays = {k: np.zeros((B, *shape), dtype=dt) for k, (shape, dt) in _INFO_FIELDS.items()}
        self._fresh_info = arrays
        return arrays

    def fill_info(self, info_arrays: dict, envs) -> None:
        """Fill the info of the envs ``envs`` from their current state."""
        if not isinstance(info_arrays, dict) or set(info_arrays) != set(_INFO_FIELDS):
            raise ValueError("info_arrays: expected the arrays of new_info_arrays()")
        e = self._env_indices(envs)
        kk = np.minimum(self.k[e], self.n_steps - 1)
        a = info_arrays
        a["time"][e] = self.k[e] * self.T
        a["step"][e] = self.k[e]
        a["position"][e] = self.q[e]
        a["measured_position"][e] = self.meas[e]
        a["velocity"][e] = self.qd[e]
        a["reference"][e] = self.ref_q[kk]
        a["contour_error"][e] = self.eps[e]
        a["orientation_error"][e] = self.orient[e]
        a["tracking_error"][e] = self.ref_q[kk] - self.q[e]
        a["force"][e] = self.applied[e]
        a["saturated"][e] = np.abs(self.applied[e]) >= self.force_limit * (1 - 1e-12)
        a["tool_tip"][e] = self.tip[e]
        a["tool_vector"][e] = self.tool[e]
        a["reference_tool_tip"][e] = self.ref_tip[kk]

    def info_of(self, info_arrays: dict, b: int) -> dict:
        """The ``info`` of env b from filled info arrays."""
        out = {}
        for key, arr in info_arrays.items():
            v = arr[b]
            out[key] = float(v) if key in _SCALARS else (int(v) if key == "step" else v)
        out["termination_reason"] = TERMINATION_REASONS.get(int(self.status[b]))
        return out

    def info_dict(self, info_arrays: dict) -> dict:
        """The batched ``info`` (leading axis B) from filled arrays."""
        out = dict(info_arrays)
        out["termination_reason"] = _REASON_BY_STATUS[self.status]
        return out

    def info(self, b: int) -> dict:
        arrays = self.new_info_arrays()
        self.fill_info(arrays, [b])
        return {
            k: (v.copy() if isinstance(v, np.ndarray) else v)
            for k, v in self.info_of(arrays, b).items()
        }

    def batch_info(self) -> dict:
        arrays = self.new_info_arrays()
        self.fill_info(arrays, self._all_envs)
        return self.info_dict(arrays)

    # --- servo signals ---------------------------------------------------------------------
    def signals_batch(self) -> dict:
        """:meth:`signals` of every env, stacked (leading axis B)."""
        kk = np.minimum(self.k, self.n_steps - 1)
        return {
            "time": self.k * self.T,
            "step": self.k.copy(),
            "measured_position": self.meas.copy(),
            "measured_velocity": self.mvel.copy(),
            "reference_position": self.ref_q[kk],
            "reference_velocity": self.ref_qd[kk],
            "reference_acceleration": self.ref_qdd[kk],
            "reference_tool_tip": self.ref_tip[kk],
            "reference_tool_vector": self.ref_tool[kk],
            "feedrate": self.ref_feed[kk],
            "servo_period_s": self.T,
        }

    def signals(self, b: int = 0) -> dict:
        """What the five-axis servo measures at the current sample of env b (SI): measured
        joints (encoder) and rates (backward difference), the joint reference ξ_d, ξ̇_d, ξ̈_d,
        the reference tool tip and tool vector, the tip feed, the reference index ``step``
        and the servo period."""
        kk = min(int(self.k[b]), self.n_steps - 1)
        return {
            "time": float(self.k[b]) * self.T,
            "step": int(self.k[b]),
            "measured_position": self.meas[b].copy(),
            "measured_velocity": self.mvel[b].copy(),
            "reference_position": self.ref_q[kk].copy(),
            "reference_velocity": self.ref_qd[kk].copy(),
            "reference_acceleration": self.ref_qdd[kk].copy(),
            "reference_tool_tip": self.ref_tip[kk].copy(),
            "reference_tool_vector": self.ref_tool[kk].copy(),
            "feedrate": float(self.ref_feed[kk]),
            "servo_period_s": self.T,
        }


def _checked_five_axis_params(plant_params, base, n_envs: int) -> list:
    plant_params = one_params_per_env(plant_params, FiveAxisParams, n_envs)
    for b, p in enumerate(plant_params):
        if not isinstance(p, FiveAxisParams):
            raise ValueError(
                f"plant_params[{b}]: expected a FiveAxisParams (the five-axis plant), got "
                f"{type(p).__name__}"
            )
        for key in ("servo_period_s", "rk4_substeps", "computation_delay"):
            if getattr(p, key) != getattr(base, key):
                raise ValueError(
                    f"plant_params[{b}]: {key} must be the case plant's "
                    f"({getattr(base, key)!r}), got {getattr(p, key)!r}"
                )
    return plant_params
