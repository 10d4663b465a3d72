"""The fused episode loops: per servo period and env, the controller law
(:func:`agents.compiled.laws.law`), the env action (the command as a float32 fraction of the
controller's force limit, as ``Controller.action``) and the kernel's per-env step
(:func:`contour_env.env.kernel.step_one`), in one compiled loop.

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
from contour_env.env.kernel import (
    I_NSTEPS,
    borrow_trace,
    borrowed_records,
    record_step,
    step_one,
)

from .laws import WORK_SIZE, CompiledLaw, law


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


@njit(cache=True, inline="always")
def borrowed_inputs(law_arrays, cfg, icfg, state, path, plant, scal, action, out, info, trace):
    """The arguments of a compiled loop, every array borrowed (no reference counting per
    step; see contour_env.env.borrow), in the same order."""
    B = borrowed
    state, path, plant, out = borrowed_records(state, path, plant, out)
    law_arrays = CompiledLaw(
        law_arrays.kind, B(law_arrays.fp), B(law_arrays.st), B(law_arrays.flim)
    )
    trace = borrow_trace(trace)
    info = (B(info[0]), B(info[1]), B(info[2]), B(info[3]))
    return law_arrays, B(cfg), B(icfg), state, path, plant, B(scal), B(action), out, info, trace


@njit(cache=True)
def run_single(law_arrays, cfg, icfg, state, path, plant, scal, action, out, info, trace):
    """Env 0 from its current (reset) state to the end of the episode. Returns (n, bad):
    n steps recorded; bad is 1 when the controller's action was not finite (nothing stepped
    then; the caller raises as the env would). ``law_arrays``: :class:`.laws.CompiledLaw`;
    the env's records (:mod:`contour_env.env.layout`); ``trace``: :class:`EpisodeTrace`. The
    loop runs on borrowed views of the arrays (no reference counting per step; see
    contour_env.env.borrow): same arithmetic."""
    return _run_single(
        *borrowed_inputs(law_arrays, cfg, icfg, state, path, plant, scal, action, out, info, trace)
    )


@njit(cache=True)
def _run_single(law_arrays, cfg, icfg, state, path, plant, scal, action, out, info, trace):
    z, ax, k = state.z, state.ax, state.k
    kind, fp, st, flim = law_arrays
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
        law(kind, A, b, kk, T, ax, path.ref_pav, path.frame, scal, fp, st, u, work)
        if not _action(A, b, u, flim, action):
            return n, 1
        if A == 2:
            step_one(2, b, cfg, icfg, state, z2, path, plant, action, out, info)
        else:
            step_one(A, b, cfg, icfg, state, z2, path, plant, action, out, info)
        record_step(n, b, A, T, n_steps, state, path, trace)
        if out.terminated[b] or out.truncated[b]:
            return n + 1, 0
    return n_max, 0


# the batch loop's blocks: one env per block up to this many blocks (an episode per env is
# plenty of work for a thread), then contiguous runs of envs
BATCH_BLOCKS = 64


@njit(cache=True, parallel=True)
def run_batch(
    law_arrays, cfg, icfg, state, path, plant, scal, action, out, info, sq, peak, count, failed,
    bad, trace, steps,
):  # fmt: skip
    """Every env of the batch from its current (reset) state to the end of its episode,
    accumulating what ``agents.compare.robustness`` accumulates: Σ min(ε, 10³)², the peak ε,
    the step count and whether the episode was stopped by a guard (ε read as +inf where not
    finite). ``trace`` (n_max, B) or (0, B): ε per step while running (NaN where not finite).
    ``steps[b]``: the env's episode length; ``bad[b]``: 1 if its controller's action went
    non-finite (the env stops there).

    The envs are cut into at most :data:`BATCH_BLOCKS` contiguous blocks, spread over numba's
    threads; each block runs in :func:`_run_block`, which borrows the arrays once, as the env's
    own parallel driver does (contour_env.env.kernel.step_range): records used inside a
    ``prange`` body reach the threads with live reference counts, an atomic update per field
    read on counters the threads share (this loop ran ~4x slower so at 4096 envs). Same
    arithmetic per env: the results do not depend on the blocks or the thread count."""
    B = state.z.shape[0]
    n_blocks = max(min(BATCH_BLOCKS, B), 1)
    for c in prange(n_blocks):
        _run_block(
            c * B // n_blocks, (c + 1) * B // n_blocks, law_arrays, cfg, icfg, state, path,
            plant, scal, action, out, info, sq, peak, count, failed, bad, trace, steps,
        )  # fmt: skip


@njit(cache=True)
def _run_block(
    lo, hi, law_arrays, cfg, icfg, state, path, plant, scal, action, out, info, sq, peak, count,
    failed, bad, trace, steps,
):  # fmt: skip
    # envs [lo, hi) of run_batch, on borrowed views (no reference counting in the loop)
    R = borrowed
    state, path, plant, out = borrowed_records(state, path, plant, out)
    kind = law_arrays.kind
    fp, st, flim = R(law_arrays.fp), R(law_arrays.st), R(law_arrays.flim)
    cfg, icfg, scal, action = R(cfg), R(icfg), R(scal), R(action)
    info = (R(info[0]), R(info[1]), R(info[2]), R(info[3]))
    sq, peak, count, failed, bad, steps = R(sq), R(peak), R(count), R(failed), R(bad), R(steps)
    trace = R(trace)
    z, ax, k, eps = state.z, state.ax, state.k, state.eps
    terminated, truncated = out.terminated, out.truncated
    A = z.shape[1]
    n_steps = icfg[I_NSTEPS]
    n_max = n_steps - 1
    T = cfg[0]
    z2 = R(z.reshape((z.shape[0] * z.shape[1], z.shape[2])))
    tracing = trace.shape[0] > 0
    u = np.zeros(A)
    work = np.zeros(WORK_SIZE)
    for b in range(lo, hi):
        for n in range(n_max):
            kk = min(k[b], n_steps - 1)
            law(kind, A, b, kk, T, ax, path.ref_pav, path.frame, scal, fp, st, u, work)
            if not _action(A, b, u, flim, action):
                bad[b] = 1
                break
            if A == 2:
                step_one(2, b, cfg, icfg, state, z2, path, plant, action, out, info)
            else:
                step_one(A, b, cfg, icfg, state, z2, path, plant, action, out, info)
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
