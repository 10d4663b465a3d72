"""Batch state and configuration behind both the single and the vectorised env.

:class:`EnvCore` owns the arrays the compiled kernel (:mod:`contour_env.env.kernel`) reads and
writes; the Gymnasium classes are thin layers over it.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numba
import numpy as np

from ..cases import Setup
from ..metrics import FOLLOW_LIMIT_M
from ..plants import PlantParams, pack_params
from ..plants.discretize import state_size
from ..plants.params import check_param_ranges, one_params_per_env
from . import kernel as K
from .layout import (
    CFG_FIELDS,
    ICFG_FIELDS,
    INFO_KEYS,
    REASON_BY_STATUS,
    TERMINATION_REASONS,
    EnvState,
    PathArrays,
    PlantArrays,
    StepOutputs,
    obs_dim,
    zero_outputs,
)

PARALLEL_MIN_ENVS = 256


class StepThreads:
    """How many threads step a batch: the env option ``num_threads``.

    ``None`` or ``"auto"`` (the default): batches below :data:`PARALLEL_MIN_ENVS` envs step on
    the calling thread; larger ones time their own steps and keep the fastest thread count. A
    probe tries each candidate (1, 2, 4, … up to numba's thread count) for a few steps and keeps
    the winner for :attr:`HOLD_S` seconds (doubling, up to :attr:`MAX_HOLD_S`, while probes
    keep the same winner), then probes again, and at once if the steps grow
    :attr:`SLOWDOWN`× slower than the probe measured (another process, or torch's threads
    in this process, took the cores); a candidate far slower than one already probed is
    dropped after its first timed step (its untimed first step, which wakes the thread pool,
    never decides); the fewest threads are re-probed at the shortest hold. So a busy machine
    gets fewer threads, down to the serial driver, instead of a thread team that waits at
    every step for a member whose core is taken. An integer n ≥ 1: always n threads (1: the
    serial driver; capped at numba's thread count). The results are bit-identical for any
    count: each env is stepped by the same arithmetic whichever thread runs it.
    """

    PROBE_CALLS = 3  # timed steps per candidate and probe (after one untimed step)
    HOLD_S = 1.0  # the first hold after a probe; doubled while probes keep the same winner
    MAX_HOLD_S = 16.0
    SLOWDOWN = 2.0

    def __init__(self, num_threads, n_envs: int):
        if num_threads is None or num_threads == "auto":
            fixed = None
        elif (
            isinstance(num_threads, (int, np.integer))
            and not isinstance(num_threads, bool)
            and num_threads >= 1
        ):
            fixed = int(num_threads)
        else:
            raise ValueError(
                f"num_threads: must be an integer >= 1, None or 'auto', got {num_threads!r}"
            )
        self.requested = "auto" if fixed is None else fixed
        top = max(1, min(int(numba.config.NUMBA_NUM_THREADS), int(n_envs)))
        if fixed is not None:
            self.candidates = (min(fixed, top),)
        elif n_envs < PARALLEL_MIN_ENVS:
            self.candidates = (1,)
        else:
            c = [1]
            while c[-1] * 2 < top:
                c.append(c[-1] * 2)
            if top > 1:
                c.append(top)
            self.candidates = tuple(c)
        self.current = self.candidates[0]
        self._probe = None  # while probing: [candidate index, calls, times per candidate]
        self._best_s = math.inf  # the winner's probe time per step
        self._ema_s = 0.0
        self._hold_s = self.HOLD_S
        self._until = 0.0  # perf_counter time of the next probe
        self.n_probes = 0
        if len(self.candidates) > 1:
            self._start_probe()

    def _start_probe(self):
        self._probe = [0, 0, [[] for _ in self.candidates]]
        self._winner = self.current
        self.current = self.candidates[0]
        self.n_probes += 1

    def _record(self, dt: float, now: float) -> None:
        probe = self._probe
        if probe is None:
            self._ema_s += 0.125 * (dt - self._ema_s)
            if now >= self._until:
                self._start_probe()
            elif self.current > self.candidates[0] and self._ema_s > self.SLOWDOWN * self._best_s:
                # the thread team got slower (the machine got busier): probe now, hold briefly.
                # Not with the fewest threads: fewer are not to be had, and a busier machine
                # does not make more threads pay
                self._hold_s = self.HOLD_S
                self._start_probe()
            return
        i, calls, times = probe
        if calls > 0:  # the first step after a switch is not timed (the threads wake)
            times[i].append(dt)
        calls += 1
        done = [sorted(t)[len(t) // 2] for t in times[:i]]
        # a candidate far slower than one already probed in a *timed* step gets no more steps.
        # Never on its untimed first step: that one includes waking (or, the first time,
        # starting) the thread pool — 28-89 ms against a 1.4 ms serial step at 4,096 envs — and
        # judging it dropped two threads from every first probe (issue 35)
        if calls > self.PROBE_CALLS or (done and calls > 1 and dt > self.SLOWDOWN * min(done)):
            i, calls = i + 1, 0
        if i < len(self.candidates):
            probe[0], probe[1] = i, calls
            self.current = self.candidates[i]
            return
        med = [sorted(t)[len(t) // 2] for t in times]
        best = min(range(len(med)), key=med.__getitem__)
        self.current = self.candidates[best]
        if self.current == self._winner and self.current != self.candidates[0]:
            self._hold_s = min(2.0 * self._hold_s, self.MAX_HOLD_S)
        else:
            # a new winner, or the fewest threads: on those no slowdown can call an early probe
            # (fewer are not to be had), so they are re-probed at the shortest hold — a
            # transient that made more threads lose once does not keep them off for 16 s
            self._hold_s = self.HOLD_S
        self._best_s = self._ema_s = med[best]
        self._probe = None
        self._until = now + self._hold_s

    def __call__(self, args: tuple):
        """Step with ``args`` (the arguments of :func:`kernel.env_step`)."""
        n = self.current
        t0 = time.perf_counter()
        if n == 1:
            result = K.env_step(*args)
        else:
            prev = numba.get_num_threads()
            numba.set_num_threads(n)
            try:
                result = K.env_step_parallel(*args)
            finally:
                numba.set_num_threads(prev)
        if len(self.candidates) > 1:
            now = time.perf_counter()
            self._record(now - t0, now)
        return result


_REASON_BY_STATUS = np.array(REASON_BY_STATUS)  # indexed by status code, batched info


DISTURBANCE_PHASES = ("random", "fixed")


@dataclass(frozen=True)
class EnvConfig:
    """Episode, observation and reward settings (SI units). See ContouringEnv for meanings."""

    abort_contour_error_m: float = 5e-3
    # the tracking-error guard; the default is the score's follow limit (metrics.FOLLOW_LIMIT_M)
    abort_tracking_error_m: float = FOLLOW_LIMIT_M
    contour_error_scale_m: float = 1e-5
    w_contour: float = 1.0
    w_lag: float = 0.0
    w_effort: float = 0.0
    error_obs_scale_m: float = 1e-4
    velocity_error_obs_scale_m_s: float = 1e-2
    curvature_obs_scale_m: float = 0.05
    preview_times_s: tuple = (0.005, 0.02, 0.05)
    measurement_noise_std_m: float = 0.0
    disturbance_force_N: float = 0.0
    obs_clip: float = 10.0
    disturbance_phase: str = "fixed"

    def __post_init__(self):
        positive = (
            "abort_contour_error_m",
            "abort_tracking_error_m",
            "contour_error_scale_m",
            "error_obs_scale_m",
            "velocity_error_obs_scale_m_s",
            "curvature_obs_scale_m",
            "obs_clip",
        )
        nonneg = (
            "w_contour",
            "w_lag",
            "w_effort",
            "measurement_noise_std_m",
            "disturbance_force_N",
        )
        for name in positive + nonneg:
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.number)):
                raise ValueError(f"{name}: expected a number, got {value!r}")
            if not math.isfinite(value) or value < 0 or (name in positive and value == 0):
                rule = "> 0" if name in positive else ">= 0"
                raise ValueError(f"{name}: must be finite and {rule}, got {value!r}")
        if self.disturbance_phase not in DISTURBANCE_PHASES:
            raise ValueError(
                f"disturbance_phase: must be one of {DISTURBANCE_PHASES}, got "
                f"{self.disturbance_phase!r}"
            )
        times = tuple(float(t) for t in self.preview_times_s)
        if not times or any(not math.isfinite(t) or t <= 0 for t in times):
            raise ValueError(f"preview_times_s: non-empty, every time > 0 s, got {times}")
        object.__setattr__(self, "preview_times_s", times)

    @property
    def guard_penalty(self) -> float:
        """P, the penalty (reward units, > 0 unless every weight is 0) of one step at the
        guards: ``(w_contour · abort_contour_error_m + w_lag · abort_tracking_error_m)
        / contour_error_scale_m + w_effort``. No step that runs costs more (ε ≤ the contour
        guard, |e_t| ≤ ‖x_d − x‖ ≤ the tracking guard, ‖a‖²/n ≤ 1); a terminated episode is
        charged P for its last step and for every step it skips."""
        return (
            self.w_contour * self.abort_contour_error_m + self.w_lag * self.abort_tracking_error_m
        ) / self.contour_error_scale_m + self.w_effort


def _checked_plant_params(plant_params, plant, n_envs: int) -> list:
    """``plant_params`` as a list of n_envs PlantParams that fit the case's plant (axes, servo
    period, state layout, delay, substeps: the kernel runs them with the case's reference and
    settings) and lie in the documented ranges (params.PARAM_RANGES); ValueError otherwise."""
    plant_params = one_params_per_env(plant_params, PlantParams, n_envs)
    base = plant.params
    want = (base.n_axes, state_size(base))
    for b, p in enumerate(plant_params):
        label = f"plant_params[{b}]"
        if not isinstance(p, PlantParams):
            raise ValueError(f"{label}: expected a PlantParams, got {type(p).__name__}")
        # servo periods equal within 1e-9 (a period read from a trace's time column carries
        # the last digits of its floating-point sum), shown in full when they differ
        same_T = math.isclose(p.servo_period_s, base.servo_period_s, rel_tol=1e-9)
        if (p.n_axes, state_size(p)) != want or not same_T:
            raise ValueError(
                f"{label}: the case's plant {base.name!r} has {base.n_axes} axes "
                f"{list(base.axis_names)}, servo period {base.servo_period_s!r} s and "
                f"{want[1]} states per axis; got {p.name!r} with {p.n_axes} axes "
                f"{list(p.axis_names)}, servo period {p.servo_period_s!r} s and "
                f"{state_size(p)} states per axis (vary the case's own parameters, e.g. "
                f"env.unwrapped.plant.params.replace(...))"
            )
        for key in ("computation_delay", "friction_substeps"):
            if getattr(p, key) != getattr(base, key):
                raise ValueError(
                    f"{label}: {key} must be the case plant's ({getattr(base, key)!r}), got "
                    f"{getattr(p, key)!r}"
                )
        check_param_ranges(p, label)
    return plant_params


class EnvCore:
    """A batch of ``n_envs`` contouring envs on one setup (case, plant, path, reference)."""

    def __init__(self, setup: Setup, config: EnvConfig, n_envs: int = 1, plant_params=None):
        if not isinstance(n_envs, (int, np.integer)) or n_envs < 1:
            raise ValueError(f"num_envs: must be an integer >= 1, got {n_envs!r}")
        self.setup = setup
        self.config = config
        self.n_envs = int(n_envs)
        plant = setup.plant
        ref = setup.reference
        self.dim = plant.n_axes
        self.T = plant.servo_period_s
        self.n_steps = ref.n_steps
        # custom plants (a mapping is checked when read, a PlantParams here); named plants lie
        # inside the ranges
        check_param_ranges(plant.params, "plant")
        if plant_params is None:
            self.packed = plant.packed_batch(self.n_envs)
        else:
            # one true parameter set per env (robustness studies); controllers keep the nominal
            self.packed = pack_params(_checked_plant_params(plant_params, plant, self.n_envs))
        if not math.isfinite(config.guard_penalty * ref.n_steps):
            raise ValueError(
                f"w_contour, w_lag, w_effort, contour_error_scale_m: the guard penalty P = "
                f"{config.guard_penalty:g} times the {ref.n_steps} steps must be finite"
            )
        self.force_limit = plant.params.force_limit_N.copy()
        # reference tables, in the kernel's layout
        self.ref_pav = np.ascontiguousarray(
            np.stack([ref.position, ref.velocity, ref.acceleration], axis=1)
        )
        self.frame = np.ascontiguousarray(ref.frame)
        self.scal = np.ascontiguousarray(
            np.stack([ref.feedrate, ref.feed_accel, ref.curvature, ref.torsion], axis=1)
        )
        path = setup.path
        self.seg_type = np.ascontiguousarray(path.seg_type, dtype=np.int64)
        self.seg_data = np.ascontiguousarray(path.seg_data, dtype=np.float64)
        self.seg_bounds = np.ascontiguousarray(path.seg_bounds, dtype=np.float64)
        preview = np.array(
            [max(1, round(t / self.T)) for t in config.preview_times_s], dtype=np.int64
        )
        self.preview = preview
        cfg = self._pack_config(config, setup, preview)
        self.cfg = cfg
        # the reference-only part of the observation, per reference index (float32)
        self.obs_tab = np.zeros((self.n_steps, 3 + len(preview) * self.dim), dtype=np.float32)
        K.observation_table(
            cfg, preview, self.ref_pav, self.frame, self.scal, self.n_steps, self.dim, self.obs_tab
        )
        icfg = {
            "NSTEPS": self.n_steps,
            "NSUB": plant.params.friction_substeps,
            "DELAY": int(plant.params.computation_delay),
        }
        self.icfg = np.array([icfg[f.name] for f in ICFG_FIELDS], dtype=np.int64)
        self.obs_dim = obs_dim(self.dim, len(preview))
        B, A = self.n_envs, self.dim
        ns = plant.initial_state(np.zeros((1, A))).z.shape[2]
        self.z = np.zeros((B, A, ns))
        self.ax = np.zeros((K.AX_SIZE, B, A))
        self.k = np.zeros(B, dtype=np.int64)
        self.eps = np.zeros(B)
        self.est = np.zeros((B, A))
        self.status = np.zeros(B, dtype=np.int64)
        self.seed = np.zeros(B, dtype=np.uint64)
        self.obs, self.reward, self.terminated, self.truncated = zero_outputs(B, self.obs_dim)
        # all True, never written: pass this very array to step() to step every env (the core
        # then knows, without a scan, that no env was left out)
        self.all_active = np.ones(B, dtype=bool)
        self._status_clear = False
        # stuck at rest where there is static friction (identical structure across the batch)
        self.stuck0 = (plant.params.static_N > 0).astype(np.float64)
        self.action = np.zeros((B, A))
        self.scratch = np.zeros((2 * B, ns))
        self._all_envs = np.arange(B, dtype=np.int64)
        self._fresh_info = None
        # read-only, so one object serves every step (np.broadcast_to costs ~8 µs a call)
        self._no_reasons = np.broadcast_to(_REASON_BY_STATUS[:1], (B,))
        self._info_spec = [
            ((K.INFO_ROWS, B, A), np.float64),
            ((2, B), np.float64),
            ((B, A), np.bool_),
            ((B,), np.int64),
        ]
        # empty info arrays: the kernel fills none
        self._no_info = (
            np.empty((K.INFO_ROWS, 0, A)),
            np.empty((2, 0)),
            np.empty((0, A), dtype=bool),
            np.empty(0, dtype=np.int64),
        )
        # the step's thread policy (see StepThreads; results are identical either way)
        self.threads = StepThreads(None, B)
        # the records every kernel call takes (fixed for the core's life: the arrays are
        # written in place, never replaced)
        self._records = self.kernel_records()
        # their arrays flat, as the entry points take them (layout.ENTRY_RECORDS)
        self._flat = tuple(a for record in self._records for a in record)

    def _pack_config(self, config: EnvConfig, setup: Setup, preview: np.ndarray) -> np.ndarray:
        """The kernel's float configuration ``cfg``: the slots declared in
        :data:`contour_env.env.layout.CFG_FIELDS` (scales, reward weights, guards, noise; the
        reciprocals the step multiplies by), each from its declared value, then the preview's
        scales after slot CFG_SIZE."""
        cfg = np.zeros(K.CFG_SIZE + len(preview))
        for slot, field in enumerate(CFG_FIELDS):
            cfg[slot] = field.value(config, setup, self.T, self.dim)
        cfg[K.CFG_SIZE :] = 1.0 / (setup.feedrate_m_s * preview * self.T)
        return cfg

    # --- the kernel's arrays, as records (contour_env.env.layout) ---------------------------
    def kernel_records(self) -> tuple:
        """``(EnvState, PathArrays, PlantArrays)`` of this core: its arrays as the compiled
        step's stages take them (the arrays themselves, not copies; each record's fields are
        the core's attributes of the same names, the plant's those of ``packed``)."""
        return (
            record_from(EnvState, self),
            record_from(PathArrays, self),
            record_from(PlantArrays, self.packed),
        )

    def step_outputs(self) -> StepOutputs:
        """The arrays the next step writes its outputs into (obs, reward, terminated,
        truncated)."""
        return record_from(StepOutputs, self)

    # --- readouts of the batch (views: valid until the next step) --------------------------
    @property
    def positions(self) -> np.ndarray:
        """True position of every env's axes (B, A), m (the table side of a two-mass axis)."""
        return self.z[:, :, 0]

    @property
    def applied_force(self) -> np.ndarray:
        """Force applied in the last servo period (B, A), N (after the computation delay)."""
        return self.ax[K.AX_APPLIED]

    @property
    def saturated(self) -> np.ndarray:
        """Whether the last period's force was at the force limit (B, A), bool (a copy)."""
        return self.ax[K.AX_SAT] > 0.0

    @property
    def no_info(self) -> tuple:
        """Empty batched-info arrays: a step given them fills no info."""
        return self._no_info

    # --- episode control -------------------------------------------------------------------
    def reset_env(self, b: int, noise_seed: int) -> None:
        """Reset env b with the episode seed ``noise_seed`` (any integer, taken mod 2⁶⁴)."""
        self.reset_envs(np.array([b], dtype=np.int64), [noise_seed])

    def _env_indices(self, envs) -> np.ndarray:
        # the compiled kernels index without bounds checks: validate here
        envs = np.ascontiguousarray(envs, dtype=np.int64).reshape(-1)
        if envs.size and (envs.min() < 0 or envs.max() >= self.n_envs):
            raise ValueError(f"envs: indices must be in [0, {self.n_envs}), got {envs.tolist()}")
        return envs

    def _check_info_arrays(self, info_arrays) -> None:
        if info_arrays is self._fresh_info:  # made by new_info_arrays: right by construction
            return
        expected = self._info_spec
        got = [(getattr(a, "shape", None), getattr(a, "dtype", None)) for a in info_arrays]
        if got != expected:
            raise ValueError(
                f"info_arrays: expected the arrays of new_info_arrays(), (shape, dtype) "
                f"{expected}, "
                f"got {got}"
            )

    def reset_envs(self, envs, noise_seeds) -> None:
        """Reset the envs ``envs`` (indices) with one episode seed each (any integers, taken
        mod 2⁶⁴), in one compiled call."""
        envs = self._env_indices(envs)
        if isinstance(noise_seeds, np.ndarray) and noise_seeds.dtype in (np.int64, np.uint64):
            # the vectorised env's autoreset: non-negative int64 draws, no conversion needed
            if noise_seeds.shape != envs.shape:
                raise ValueError(f"noise_seeds: one per env ({envs.size}), got {noise_seeds.size}")
            if noise_seeds.dtype == np.int64 and noise_seeds.size and noise_seeds.min() < 0:
                noise_seeds = noise_seeds.astype(object)  # taken mod 2**64 below
            else:
                self.seed[envs] = noise_seeds.astype(np.uint64)
                noise_seeds = None
        if noise_seeds is not None:
            noise_seeds = list(noise_seeds)
            if len(noise_seeds) != envs.size:
                raise ValueError(f"noise_seeds: one per env ({envs.size}), got {len(noise_seeds)}")
            self.seed[envs] = np.array([int(s) % (1 << 64) for s in noise_seeds], dtype=np.uint64)
        K.env_reset(envs, self.cfg, self.icfg, self.stuck0, *self._flat, *self.step_outputs())

    def new_info_arrays(self) -> tuple:
        """Fresh (uninitialised) arrays for :meth:`step` to fill with the batched info."""
        B, A = self.n_envs, self.dim
        arrays = (
            np.empty((K.INFO_ROWS, B, A)),
            np.empty((2, B)),
            np.empty((B, A), dtype=bool),
            np.empty(B, dtype=np.int64),
        )
        # made here with the right shapes: step() and fill_info() need not check them again
        self._fresh_info = arrays
        return arrays

    def fill_info(self, info_arrays: tuple, envs) -> None:
        """Fill the info arrays of the envs ``envs`` from their current state (e.g. after a
        reset that followed the step)."""
        self._check_info_arrays(info_arrays)
        K.fill_info_envs(
            self._env_indices(envs), self.T, info_arrays, *self._flat, *self.step_outputs()
        )

    def info_of(self, info_arrays: tuple, b: int) -> dict:
        """The ``info`` of env b (keys and units of :meth:`info`,
        :data:`contour_env.env.layout.INFO_KEYS`) from filled info arrays: views of those
        (fresh) arrays, not copies of the state."""
        return _info_of(self, info_arrays, b)

    def info_dict(self, info_arrays: tuple) -> dict:
        """The batched ``info`` (keys of :meth:`info`, leading axis B) from filled arrays."""
        return _info_dict(self, info_arrays)

    def step(
        self,
        action: np.ndarray,
        active: np.ndarray,
        info_arrays=None,
        fresh_outputs=False,
        carry_inactive=True,
    ) -> int:
        """Advance the active envs with ``action`` (B, A) in [-1, 1]; raises on NaN/inf.
        Returns the number of stepped envs whose episode has now ended (terminated or
        truncated).

        With ``info_arrays`` (:meth:`new_info_arrays`) the kernel also fills the batched info
        of every stepped env, while its data is in cache. With ``fresh_outputs`` the kernel
        writes ``obs``, ``reward``, ``terminated`` and ``truncated`` into new arrays, which
        then replace the old ones (rows of inactive envs carried over, unless
        ``carry_inactive`` is False: for a caller that resets every inactive env right after,
        which writes those rows anyway): a caller may hand those out without copying them as
        long as it makes every later write go to new arrays too (steps with ``fresh_outputs``,
        :meth:`renew_outputs` before a reset), as the vectorised env does."""
        if info_arrays is None:
            info_arrays = self._no_info
        else:
            self._check_info_arrays(info_arrays)
        if fresh_outputs:
            outputs = StepOutputs(
                np.empty_like(self.obs),
                np.empty_like(self.reward),
                np.empty_like(self.terminated),
                np.empty_like(self.truncated),
            )
        else:
            outputs = StepOutputs(self.obs, self.reward, self.terminated, self.truncated)
        bad, n_terminated, n_ended = self.threads(
            (self.cfg, self.icfg, action, active, info_arrays, *self._flat, *outputs)
        )
        if bad >= 0:
            raise nonfinite_action_error(action, bad)
        all_active = active is self.all_active
        if fresh_outputs:
            carry = None if all_active or not carry_inactive else ~np.asarray(active, bool)
            self._adopt_outputs(outputs, carry)
        # every status is known to be "running" only if every env was stepped and none ended
        self._status_clear = all_active and n_terminated == 0
        return n_ended

    @property
    def num_threads(self):
        """The env option ``num_threads`` ("auto" or a fixed count; see :class:`StepThreads`);
        assign to change it."""
        return self.threads.requested

    @num_threads.setter
    def num_threads(self, value) -> None:
        self.threads = StepThreads(value, self.n_envs)

    def _adopt_outputs(self, outputs, carry) -> None:
        # replace obs, reward, terminated, truncated by ``outputs``, copying the rows ``carry``
        # (a boolean mask; None: none) from the arrays they replace
        if carry is not None and carry.any():
            olds = (self.obs, self.reward, self.terminated, self.truncated)
            for new, old in zip(outputs, olds, strict=True):
                new[carry] = old[carry]
        self.obs, self.reward, self.terminated, self.truncated = outputs

    def refuse_nonfinite(self, action: np.ndarray, rows: np.ndarray) -> None:
        """The ValueError of :meth:`step` if the action (B, A) of an env in ``rows`` (a boolean
        mask) is not finite; for envs whose action is not used (the vector env's autoreset)."""
        bad = K.first_bad_action(action, rows)
        if bad >= 0:
            raise nonfinite_action_error(action, bad)

    def renew_outputs(self) -> None:
        """Give the core new ``obs``, ``reward``, ``terminated`` and ``truncated`` arrays (copies
        of the current ones), so that arrays handed out earlier are never written again."""
        self._adopt_outputs(
            (self.obs.copy(), self.reward.copy(), self.terminated.copy(), self.truncated.copy()),
            None,
        )

    # --- readouts (physical units) ---------------------------------------------------------
    def info(self, b: int) -> dict:
        """The per-step ``info`` dict of env b: the keys, units and meanings of
        :data:`contour_env.env.layout.INFO_KEYS` (the table in ContouringEnv's docstring), read
        from the current state."""
        if not isinstance(b, (int, np.integer)) or not 0 <= b < self.n_envs:
            raise ValueError(f"b: an env index in [0, {self.n_envs}), got {b!r}")
        b = int(b)
        A = self.dim
        arrays = (
            np.empty((K.INFO_ROWS, b + 1, A)),
            np.empty((2, b + 1)),
            np.empty((b + 1, A), dtype=bool),
            np.empty(b + 1, dtype=np.int64),
        )
        K.fill_info_envs(np.array([b]), self.T, arrays, *self._flat, *self.step_outputs())
        return self.info_of(arrays, b)

    def batch_info(self) -> dict:
        """Same keys as :meth:`info`, stacked over the batch (leading axis B), read from the
        current state; the termination reason is "" while an env runs. (The vector env's step
        gets the same arrays filled by the step kernel itself.)"""
        arrays = self.new_info_arrays()
        self.fill_info(arrays, self._all_envs)
        return self.info_dict(arrays)

    def _reasons(self) -> np.ndarray:
        # While every env runs (almost every step) a read-only broadcast of "": no memory at
        # all (a (B,) array of 19-character strings is the size of five float arrays); a real
        # array once one ended. (_status_clear: the last step stepped every env and none
        # terminated, so the status array need not be scanned.)
        if self._status_clear:
            return self._no_reasons
        ended = np.flatnonzero(self.status)
        if ended.size == 0:
            return self._no_reasons
        # zeros are empty strings: only the few ended envs are written (indexing the whole
        # table by the status array copied every row, a third of the step's Python time)
        out = np.zeros(self.n_envs, dtype=_REASON_BY_STATUS.dtype)
        out[ended] = _REASON_BY_STATUS[self.status[ended]]
        return out

    def signals_batch(self) -> dict:
        """:meth:`signals` of every env, stacked (leading axis B)."""
        kk = np.minimum(self.k, self.n_steps - 1)
        A = self.dim
        return {
            "time": self.k * self.T,
            "step": self.k.copy(),
            "measured_position": self.ax[K.AX_MEAS].copy(),
            "measured_velocity": self.ax[K.AX_VEL].copy(),
            "reference_position": self.ref_pav[kk, 0, :A],
            "reference_velocity": self.ref_pav[kk, 1, :A],
            "reference_acceleration": self.ref_pav[kk, 2, :A],
            "frame": self.frame[kk, :A, :A],
            "curvature": self.scal[kk, 2],
            "torsion": self.scal[kk, 3],
            "feedrate": self.scal[kk, 0],
            "servo_period_s": self.T,
        }

    def signals(self, b: int = 0) -> dict:
        """What a real servo controller measures at the current sample of env b (SI units):
        measured position and velocity (encoder, backward difference), the reference position,
        velocity, acceleration, the path frame (columns t n b), curvature, torsion, feedrate,
        the servo period and the nominal plant parameters."""
        kk = min(int(self.k[b]), self.n_steps - 1)
        A = self.dim
        return {
            "time": float(self.k[b]) * self.T,
            "step": int(self.k[b]),
            "measured_position": self.ax[K.AX_MEAS, b].copy(),
            "measured_velocity": self.ax[K.AX_VEL, b].copy(),
            "reference_position": self.ref_pav[kk, 0, :A].copy(),
            "reference_velocity": self.ref_pav[kk, 1, :A].copy(),
            "reference_acceleration": self.ref_pav[kk, 2, :A].copy(),
            "frame": self.frame[kk, :A, :A].copy(),
            "curvature": float(self.scal[kk, 2]),
            "torsion": float(self.scal[kk, 3]),
            "feedrate": float(self.scal[kk, 0]),
            "servo_period_s": self.T,
        }


def core_of(env) -> tuple:
    """``(holder, core)`` of a contour_env env — single, wrapped (``env.unwrapped``) or
    vectorised: the object that holds the simulation core and the core (:class:`EnvCore` or
    :class:`~contour_env.env.five_axis_core.FiveAxisCore`, both a
    :class:`~contour_env.env.protocol.Core`). ValueError for anything else."""
    for candidate in (env, getattr(env, "unwrapped", None)):
        core = getattr(candidate, "core", None)
        if core is not None:
            return candidate, core
    raise ValueError("env: expected a contour_env env (single, wrapped or vectorised)")


def signals_to_batch(signals: dict) -> dict:
    """A single env's signals with a leading batch axis of one (controllers work on batches)."""
    if np.ndim(signals["measured_position"]) == 2:
        return signals
    out = {}
    for key, value in signals.items():
        if key == "servo_period_s":
            out[key] = value
        else:
            out[key] = np.asarray(value)[None, ...]
    return out


# the arguments of gym.make / make_vec besides EnvConfig's fields (ContouringEnv, "Arguments")
ENV_ARGUMENTS = (
    "case",
    "plant",
    "path",
    "feedrate_m_s",
    "max_accel_m_s2",
    "max_jerk_m_s3",
    "settle_time_s",
    "ideal",
    "structural_mode",
    "plant_params",
    "strict",
    "rapid_feed_m_s",
    "num_threads",
    "render_mode",
)
# the largest episode seed: numpy's seeds are 0 ... 2**64 - 1 (the counter-based noise key)
MAX_SEED = 2**64 - 1


def check_env_arguments(config: dict) -> None:
    """ValueError naming every argument of ``config`` that neither the env nor `EnvConfig`
    has, and listing the known ones (instead of a TypeError from deep inside)."""
    fields = EnvConfig.__dataclass_fields__
    unknown = [k for k in config if k not in fields]
    if unknown:
        names = ", ".join(repr(k) for k in unknown)
        known = ", ".join((*ENV_ARGUMENTS, *fields))
        raise ValueError(
            f"unknown argument{'s' * (len(unknown) > 1)} {names}; the env's arguments are: {known}"
        )


def nonfinite_action_error(action: np.ndarray, bad: int) -> ValueError:
    """The error for the non-finite action of env ``bad`` (row ``bad`` of ``action``)."""
    return ValueError(
        f"action: must be finite, got {action[bad].tolist()} (env {bad}); the action is "
        "the per-axis command in [-1, 1] of the force limit"
    )


def check_seed(seed, name: str = "seed") -> int:
    """``seed`` as an int in numpy's seed range 0 ... 2**64 - 1; ValueError naming ``name``
    otherwise (a larger seed would be reduced modulo 2**64 and repeat another episode)."""
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)):
        raise ValueError(f"{name}: expected None or an integer in [0, 2**64 - 1], got {seed!r}")
    seed = int(seed)
    if not 0 <= seed <= MAX_SEED:
        raise ValueError(
            f"{name}: must be in [0, 2**64 - 1] (numpy's seed range), got {seed} "
            f"({'negative' if seed < 0 else f'about 2**{seed.bit_length() - 1}'})"
        )
    return seed


def record_from(record, *holders):
    """The record (a named tuple class of the kernel's arrays) whose each field is the
    attribute of that name of the first of ``holders`` that has one (``AttributeError``
    naming the field where none has): the cores build their kernel records this way, so a
    record's field list is written only in its declaration."""

    def field(name):
        for holder in holders:
            if hasattr(holder, name):
                return getattr(holder, name)
        raise AttributeError(f"{name}: in none of {[type(h).__name__ for h in holders]}")

    return record(*(field(name) for name in record._fields))


def _info_builder(batched: bool):
    # info_of (one env) or info_dict (batched) as a literal dict, made from the declared
    # INFO_KEYS: a literal dict is a few per cent of the single env's step cheaper than one
    # built by a loop over a key table
    items = []
    for field, where in INFO_KEYS:
        if where == "reason":
            value = "core._reasons()" if batched else (
                "TERMINATION_REASONS.get(int(core.status[b]))"
            )  # fmt: skip
        elif where == "sat":
            value = "sat" if batched else "sat[b]"
        elif where == "step":
            value = "step" if batched else "int(step[b])"
        elif where[0] == "s":
            value = f"sc[{where[1]}]" if batched else f"float(sc[{where[1]}, b])"
        else:
            row = getattr(K, f"INFO_{where[1]}")
            value = f"f[{row}]" if batched else f"f[{row}, b]"
        items.append(f"        {field.name!r}: {value},")
    args = "core, arrays" if batched else "core, arrays, b"
    source = "\n".join(
        [f"def build({args}):", "    f, sc, sat, step = arrays", "    return {", *items, "    }"]
    )
    namespace = {"TERMINATION_REASONS": TERMINATION_REASONS}
    exec(source, namespace)  # noqa: S102  (made from the declaration, no outside input)
    return namespace["build"]


_info_of = _info_builder(batched=False)
_info_dict = _info_builder(batched=True)
