"""The fused episode loops: per servo period and env, the controller law
(:func:`agents.compiled.laws.law`), the env action (the command as a float32 fraction of the
controller's force limit, as ``Controller.action``) and the kernel's per-env step
(:func:`contour_env.env.kernel._step_one`), in one compiled loop.

They live here, next to the laws, rather than in :mod:`contour_env.env.rollout` (which holds
the env side: recording, eligibility, the EpisodeRecord) because a numba function that takes
another compiled function as an argument cannot be cached to disk, and the loop inlines the
whole step kernel: it must come from the cache to start in milliseconds.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from contour_env.env.borrow import borrowed
from contour_env.env.kernel import AX_APPLIED, I_NSTEPS, _step_one

from .laws import law

WORK_SIZE = 4 * 3 + 2 * 9 + 6


@njit(cache=True, inline="always")
def _action(A, b, u, flim, action):
    # Controller.action: clip(u / force_limit, -1, 1) as float32, then the env's float64
    ok = True
    for i in range(A):
        a = u[i] / flim[i]
        if a < -1.0:
            a = -1.0
        elif a > 1.0:
            a = 1.0
        a = np.float64(np.float32(a))
        if not math.isfinite(a):
            ok = False
        action[b, i] = a
    return ok


@njit(cache=True)
def run_single(
    kind, fp, st, flim, cfg, icfg, obs_tab, z, ax, k, eps, est, status, seed, ref_pav, frame,
    scal, seg_type, seg_data, seg_bounds, mat_T, mat_h, cont, nl, pidx, action, obs, reward,
    terminated, truncated, scratch, info, rec_time, rec_eps, rec_pos, rec_ref, rec_force,
):  # fmt: skip
    """Env 0 from its current (reset) state to the end of the episode. Returns (n, bad):
    n steps recorded; bad is 1 when the controller's action was not finite (nothing stepped
    then; the caller raises as the env would). The loop runs on borrowed views of the arrays
    (no reference counting per step; see contour_env.env.borrow): same arithmetic."""
    B = borrowed
    return _run_single(
        kind, B(fp), B(st), B(flim), B(cfg), B(icfg), B(obs_tab), B(z), B(ax), B(k), B(eps),
        B(est), B(status), B(seed), B(ref_pav), B(frame), B(scal), B(seg_type), B(seg_data),
        B(seg_bounds), B(mat_T), B(mat_h), B(cont), B(nl), B(pidx), B(action), B(obs),
        B(reward), B(terminated), B(truncated), B(scratch),
        (B(info[0]), B(info[1]), B(info[2]), B(info[3])),
        B(rec_time), B(rec_eps), B(rec_pos), B(rec_ref), B(rec_force),
    )  # fmt: skip


@njit(cache=True)
def _run_single(
    kind, fp, st, flim, cfg, icfg, obs_tab, z, ax, k, eps, est, status, seed, ref_pav, frame,
    scal, seg_type, seg_data, seg_bounds, mat_T, mat_h, cont, nl, pidx, action, obs, reward,
    terminated, truncated, scratch, info, rec_time, rec_eps, rec_pos, rec_ref, rec_force,
):  # fmt: skip
    A = z.shape[1]
    n_steps = icfg[I_NSTEPS]
    n_max = n_steps - 1
    T = cfg[0]
    z2 = z.reshape((z.shape[0] * z.shape[1], z.shape[2]))
    u = np.zeros(A)
    work = np.zeros(WORK_SIZE)
    b = 0
    for n in range(n_max):
        kk = min(k[b], n_steps - 1)
        law(kind, A, b, kk, T, ax, ref_pav, frame, scal, fp, st, u, work)
        if not _action(A, b, u, flim, action):
            return n, 1
        if A == 2:
            _step_one(
                2, b, cfg, icfg, obs_tab, z, z2, ax, k, eps, est, status, seed, ref_pav,
                frame, seg_type, seg_data, seg_bounds, mat_T, mat_h, cont, nl, pidx, action,
                obs, reward, terminated, truncated, scratch, info,
            )  # fmt: skip
        else:
            _step_one(
                A, b, cfg, icfg, obs_tab, z, z2, ax, k, eps, est, status, seed, ref_pav,
                frame, seg_type, seg_data, seg_bounds, mat_T, mat_h, cont, nl, pidx, action,
                obs, reward, terminated, truncated, scratch, info,
            )  # fmt: skip
        kb = k[b]
        rec_time[n] = kb * T
        rec_eps[n] = eps[b]
        kk = min(kb, n_steps - 1)
        for i in range(A):
            rec_pos[n, i] = z[b, i, 0]
            rec_ref[n, i] = ref_pav[kk, 0, i]
            rec_force[n, i] = ax[AX_APPLIED, b, i]
        if terminated[b] or truncated[b]:
            return n + 1, 0
    return n_max, 0


@njit(cache=True, parallel=True)
def run_batch(
    kind, fp, st, flim, cfg, icfg, obs_tab, z, ax, k, eps, est, status, seed, ref_pav, frame,
    scal, seg_type, seg_data, seg_bounds, mat_T, mat_h, cont, nl, pidx, action, obs, reward,
    terminated, truncated, scratch, info, sq, peak, count, failed, bad, trace, steps,
):  # fmt: skip
    """Every env of the batch from its current (reset) state to the end of its episode, each
    on its own thread, accumulating what ``agents.compare.robustness`` accumulates: Σ min(ε,
    10³)², the peak ε, the step count and whether the episode was stopped by a guard (ε read
    as +inf where not finite). ``trace`` (n_max, B) or (0, B): ε per step while running (NaN
    where not finite). ``steps[b]``: the env's episode length; ``bad[b]``: 1 if its
    controller's action went non-finite (the env stops there)."""
    A = z.shape[1]
    n_steps = icfg[I_NSTEPS]
    n_max = n_steps - 1
    T = cfg[0]
    B = z.shape[0]
    z2 = z.reshape((z.shape[0] * z.shape[1], z.shape[2]))
    tracing = trace.shape[0] > 0
    for b in prange(B):
        u = np.zeros(A)
        work = np.zeros(WORK_SIZE)
        for n in range(n_max):
            kk = min(k[b], n_steps - 1)
            law(kind, A, b, kk, T, ax, ref_pav, frame, scal, fp, st, u, work)
            if not _action(A, b, u, flim, action):
                bad[b] = 1
                break
            if A == 2:
                _step_one(
                    2, b, cfg, icfg, obs_tab, z, z2, ax, k, eps, est, status, seed, ref_pav,
                    frame, seg_type, seg_data, seg_bounds, mat_T, mat_h, cont, nl, pidx,
                    action, obs, reward, terminated, truncated, scratch, info,
                )  # fmt: skip
            else:
                _step_one(
                    A, b, cfg, icfg, obs_tab, z, z2, ax, k, eps, est, status, seed, ref_pav,
                    frame, seg_type, seg_data, seg_bounds, mat_T, mat_h, cont, nl, pidx,
                    action, obs, reward, terminated, truncated, scratch, info,
                )  # fmt: skip
            e = eps[b]
            if not math.isfinite(e):
                e = math.inf
            elif tracing:
                trace[n, b] = e
            m = min(e, 1e3)
            sq[b] += m * m
            if e > peak[b] or e != e:
                peak[b] = e
            count[b] += 1.0
            steps[b] = n + 1
            if terminated[b]:
                failed[b] = True
            if terminated[b] or truncated[b]:
                break
