"""The compiled environment step, shared by the single and the vectorised env.

One call: plant step → reference at k+1 → measurement → true contour error → crash guards
(contour error, tracking error, non-finite state) → reward → observation, for every active env
of the batch. The single env is a batch of one, so
the two cannot drift apart.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..contour_error import path_distance
from ..noise import standard_normal, uniform01
from ..plants.kernel import NL_FD, NL_FMAX, NL_INV_RES, NL_RES, axis_step
from .borrow import borrowed

# float configuration (cfg)
(
    C_T,
    C_ERR_SCALE,
    C_VERR_SCALE,
    C_FEED_SCALE,
    C_ACC_SCALE,
    C_CURV_SCALE,
    C_W_CONTOUR,
    C_W_LAG,
    C_W_EFFORT,
    C_EPS_SCALE,
    C_ABORT,
    C_NOISE_STD,
    C_DIST_AMP,
    C_OBS_CLIP,
    C_DIST_PHASE_RANDOM,
    C_INV_T,
    C_INV_ERR,
    C_INV_VERR,
    C_INV_FEED,
    C_INV_ACC,
    C_INV_EPS,
    C_INV_AXES,
    C_ABORT_TRACK2,
    C_GUARD_PENALTY,
) = range(24)
# C_ABORT_TRACK2: the tracking-error guard squared (m²), compared with ‖x_d − x‖² (no root);
# C_GUARD_PENALTY: P ≥ 0, the penalty of one step at the guards, charged for the terminating
# step and every step a termination skips (see EnvConfig.guard_penalty)
# cfg[CFG_SIZE + j]: 1 / (feed scale · preview time j), the preview's scale; the reciprocals
# are computed once by EnvCore so that the per-step code multiplies instead of dividing
CFG_SIZE = 24
# integer configuration (icfg)
I_NSTEPS, I_NSUB, I_DELAY = range(3)
ICFG_SIZE = 3
# per-axis env state and readout rows (ax[row, b, axis]; row-major so each row of the batch
# is contiguous and the info arrays are plain copies)
# AX_TOFF: the env's time offset of the plant's periodic disturbance d(t) (s), drawn per episode
AX_STUCK, AX_UPEND, AX_MEAS, AX_VEL, AX_PREV, AX_APPLIED, AX_SAT, AX_REF, AX_TOFF = range(9)
AX_SIZE = 9
# termination status codes
STATUS_OK, STATUS_CONTOUR_LIMIT, STATUS_NONFINITE, STATUS_TRACKING_LIMIT = 0, 1, 2, 3
# noise streams
_STREAM_MEAS, _STREAM_DIST, _STREAM_PHASE = 0, 1, 2


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
def observe(dim, b, kk, cfg, obs_tab, ax, ref_pav, frame, obs):
    """Fill obs[b] for reference index kk from the measured state (layout: see ContouringEnv);
    the reference-only fields come from ``obs_tab`` (:func:`observation_table`). ``dim`` is
    the axis count, passed in (not read from a shape) so that the two-axis driver can give it
    as a literal: the small loops are then unrolled (about 8 % off the whole step)."""
    clip = cfg[C_OBS_CLIP]
    inv_err = cfg[C_INV_ERR]
    inv_verr = cfg[C_INV_VERR]
    o = 0
    # task-frame position error Fᵀ(x_d − x_meas), scaled
    for r in range(dim):
        acc = 0.0
        for c in range(dim):
            acc += frame[kk, c, r] * (ref_pav[kk, 0, c] - ax[AX_MEAS, b, c])
        obs[b, o] = min(max(acc * inv_err, -clip), clip)
        o += 1
    # task-frame velocity error Fᵀ(v_d − v_meas), scaled
    for r in range(dim):
        acc = 0.0
        for c in range(dim):
            acc += frame[kk, c, r] * (ref_pav[kk, 1, c] - ax[AX_VEL, b, c])
        obs[b, o] = min(max(acc * inv_verr, -clip), clip)
        o += 1
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
        xm += cfg[C_NOISE_STD] * standard_normal(seed_b, step, i, _STREAM_MEAS)
    res = nl[p, i, NL_RES]
    if res > 0.0:
        xm = np.floor(xm * nl[p, i, NL_INV_RES] + 0.5) * res
    return xm


# rows of the float block of the batched info (each (B, A)); info_s rows: time, contour error
(
    INFO_POSITION,
    INFO_MEASURED,
    INFO_VELOCITY,
    INFO_REFERENCE,
    INFO_ESTIMATE,
    INFO_TRACKING,
    INFO_FORCE,
) = range(7)
INFO_ROWS = 7


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
def fill_info_envs(envs, T, k, z, ax, eps, est, info):
    """:func:`fill_info` for the envs listed in ``envs`` (e.g. those reset after a step)."""
    for j in range(envs.shape[0]):
        fill_info(z.shape[1], envs[j], T, k, z, ax, eps, est, info)


@njit(cache=True, inline="always")
def _step_one(
    n_axes,
    b,
    cfg,
    icfg,
    obs_tab,
    z,
    z2,
    ax,
    k,
    eps,
    est,
    status,
    seed,
    ref_pav,
    frame,
    seg_type,
    seg_data,
    seg_bounds,
    mat_T,
    mat_h,
    cont,
    nl,
    pidx,
    action,
    obs,
    reward,
    terminated,
    truncated,
    scratch,
    info,
):
    # one env, one servo period (the body shared by the serial and the parallel driver);
    # n_axes = z.shape[1], passed in so that a driver can give it as a literal
    T = cfg[C_T]
    inv_T = cfg[C_INV_T]
    n_steps = icfg[I_NSTEPS]
    n_sub = icfg[I_NSUB]
    delay = icfg[I_DELAY] != 0
    dist_amp = cfg[C_DIST_AMP]
    p = pidx[b]
    kb = k[b]
    t0 = kb * T
    effort = 0.0
    for i in range(n_axes):
        a = min(max(action[b, i], -1.0), 1.0)
        ax[AX_PREV, b, i] = a
        effort += a * a
        cmd = a * nl[p, i, NL_FMAX]
        if delay:
            u = ax[AX_UPEND, b, i]
            ax[AX_UPEND, b, i] = cmd
        else:
            u = cmd
        ax[AX_APPLIED, b, i] = u
        ax[AX_SAT, b, i] = 1.0 if abs(u) >= nl[p, i, NL_FMAX] * (1.0 - 1e-12) else 0.0
        w_extra = 0.0
        if dist_amp > 0.0:
            w_extra = dist_amp * (2.0 * uniform01(seed[b], kb, i, _STREAM_DIST) - 1.0)
        ax[AX_STUCK, b, i] = axis_step(
            z2,
            b * n_axes + i,
            ax[AX_STUCK, b, i],
            u,
            t0 + ax[AX_TOFF, b, i],
            T,
            n_sub,
            mat_T,
            mat_h,
            cont,
            nl,
            p,
            i,
            scratch,
            2 * b,
            w_extra,
        )
    kb += 1
    k[b] = kb
    kk = min(kb, n_steps - 1)
    finite = True
    te2 = 0.0  # ‖x_d − x‖², the squared tracking error (true position)
    for i in range(n_axes):
        x = z[b, i, 0]
        if not (math.isfinite(x) and math.isfinite(z[b, i, 1])):
            finite = False
        xm = _encoder(_drive_position(z, b, i), seed[b], kb, i, p, cfg, nl)
        ax[AX_VEL, b, i] = (xm - ax[AX_MEAS, b, i]) * inv_T
        ax[AX_MEAS, b, i] = xm
    for r in range(n_axes):
        acc = 0.0
        for c in range(n_axes):
            acc += frame[kk, c, r] * (ref_pav[kk, 0, c] - z[b, c, 0])
        est[b, r] = acc
        ax[AX_REF, b, r] = ref_pav[kk, 0, r]
        d = ref_pav[kk, 0, r] - z[b, r, 0]
        te2 += d * d
    if finite:
        pz = z[b, 2, 0] if n_axes == 3 else 0.0
        e = path_distance(seg_type, seg_data, seg_bounds, z[b, 0, 0], z[b, 1, 0], pz)
        eps[b] = e
        st = STATUS_OK
        if e > cfg[C_ABORT]:
            st = STATUS_CONTOUR_LIMIT
        elif te2 > cfg[C_ABORT_TRACK2]:
            st = STATUS_TRACKING_LIMIT
        status[b] = st
        if st == STATUS_OK:
            reward[b] = (
                -(cfg[C_W_CONTOUR] * e + cfg[C_W_LAG] * abs(est[b, 0])) * cfg[C_INV_EPS]
                - cfg[C_W_EFFORT] * effort * cfg[C_INV_AXES]
            )
        else:
            # a guard ended the episode: this step and each of the n_steps − 1 − kb it skips
            # count the guard penalty P, no less than any step that runs, so ending early
            # never pays (at least this step, should a caller step past the end)
            reward[b] = -cfg[C_GUARD_PENALTY] * max(n_steps - kb, 1)
        observe(n_axes, b, kk, cfg, obs_tab, ax, ref_pav, frame, obs)
    else:
        eps[b] = math.inf
        status[b] = STATUS_NONFINITE
        # a finite penalty: the guard penalty for this step and every skipped one (as above);
        # observation zeroed
        reward[b] = -cfg[C_GUARD_PENALTY] * max(n_steps - kb, 1)
        for o in range(obs.shape[1]):
            obs[b, o] = 0.0
    terminated[b] = status[b] != STATUS_OK
    truncated[b] = (kb >= n_steps - 1) and not terminated[b]
    # the batched info arrays (empty ones: not wanted), written while the env's data is hot
    if info[3].shape[0] > 0:
        fill_info(n_axes, b, T, k, z, ax, eps, est, info)


@njit(cache=True)
def first_bad_action(action, active):
    """Index of the first active env whose action is not finite, or -1."""
    for b in range(action.shape[0]):
        if active[b]:
            for i in range(action.shape[1]):
                if not math.isfinite(action[b, i]):
                    return b
    return -1


@njit(cache=True)
def env_step(
    cfg,
    icfg,
    obs_tab,
    z,
    ax,
    k,
    eps,
    est,
    status,
    seed,
    ref_pav,
    frame,
    seg_type,
    seg_data,
    seg_bounds,
    mat_T,
    mat_h,
    cont,
    nl,
    pidx,
    action,
    active,
    obs,
    reward,
    terminated,
    truncated,
    scratch,
    info,
):
    """Advance every active env by one servo period, in place (serial driver).

    Returns (bad, n_terminated, n_ended): bad is -1, or the index of the first env whose action
    is not finite (nothing is changed then); n_terminated and n_ended count the stepped envs
    now terminated, and terminated or truncated.

    Shapes: z (B, A, ns); ax (AX_SIZE, B, A); k, status (B,) int64; eps (B,); est (B, A);
    seed (B,) uint64; ref_pav (n, 3, 3) rows [position, velocity, acceleration];
    frame (n, 3, 3) columns [t n b]; obs_tab (n, n_static) float32 (observation_table);
    action (B, A) in [-1, 1] of the force limit; obs (B, O) float32; scratch (2 B, ns)
    (rows 2b, 2b + 1: work space of env b); info: the tuple of batched info arrays of
    :func:`fill_info`, filled for every stepped env (empty arrays: none).

    Two axes are given to the step as a literal: the compiler unrolls the per-axis loops and
    interleaves the two axes (measured 1.1-2x faster); other axis counts take the generic body.
    Same arithmetic either way (no fast-math), so the results do not depend on the branch, the
    driver or the thread count.
    """
    bad = first_bad_action(action, active)
    if bad >= 0:
        return bad, 0, 0
    # the states as rows (env b, axis i) -> b * A + i: a view made once per call, not per env
    z2 = z.reshape((z.shape[0] * z.shape[1], z.shape[2]))
    # borrowed views (no reference count; see contour_env.env.borrow), made once per call
    # before the loop, with the per-env step inlined in the loop: the compiled step then has
    # no reference-count update left at all (a null meminfo is a constant, so LLVM removes
    # the increments and decrements), where a non-inlined per-env or per-chunk function
    # received its arrays as arguments and paid a call and a check per array and env
    # (issue 35: 1.6x slower)
    cfg = borrowed(cfg)
    icfg = borrowed(icfg)
    obs_tab = borrowed(obs_tab)
    z = borrowed(z)
    ax = borrowed(ax)
    k = borrowed(k)
    eps = borrowed(eps)
    est = borrowed(est)
    status = borrowed(status)
    seed = borrowed(seed)
    ref_pav = borrowed(ref_pav)
    frame = borrowed(frame)
    seg_type = borrowed(seg_type)
    seg_data = borrowed(seg_data)
    seg_bounds = borrowed(seg_bounds)
    mat_T = borrowed(mat_T)
    mat_h = borrowed(mat_h)
    cont = borrowed(cont)
    nl = borrowed(nl)
    pidx = borrowed(pidx)
    action = borrowed(action)
    active = borrowed(active)
    obs = borrowed(obs)
    reward = borrowed(reward)
    terminated = borrowed(terminated)
    truncated = borrowed(truncated)
    scratch = borrowed(scratch)
    z2 = borrowed(z2)
    info = (borrowed(info[0]), borrowed(info[1]), borrowed(info[2]), borrowed(info[3]))
    n_envs = z.shape[0]
    n_axes = z.shape[1]
    n_terminated = 0
    n_ended = 0
    if n_axes == 2:
        for b in range(n_envs):
            if active[b]:
                _step_one(
                    2,
                    b,
                    cfg,
                    icfg,
                    obs_tab,
                    z,
                    z2,
                    ax,
                    k,
                    eps,
                    est,
                    status,
                    seed,
                    ref_pav,
                    frame,
                    seg_type,
                    seg_data,
                    seg_bounds,
                    mat_T,
                    mat_h,
                    cont,
                    nl,
                    pidx,
                    action,
                    obs,
                    reward,
                    terminated,
                    truncated,
                    scratch,
                    info,
                )
                n_terminated += 1 if terminated[b] else 0
                n_ended += 1 if terminated[b] or truncated[b] else 0
    else:
        for b in range(n_envs):
            if active[b]:
                _step_one(
                    n_axes,
                    b,
                    cfg,
                    icfg,
                    obs_tab,
                    z,
                    z2,
                    ax,
                    k,
                    eps,
                    est,
                    status,
                    seed,
                    ref_pav,
                    frame,
                    seg_type,
                    seg_data,
                    seg_bounds,
                    mat_T,
                    mat_h,
                    cont,
                    nl,
                    pidx,
                    action,
                    obs,
                    reward,
                    terminated,
                    truncated,
                    scratch,
                    info,
                )
                n_terminated += 1 if terminated[b] else 0
                n_ended += 1 if terminated[b] or truncated[b] else 0
    return -1, n_terminated, n_ended


@njit(cache=True, parallel=True)
def env_step_parallel(
    cfg,
    icfg,
    obs_tab,
    z,
    ax,
    k,
    eps,
    est,
    status,
    seed,
    ref_pav,
    frame,
    seg_type,
    seg_data,
    seg_bounds,
    mat_T,
    mat_h,
    cont,
    nl,
    pidx,
    action,
    active,
    obs,
    reward,
    terminated,
    truncated,
    scratch,
    info,
):
    """As :func:`env_step`, with the envs spread over numba's threads (``numba.set_num_threads``
    before the call sets how many): a ``prange`` over the envs, which numba's static schedule
    cuts into one contiguous block of nearly equal size per thread (one hand-off per call).
    Same arithmetic per env, and each env's step reads and writes only its own rows, so the
    results are bit-identical to the serial driver whatever the thread count (the two counts
    returned are integer sums)."""
    bad = first_bad_action(action, active)
    if bad >= 0:
        return bad, 0, 0
    # the states as rows (env b, axis i) -> b * A + i: a view made once per call, not per env
    z2 = z.reshape((z.shape[0] * z.shape[1], z.shape[2]))
    # the arrays as they are, not borrowed: numba's thread team receives them as raw buffers,
    # with no reference count to update (borrowed views measured no faster here; see
    # contour_env.env.borrow on views in a prange). The step is inlined in the loop body, so
    # the per-env code makes no call (issue 35: a non-inlined per-chunk function cost 1.6x)
    n_envs = z.shape[0]
    n_axes = z.shape[1]
    n_terminated = 0
    n_ended = 0
    if n_axes == 2:
        for b in prange(n_envs):
            if active[b]:
                _step_one(
                    2,
                    b,
                    cfg,
                    icfg,
                    obs_tab,
                    z,
                    z2,
                    ax,
                    k,
                    eps,
                    est,
                    status,
                    seed,
                    ref_pav,
                    frame,
                    seg_type,
                    seg_data,
                    seg_bounds,
                    mat_T,
                    mat_h,
                    cont,
                    nl,
                    pidx,
                    action,
                    obs,
                    reward,
                    terminated,
                    truncated,
                    scratch,
                    info,
                )
                n_terminated += 1 if terminated[b] else 0
                n_ended += 1 if terminated[b] or truncated[b] else 0
    else:
        for b in prange(n_envs):
            if active[b]:
                _step_one(
                    n_axes,
                    b,
                    cfg,
                    icfg,
                    obs_tab,
                    z,
                    z2,
                    ax,
                    k,
                    eps,
                    est,
                    status,
                    seed,
                    ref_pav,
                    frame,
                    seg_type,
                    seg_data,
                    seg_bounds,
                    mat_T,
                    mat_h,
                    cont,
                    nl,
                    pidx,
                    action,
                    obs,
                    reward,
                    terminated,
                    truncated,
                    scratch,
                    info,
                )
                n_terminated += 1 if terminated[b] else 0
                n_ended += 1 if terminated[b] or truncated[b] else 0
    return -1, n_terminated, n_ended


@njit(cache=True)
def env_reset(
    envs,
    cfg,
    obs_tab,
    z,
    ax,
    k,
    eps,
    est,
    status,
    seed,
    ref_pav,
    frame,
    seg_type,
    seg_data,
    seg_bounds,
    nl,
    pidx,
    stuck0,
    obs,
    reward,
    terminated,
    truncated,
):
    """Put every env listed in ``envs`` (int64 indices) at rest on the reference start point
    (k = 0), with its observation, zero reward and no done flags (seeds already in ``seed``)."""
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
                toff = uniform01(seed[b], 0, i, _STREAM_PHASE) / nl[p, i, NL_FD]
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
