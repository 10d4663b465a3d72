"""The compiled environment step, shared by the single and the vectorised env.

One call: plant step → reference at k+1 → measurement → true contour error → crash guard →
reward → observation, for every active env of the batch. The single env is a batch of one, so
the two cannot drift apart.
"""

from __future__ import annotations

import math

from numba import njit, prange

from ..contour_error import path_distance
from ..noise import standard_normal, uniform01
from ..plants.kernel import NL_FD, NL_FMAX, NL_RES, axis_step

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
) = range(15)
CFG_SIZE = 15
# integer configuration (icfg)
I_NSTEPS, I_NSUB, I_DELAY = range(3)
ICFG_SIZE = 3
# per-axis env state and readout rows (ax[row, b, axis]; row-major so each row of the batch
# is contiguous and the info arrays are plain copies)
# AX_TOFF: the env's time offset of the plant's periodic disturbance d(t) (s), drawn per episode
AX_STUCK, AX_UPEND, AX_MEAS, AX_VEL, AX_PREV, AX_APPLIED, AX_SAT, AX_REF, AX_TOFF = range(9)
AX_SIZE = 9
# termination status codes
STATUS_OK, STATUS_CONTOUR_LIMIT, STATUS_NONFINITE = 0, 1, 2
# noise streams
_STREAM_MEAS, _STREAM_DIST, _STREAM_PHASE = 0, 1, 2


@njit(cache=True, inline="always")
def observe(b, kk, cfg, preview, ax, ref_pav, frame, scal, n_steps, obs):
    """Fill obs[b] for reference index kk from the measured state (layout: see ContouringEnv)."""
    dim = ax.shape[2]
    clip = cfg[C_OBS_CLIP]
    # reciprocals once per call: a multiply per field instead of a division
    inv_err = 1.0 / cfg[C_ERR_SCALE]
    inv_verr = 1.0 / cfg[C_VERR_SCALE]
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
    obs[b, o] = min(max(scal[kk, 0] / cfg[C_FEED_SCALE], -clip), clip)
    obs[b, o + 1] = min(max(scal[kk, 1] / cfg[C_ACC_SCALE], -clip), clip)
    obs[b, o + 2] = min(max(scal[kk, 2] * cfg[C_CURV_SCALE], -clip), clip)
    o += 3
    # preview: upcoming reference points in the current task frame, scaled by the distance the
    # nominal feed covers in that time (≈ (1, 0, 0) on a straight at full feed)
    for j in range(preview.shape[0]):
        kj = min(kk + preview[j], n_steps - 1)
        inv_scale = 1.0 / (cfg[C_FEED_SCALE] * preview[j] * cfg[C_T])
        for r in range(dim):
            acc = 0.0
            for c in range(dim):
                acc += frame[kk, c, r] * (ref_pav[kj, 0, c] - ref_pav[kk, 0, c])
            obs[b, o] = min(max(acc * inv_scale, -clip), clip)
            o += 1
    for r in range(dim):
        obs[b, o] = ax[AX_PREV, b, r]
        o += 1


@njit(cache=True, inline="always")
def _step_one(
    b,
    cfg,
    icfg,
    preview,
    z,
    ax,
    k,
    eps,
    est,
    status,
    seed,
    ref_pav,
    frame,
    scal,
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
):
    # one env, one servo period (the body shared by the serial and the parallel driver)
    n_axes = z.shape[1]
    ns = z.shape[2]
    T = cfg[C_T]
    n_steps = icfg[I_NSTEPS]
    n_sub = icfg[I_NSUB]
    delay = icfg[I_DELAY] != 0
    noise_std = cfg[C_NOISE_STD]
    dist_amp = cfg[C_DIST_AMP]
    cur = scratch[b, 0]
    tmp = scratch[b, 1]
    tmp2 = scratch[b, 2]
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
        for r in range(ns):
            cur[r] = z[b, i, r]
        ax[AX_STUCK, b, i] = axis_step(
            cur,
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
            tmp,
            tmp2,
            w_extra,
        )
        for r in range(ns):
            z[b, i, r] = cur[r]
    kb += 1
    k[b] = kb
    kk = min(kb, n_steps - 1)
    finite = True
    for i in range(n_axes):
        x = z[b, i, 0]
        if not (math.isfinite(x) and math.isfinite(z[b, i, 1])):
            finite = False
        xm = x
        if noise_std > 0.0:
            xm += noise_std * standard_normal(seed[b], kb, i, _STREAM_MEAS)
        res = nl[p, i, NL_RES]
        if res > 0.0:
            xm = math.floor(xm / res + 0.5) * res
        ax[AX_VEL, b, i] = (xm - ax[AX_MEAS, b, i]) / T
        ax[AX_MEAS, b, i] = xm
    for r in range(n_axes):
        acc = 0.0
        for c in range(n_axes):
            acc += frame[kk, c, r] * (ref_pav[kk, 0, c] - z[b, c, 0])
        est[b, r] = acc
        ax[AX_REF, b, r] = ref_pav[kk, 0, r]
    if finite:
        pz = z[b, 2, 0] if n_axes == 3 else 0.0
        e = path_distance(seg_type, seg_data, seg_bounds, z[b, 0, 0], z[b, 1, 0], pz)
        eps[b] = e
        if e > cfg[C_ABORT]:
            status[b] = STATUS_CONTOUR_LIMIT
        else:
            status[b] = STATUS_OK
        reward[b] = (
            -(cfg[C_W_CONTOUR] * e + cfg[C_W_LAG] * abs(est[b, 0])) / cfg[C_EPS_SCALE]
            - cfg[C_W_EFFORT] * effort / n_axes
        )
        observe(b, kk, cfg, preview, ax, ref_pav, frame, scal, n_steps, obs)
    else:
        eps[b] = math.inf
        status[b] = STATUS_NONFINITE
        # a finite penalty equal to sitting at the crash guard; observation zeroed
        reward[b] = -(cfg[C_W_CONTOUR] * cfg[C_ABORT]) / cfg[C_EPS_SCALE] - cfg[C_W_EFFORT]
        for o in range(obs.shape[1]):
            obs[b, o] = 0.0
    terminated[b] = status[b] != STATUS_OK
    truncated[b] = (kb >= n_steps - 1) and not terminated[b]


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
    preview,
    z,
    ax,
    k,
    eps,
    est,
    status,
    seed,
    ref_pav,
    frame,
    scal,
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
):
    """Advance every active env by one servo period, in place (serial driver).

    Returns -1, or the index of the first env whose action is not finite (nothing is changed
    then). Shapes: z (B, A, ns); ax (AX_SIZE, B, A); k, status (B,) int64; eps (B,);
    est (B, A); seed (B,) uint64; ref_pav (n, 3, 3) rows [position, velocity, acceleration];
    frame (n, 3, 3) columns [t n b]; scal (n, 4) [feedrate, feed accel, curvature, torsion];
    action (B, A) in [-1, 1] of the force limit; obs (B, O) float32; scratch (B, 3, ns).
    """
    bad = first_bad_action(action, active)
    if bad >= 0:
        return bad
    for b in range(z.shape[0]):
        if active[b]:
            _step_one(
                b,
                cfg,
                icfg,
                preview,
                z,
                ax,
                k,
                eps,
                est,
                status,
                seed,
                ref_pav,
                frame,
                scal,
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
            )
    return -1


@njit(cache=True, parallel=True)
def env_step_parallel(
    cfg,
    icfg,
    preview,
    z,
    ax,
    k,
    eps,
    est,
    status,
    seed,
    ref_pav,
    frame,
    scal,
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
):
    """As :func:`env_step`, with the envs spread over threads (same arithmetic per env, so the
    results are bit-identical to the serial driver)."""
    bad = first_bad_action(action, active)
    if bad >= 0:
        return bad
    for b in prange(z.shape[0]):
        if active[b]:
            _step_one(
                b,
                cfg,
                icfg,
                preview,
                z,
                ax,
                k,
                eps,
                est,
                status,
                seed,
                ref_pav,
                frame,
                scal,
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
            )
    return -1


@njit(cache=True)
def env_reset(
    b,
    cfg,
    preview,
    z,
    ax,
    k,
    eps,
    est,
    status,
    seed,
    ref_pav,
    frame,
    scal,
    seg_type,
    seg_data,
    seg_bounds,
    nl,
    pidx,
    stuck0,
    obs,
    n_steps,
):
    """Put env b at rest on the reference start point (k = 0) and fill its observation."""
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
        xm = z[b, i, 0]
        if cfg[C_NOISE_STD] > 0.0:
            xm += cfg[C_NOISE_STD] * standard_normal(seed[b], 0, i, _STREAM_MEAS)
        res = nl[p, i, NL_RES]
        if res > 0.0:
            xm = math.floor(xm / res + 0.5) * res
        ax[AX_MEAS, b, i] = xm
        ax[AX_VEL, b, i] = 0.0
        est[b, i] = ref_pav[0, 0, i] - z[b, i, 0]
    k[b] = 0
    status[b] = STATUS_OK
    pz = z[b, 2, 0] if n_axes == 3 else 0.0
    eps[b] = path_distance(seg_type, seg_data, seg_bounds, z[b, 0, 0], z[b, 1, 0], pz)
    observe(b, 0, cfg, preview, ax, ref_pav, frame, scal, n_steps, obs)
