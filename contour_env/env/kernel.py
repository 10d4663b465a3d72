"""The compiled environment step, shared by the single and the vectorised env.

One step of one env, :func:`step_one`, is its stages in order, each a small compiled function
(inlined: no call is left at run time):

1. command — :func:`command_stage`: the action, clipped to [−1, 1], times the force limit,
   held one servo period when the plant has the computation delay;
2. plant — :func:`plant_stage`: the axis model integrated over the period
   (:func:`contour_env.plants.kernel.axis_step`), with the optional random disturbance;
3. measurement — :func:`measure_stage`: what the encoders read (quantised, optional noise)
   and the backward-difference velocity;
4. tracking error in the path frame — :func:`frame_error_stage`: Fᵀ(x_d − x), and ‖x_d − x‖²;
5. contour error — the true distance from the tool to the path
   (:func:`contour_env.contour_error.path_distance`);
6. guards — :func:`guard_stage`: contour error, tracking error (non-finite state before
   both);
7. reward — :mod:`contour_env.env.reward`;
8. observation — :func:`observe`.

The drivers (:func:`env_step` serial, :func:`env_step_parallel` over numba's threads) run it
for every active env of the batch; the single env is a batch of one, so the two cannot drift
apart. What the arrays hold, and the records the stages receive them in, is
:mod:`contour_env.env.layout`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..contour_error import path_distance
from ..noise import standard_normal, uniform01
from ..plants.kernel import NL_FD, NL_FMAX, NL_INV_RES, NL_RES, axis_step
from .borrow import borrowed, record_borrower
from .layout import (  # noqa: F401  (the layout's names, re-exported: K.AX_MEAS, K.C_T, ...)
    AX_APPLIED,
    AX_MEAS,
    AX_PREV,
    AX_REF,
    AX_SAT,
    AX_SIZE,
    AX_STUCK,
    AX_TOFF,
    AX_UPEND,
    AX_VEL,
    C_ABORT,
    C_ABORT_TRACK2,
    C_ACC_SCALE,
    C_CURV_SCALE,
    C_DIST_AMP,
    C_DIST_PHASE_RANDOM,
    C_EPS_SCALE,
    C_ERR_SCALE,
    C_FEED_SCALE,
    C_GUARD_PENALTY,
    C_INV_ACC,
    C_INV_AXES,
    C_INV_EPS,
    C_INV_ERR,
    C_INV_FEED,
    C_INV_T,
    C_INV_VERR,
    C_NOISE_STD,
    C_OBS_CLIP,
    C_T,
    C_VERR_SCALE,
    C_W_CONTOUR,
    C_W_EFFORT,
    C_W_LAG,
    CFG_SIZE,
    ENTRY_RECORDS,
    I_DELAY,
    I_NSTEPS,
    I_NSUB,
    ICFG_SIZE,
    INFO_ESTIMATE,
    INFO_FORCE,
    INFO_MEASURED,
    INFO_POSITION,
    INFO_REFERENCE,
    INFO_ROWS,
    INFO_TRACKING,
    INFO_VELOCITY,
    OUT_END,
    PATH_END,
    PLANT_END,
    STATE_END,
    STATUS_CONTOUR_LIMIT,
    STATUS_NONFINITE,
    STATUS_OK,
    STATUS_TRACKING_LIMIT,
    STREAM_DIST,
    STREAM_MEAS,
    STREAM_PHASE,
    EnvState,
    EpisodeTrace,
    PathArrays,
    PlantArrays,
    StepOutputs,
)
from .reward import feed_drive_reward, guard_reward


@njit(cache=True)
def observation_table(cfg, preview, ref_pav, frame, scal, n_steps, dim, out):
    """Fill out[kk] (float32, (n_steps, 3 + len(preview) · dim)) with the part of the
    observation that depends on the reference index kk only: scaled feedrate, feed
    acceleration and curvature, then the path preview. Computed once per env setup, so the
    step copies it instead of recomputing it for every env."""
    clip = cfg[C_OBS_CLIP]
    for kk in range(n_steps):
        out[kk, 0] = min(max(scal[kk, 0] * cfg[C_INV_FEED], -clip), clip)
        out[kk, 1] = min(max(scal[kk, 1] * cfg[C_INV_ACC], -clip), clip)
        out[kk, 2] = min(max(scal[kk, 2] * cfg[C_CURV_SCALE], -clip), clip)
        o = 3
        # preview: upcoming reference points in the current task frame, scaled by the distance
        # the nominal feed covers in that time (≈ (1, 0, 0) on a straight at full feed)
        for j in range(preview.shape[0]):
            kj = min(kk + preview[j], n_steps - 1)
            inv_scale = cfg[CFG_SIZE + j]
            for r in range(dim):
                acc = 0.0
                for c in range(dim):
                    acc += frame[kk, c, r] * (ref_pav[kj, 0, c] - ref_pav[kk, 0, c])
                out[kk, o] = min(max(acc * inv_scale, -clip), clip)
                o += 1


@njit(cache=True, inline="always")
def _copy_table_row(obs, b, o, obs_tab, kk, n):
    # obs[b, o : o + n] = obs_tab[kk, :n]; (indexed by the range variable itself: with o + j
    # numba adds a negative-index check and LLVM turned the copy into a vector scatter)
    for jj in range(o, o + n):
        obs[b, jj] = obs_tab[kk, jj - o]


@njit(cache=True, inline="always")
def _task_frame_error(dim, b, kk, frame, ref_pav, ref_row, ax, ax_row, scale, clip, obs, o):
    # obs[b, o + r] = clip(scale · Σ_c F[c, r] (ref_pav[kk, ref_row, c] − ax[ax_row, b, c]));
    # indexed by the range variable itself, as _copy_table_row (no negative-index check)
    for jj in range(o, o + dim):
        r = jj - o
        acc = 0.0
        for c in range(dim):
            acc += frame[kk, c, r] * (ref_pav[kk, ref_row, c] - ax[ax_row, b, c])
        obs[b, jj] = min(max(acc * scale, -clip), clip)


@njit(cache=True, inline="always")
def observe(dim, b, kk, cfg, obs_tab, ax, ref_pav, frame, obs):
    """Fill obs[b] for reference index kk from the measured state (layout: see ContouringEnv);
    the reference-only fields come from ``obs_tab`` (:func:`observation_table`). ``dim`` is
    the axis count, passed in (not read from a shape) so that the two-axis driver can give it
    as a literal: the small loops are then unrolled (about 8 % off the whole step)."""
    clip = cfg[C_OBS_CLIP]
    inv_err = cfg[C_INV_ERR]
    inv_verr = cfg[C_INV_VERR]
    # task-frame position error Fᵀ(x_d − x_meas) and velocity error Fᵀ(v_d − v_meas), scaled
    _task_frame_error(dim, b, kk, frame, ref_pav, 0, ax, AX_MEAS, inv_err, clip, obs, 0)
    _task_frame_error(dim, b, kk, frame, ref_pav, 1, ax, AX_VEL, inv_verr, clip, obs, dim)
    o = 2 * dim
    n_tab = obs_tab.shape[1]
    if n_tab == 3 + 3 * dim:
        # the default three preview times: a literal length, so the copy is unrolled
        _copy_table_row(obs, b, o, obs_tab, kk, 3 + 3 * dim)
    else:
        _copy_table_row(obs, b, o, obs_tab, kk, n_tab)
    o += n_tab
    for r in range(dim):
        obs[b, o] = ax[AX_PREV, b, r]
        o += 1


@njit(cache=True, inline="always")
def _drive_position(z, b, i):
    """The position the encoder reads (m): the drive (motor) side of the two-mass model,
    state index 2, when the plant has the axial mode (semi-closed loop: the encoder is on
    the drive, the table/tool point vibrates against it); otherwise the table, index 0."""
    return z[b, i, 2] if z.shape[2] >= 4 else z[b, i, 0]


@njit(cache=True, inline="always")
def _encoder(x, seed_b, step, i, p, cfg, nl):
    """What the encoder of axis i reads at sample ``step`` for the true position x (m):
    x plus the optional measurement noise, rounded to the nearest count."""
    xm = x
    if cfg[C_NOISE_STD] > 0.0:
        xm += cfg[C_NOISE_STD] * standard_normal(seed_b, step, i, STREAM_MEAS)
    res = nl[p, i, NL_RES]
    if res > 0.0:
        xm = np.floor(xm * nl[p, i, NL_INV_RES] + 0.5) * res
    return xm


@njit(cache=True, inline="always")
def fill_info(n_axes, b, T, k, z, ax, eps, est, info):
    """Env b's entries (n_axes axes, a literal where the driver gives one) of the batched
    ``info`` arrays (physical units), the tuple
    (info_f (INFO_ROWS, B, A), info_s (2, B) = [time (s), true contour error (m)], info_b (B, A)
    saturated, info_k (B,) step)."""
    info_f = info[0]
    info_s = info[1]
    info_b = info[2]
    info_k = info[3]
    info_k[b] = k[b]
    info_s[0, b] = k[b] * T
    info_s[1, b] = eps[b]
    for i in range(n_axes):
        x = z[b, i, 0]
        ref = ax[AX_REF, b, i]
        info_f[INFO_POSITION, b, i] = x
        info_f[INFO_MEASURED, b, i] = ax[AX_MEAS, b, i]
        info_f[INFO_VELOCITY, b, i] = z[b, i, 1]
        info_f[INFO_REFERENCE, b, i] = ref
        info_f[INFO_ESTIMATE, b, i] = est[b, i]
        info_f[INFO_TRACKING, b, i] = ref - x
        info_f[INFO_FORCE, b, i] = ax[AX_APPLIED, b, i]
        info_b[b, i] = ax[AX_SAT, b, i] > 0.0


@njit(cache=True)
def fill_info_envs(envs, T, info, *arrays):
    """:func:`fill_info` for the envs listed in ``envs`` (e.g. those reset after a step); the
    records' arrays flat, as :func:`env_step` takes them."""
    state = records_of(arrays)[0]
    z = state.z
    for j in range(envs.shape[0]):
        fill_info(z.shape[1], envs[j], T, state.k, z, state.ax, state.eps, state.est, info)


@njit(cache=True, inline="always")
def command_stage(b, i, p, delay, action, ax, nl):
    """Stage 1, command of axis i: a = clip(action, −1, 1) times the force limit (N), held one
    period when the plant has the computation delay (``delay``); the force applied this
    period, with the saturation flag and the action kept in ``ax``. Returns (u, a²)."""
    a = min(max(action[b, i], -1.0), 1.0)
    ax[AX_PREV, b, i] = a
    cmd = a * nl[p, i, NL_FMAX]
    if delay:
        u = ax[AX_UPEND, b, i]
        ax[AX_UPEND, b, i] = cmd
    else:
        u = cmd
    ax[AX_APPLIED, b, i] = u
    ax[AX_SAT, b, i] = 1.0 if abs(u) >= nl[p, i, NL_FMAX] * (1.0 - 1e-12) else 0.0
    return u, a * a


@njit(cache=True, inline="always")
def plant_stage(n_axes, b, i, p, kb, u, cfg, icfg, state, z2, plant):
    """Stage 2, plant of axis i: the axis model over one servo period under the force u (N)
    (:func:`contour_env.plants.kernel.axis_step`, state row b·A + i of ``z2``), with the
    random disturbance of amplitude ``cfg[C_DIST_AMP]`` (N) when it is on."""
    T = cfg[C_T]
    ax = state.ax
    dist_amp = cfg[C_DIST_AMP]
    w_extra = 0.0
    if dist_amp > 0.0:
        w_extra = dist_amp * (2.0 * uniform01(state.seed[b], kb, i, STREAM_DIST) - 1.0)
    ax[AX_STUCK, b, i] = axis_step(
        z2,
        b * n_axes + i,
        ax[AX_STUCK, b, i],
        u,
        kb * T + ax[AX_TOFF, b, i],
        T,
        icfg[I_NSUB],
        plant.mat_T,
        plant.mat_h,
        plant.cont,
        plant.nl,
        p,
        i,
        state.scratch,
        2 * b,
        w_extra,
    )


@njit(cache=True, inline="always")
def measure_stage(n_axes, b, kb, p, cfg, state, nl):
    """Stage 3, measurement: each encoder's reading at sample ``kb`` (quantised, optional
    noise) and the backward-difference velocity (m/s). Returns whether the plant state is
    finite."""
    z, ax = state.z, state.ax
    inv_T = cfg[C_INV_T]
    finite = True
    for i in range(n_axes):
        x = z[b, i, 0]
        if not (math.isfinite(x) and math.isfinite(z[b, i, 1])):
            finite = False
        xm = _encoder(_drive_position(z, b, i), state.seed[b], kb, i, p, cfg, nl)
        ax[AX_VEL, b, i] = (xm - ax[AX_MEAS, b, i]) * inv_T
        ax[AX_MEAS, b, i] = xm
    return finite


@njit(cache=True, inline="always")
def frame_error_stage(n_axes, b, kk, state, path):
    """Stage 4, tracking error in the path frame: est = Fᵀ(x_d − x) (m; est[0] along the
    tangent, the lag), the reference kept in ``ax``. Returns ‖x_d − x‖² (m²)."""
    z, ax, est = state.z, state.ax, state.est
    frame, ref_pav = path.frame, path.ref_pav
    te2 = 0.0
    for r in range(n_axes):
        acc = 0.0
        for c in range(n_axes):
            acc += frame[kk, c, r] * (ref_pav[kk, 0, c] - z[b, c, 0])
        est[b, r] = acc
        ax[AX_REF, b, r] = ref_pav[kk, 0, r]
        d = ref_pav[kk, 0, r] - z[b, r, 0]
        te2 += d * d
    return te2


@njit(cache=True, inline="always")
def contour_error_stage(n_axes, b, state, path):
    """Stage 5, the true contour error: the distance (m) from the tool to the path."""
    z = state.z
    pz = z[b, 2, 0] if n_axes == 3 else 0.0
    return path_distance(path.seg_type, path.seg_data, path.seg_bounds, z[b, 0, 0], z[b, 1, 0], pz)


@njit(cache=True, inline="always")
def guard_stage(e, te2, cfg):
    """Stage 6, guards: the status after a finite step with contour error e (m) and squared
    tracking error te2 (m²)."""
    if e > cfg[C_ABORT]:
        return STATUS_CONTOUR_LIMIT
    if te2 > cfg[C_ABORT_TRACK2]:
        return STATUS_TRACKING_LIMIT
    return STATUS_OK


@njit(cache=True, inline="always")
def step_one(n_axes, b, cfg, icfg, state, z2, path, plant, action, out, info):
    """One env, one servo period: the stages of the module docstring in order (the body
    shared by the serial and the parallel driver and the compiled episode loops of
    :mod:`agents.compiled`). ``n_axes`` = z.shape[1], passed in so that a driver can give it
    as a literal; ``z2`` the plant states as rows (b·A + i)."""
    n_steps = icfg[I_NSTEPS]
    delay = icfg[I_DELAY] != 0
    ax, k, eps, est, status = state.ax, state.k, state.eps, state.est, state.status
    obs, reward = out.obs, out.reward
    p = plant.pidx[b]
    kb = k[b]
    effort = 0.0
    for i in range(n_axes):
        u, a2 = command_stage(b, i, p, delay, action, ax, plant.nl)
        effort += a2
        plant_stage(n_axes, b, i, p, kb, u, cfg, icfg, state, z2, plant)
    kb += 1
    k[b] = kb
    kk = min(kb, n_steps - 1)
    finite = measure_stage(n_axes, b, kb, p, cfg, state, plant.nl)
    te2 = frame_error_stage(n_axes, b, kk, state, path)
    if finite:
        e = contour_error_stage(n_axes, b, state, path)
        eps[b] = e
        st = guard_stage(e, te2, cfg)
        status[b] = st
        if st == STATUS_OK:
            reward[b] = feed_drive_reward(
                cfg[C_W_CONTOUR], cfg[C_W_LAG], cfg[C_W_EFFORT], cfg[C_INV_EPS],
                cfg[C_INV_AXES], e, est[b, 0], effort,
            )  # fmt: skip
        else:
            # this step and each of the n_steps − 1 − kb it skips (at least this one)
            reward[b] = guard_reward(cfg[C_GUARD_PENALTY], max(n_steps - kb, 1))
        observe(n_axes, b, kk, cfg, path.obs_tab, ax, path.ref_pav, path.frame, obs)
    else:
        eps[b] = math.inf
        status[b] = STATUS_NONFINITE
        # a finite penalty (as a guard's), the observation zeroed
        reward[b] = guard_reward(cfg[C_GUARD_PENALTY], max(n_steps - kb, 1))
        for o in range(obs.shape[1]):
            obs[b, o] = 0.0
    out.terminated[b] = status[b] != STATUS_OK
    out.truncated[b] = (kb >= n_steps - 1) and not out.terminated[b]
    # the batched info arrays (empty ones: not wanted), written while the env's data is hot
    if info[3].shape[0] > 0:
        fill_info(n_axes, b, cfg[C_T], k, state.z, ax, eps, est, info)


@njit(cache=True)
def first_bad_action(action, active):
    """Index of the first active env whose action is not finite, or -1."""
    for b in range(action.shape[0]):
        if active[b]:
            for i in range(action.shape[1]):
                if not math.isfinite(action[b, i]):
                    return b
    return -1


@njit(cache=True, inline="always")
def records_of(arrays):
    """The records (EnvState, PathArrays, PlantArrays, StepOutputs) of an entry point's flat
    arrays (:data:`contour_env.env.layout.ENTRY_RECORDS`)."""
    return (
        EnvState(*arrays[0:STATE_END]),
        PathArrays(*arrays[STATE_END:PATH_END]),
        PlantArrays(*arrays[PATH_END:PLANT_END]),
        StepOutputs(*arrays[PLANT_END:OUT_END]),
    )


# the records with every array borrowed (contour_env.env.borrow), made from their declarations
_borrow_state, _borrow_path, _borrow_plant, _borrow_out = (
    record_borrower(record) for record in ENTRY_RECORDS
)
borrow_trace = record_borrower(EpisodeTrace)


@njit(cache=True, inline="always")
def borrowed_records(state, path, plant, out):
    """The records with every array borrowed (:func:`contour_env.env.borrow.borrowed`), for a
    compiled loop called from Python with them (the drivers below, :mod:`agents.compiled`)."""
    return _borrow_state(state), _borrow_path(path), _borrow_plant(plant), _borrow_out(out)


@njit(cache=True, inline="always")
def record_step(n, b, n_axes, T, n_steps, state, path, trace):
    """Row n of an episode's trace (:class:`~contour_env.env.layout.EpisodeTrace`) after a
    step of env b: time (s), true contour error (m), position, reference and applied force
    per axis — what :func:`contour_env.evaluation.run_episode` records."""
    kb = state.k[b]
    trace.time[n] = kb * T
    trace.eps[n] = state.eps[b]
    kk = min(kb, n_steps - 1)
    for i in range(n_axes):
        trace.pos[n, i] = state.z[b, i, 0]
        trace.ref[n, i] = path.ref_pav[kk, 0, i]
        trace.force[n, i] = state.ax[AX_APPLIED, b, i]


@njit(cache=True)
def step_range(lo, hi, cfg, icfg, action, active, info, arrays):
    """The one loop of both drivers: every active env b of [lo, hi) advanced by one servo
    period (:func:`step_one`). Returns (n_terminated, n_ended) among them. ``arrays``: the
    entry point's flat record arrays (:func:`records_of`), passed on as the one tuple (a
    tuple argument reaches the parallel driver's threads as it is; records built in the
    driver and handed into its ``prange`` do not compile).

    The records are borrowed once here, before the loop, and the per-env step is inlined in
    it: a null meminfo is a constant, so the compiled loop has no reference-count update left
    at all (:mod:`contour_env.env.borrow`; issue 35: a per-env function receiving its arrays
    cost 1.6x). Records built in a ``prange`` body instead are hoisted out of it by numba's
    parfor pass and reach the threads with the caller's reference counts: every field read was
    then an atomic increment and decrement on counters the threads share (measured at 4096
    envs: the parallel driver 2.1 M env-steps/s on one thread against the serial 5.7 M, and
    slower on two threads than on one). The parallel driver therefore calls this function once
    per thread, on a contiguous block of envs."""
    B = borrowed
    state, path, plant, out = records_of(arrays)
    state, path, plant, out = borrowed_records(state, path, plant, out)
    z = state.z
    # the states as rows (env b, axis i) -> b * A + i: a view made once per call, not per env
    z2 = B(z.reshape((z.shape[0] * z.shape[1], z.shape[2])))
    cfg, icfg, action, active = B(cfg), B(icfg), B(action), B(active)
    info = (B(info[0]), B(info[1]), B(info[2]), B(info[3]))
    n_axes = z.shape[1]
    n_terminated = 0
    n_ended = 0
    for b in range(lo, hi):
        if active[b]:
            if n_axes == 2:
                step_one(2, b, cfg, icfg, state, z2, path, plant, action, out, info)
            else:
                step_one(n_axes, b, cfg, icfg, state, z2, path, plant, action, out, info)
            n_terminated += 1 if out.terminated[b] else 0
            n_ended += 1 if out.terminated[b] or out.truncated[b] else 0
    return n_terminated, n_ended


@njit(cache=True)
def env_step(cfg, icfg, action, active, info, *arrays):
    """Advance every active env by one servo period, in place (serial driver).

    Returns (bad, n_terminated, n_ended): bad is -1, or the index of the first env whose action
    is not finite (nothing is changed then); n_terminated and n_ended count the stepped envs
    now terminated, and terminated or truncated.

    The arguments (:mod:`.layout`): cfg, icfg; action (B, A) in [-1, 1] of the force limit;
    active (B,) bool; info: the tuple of batched info arrays of :func:`fill_info`, filled for
    every stepped env (empty arrays: none); then the arrays of the records :class:`EnvState`,
    :class:`PathArrays`, :class:`PlantArrays` and :class:`StepOutputs` (obs (B, O) float32,
    reward, terminated, truncated (B,)), flat, in their declared order (:func:`records_of`).

    Two axes are given to the step as a literal: the compiler unrolls the per-axis loops and
    interleaves the two axes (measured 1.1-2x faster); other axis counts take the generic body.
    Same arithmetic either way (no fast-math), so the results do not depend on the branch, the
    driver or the thread count.
    """
    bad = first_bad_action(action, active)
    if bad >= 0:
        return bad, 0, 0
    n_terminated, n_ended = step_range(0, action.shape[0], cfg, icfg, action, active, info, arrays)
    return -1, n_terminated, n_ended


# the parallel driver's blocks: enough envs per block that its one call is noise (a block of
# 128 envs is ~20 µs of stepping), enough blocks to share out evenly over the threads
PARALLEL_BLOCK_ENVS = 128
PARALLEL_BLOCKS = 64


@njit(cache=True, parallel=True)
def env_step_parallel(cfg, icfg, action, active, info, *arrays):
    """As :func:`env_step`, with the envs spread over numba's threads (``numba.set_num_threads``
    before the call sets how many): the batch cut into contiguous blocks of at least
    :data:`PARALLEL_BLOCK_ENVS` envs (at most :data:`PARALLEL_BLOCKS` blocks), which numba's
    static schedule hands out in equal runs per thread, each block stepped by
    :func:`step_range` (one call per block and servo period). Same arithmetic per
    env, and each env's step reads and writes only its own rows, so the results are
    bit-identical to the serial driver whatever the thread count (the two counts returned are
    integer sums)."""
    bad = first_bad_action(action, active)
    if bad >= 0:
        return bad, 0, 0
    n_envs = action.shape[0]
    n_chunks = max(min(PARALLEL_BLOCKS, n_envs // PARALLEL_BLOCK_ENVS), 1)
    counts = np.zeros((n_chunks, 2), dtype=np.int64)
    for c in prange(n_chunks):
        lo = c * n_envs // n_chunks
        hi = (c + 1) * n_envs // n_chunks
        n_term, n_end = step_range(lo, hi, cfg, icfg, action, active, info, arrays)
        counts[c, 0] = n_term
        counts[c, 1] = n_end
    return -1, counts[:, 0].sum(), counts[:, 1].sum()


@njit(cache=True)
def env_reset(envs, cfg, icfg, stuck0, *arrays):
    """Put every env listed in ``envs`` (int64 indices) at rest on the reference start point
    (k = 0), with its observation, zero reward and no done flags (seeds already in
    ``state.seed``). ``stuck0`` (A,): 1.0 where the axis starts held by static friction; the
    records' arrays flat, as :func:`env_step` takes them (``icfg`` and the plant matrices
    unused here)."""
    state, path, plant, out = records_of(arrays)
    z, ax, k, eps, est = state.z, state.ax, state.k, state.eps, state.est
    status, seed, nl, pidx = state.status, state.seed, plant.nl, plant.pidx
    ref_pav, frame, obs_tab = path.ref_pav, path.frame, path.obs_tab
    seg_type, seg_data, seg_bounds = path.seg_type, path.seg_data, path.seg_bounds
    obs, reward, terminated, truncated = out.obs, out.reward, out.terminated, out.truncated
    for j in range(envs.shape[0]):
        b = envs[j]
        n_axes = z.shape[1]
        p = pidx[b]
        for i in range(n_axes):
            for r in range(z.shape[2]):
                z[b, i, r] = 0.0
            z[b, i, 0] = ref_pav[0, 0, i]
            if z.shape[2] >= 4:
                z[b, i, 2] = ref_pav[0, 0, i]  # motor side of the two-mass model
            ax[AX_STUCK, b, i] = stuck0[i]
            ax[AX_UPEND, b, i] = 0.0
            ax[AX_PREV, b, i] = 0.0
            ax[AX_APPLIED, b, i] = 0.0
            ax[AX_SAT, b, i] = 0.0
            ax[AX_REF, b, i] = ref_pav[0, 0, i]
            # the plant's disturbance is not synchronised with the program: its phase is drawn
            # per episode (from the episode seed) unless the config fixes it
            toff = 0.0
            if cfg[C_DIST_PHASE_RANDOM] > 0.0 and nl[p, i, NL_FD] > 0.0:
                toff = uniform01(seed[b], 0, i, STREAM_PHASE) / nl[p, i, NL_FD]
            ax[AX_TOFF, b, i] = toff
            ax[AX_MEAS, b, i] = _encoder(_drive_position(z, b, i), seed[b], 0, i, p, cfg, nl)
            ax[AX_VEL, b, i] = 0.0
            est[b, i] = ref_pav[0, 0, i] - z[b, i, 0]
        k[b] = 0
        status[b] = STATUS_OK
        pz = z[b, 2, 0] if n_axes == 3 else 0.0
        eps[b] = path_distance(seg_type, seg_data, seg_bounds, z[b, 0, 0], z[b, 1, 0], pz)
        observe(n_axes, b, 0, cfg, obs_tab, ax, ref_pav, frame, obs)
        reward[b] = 0.0
        terminated[b] = False
        truncated[b] = False
