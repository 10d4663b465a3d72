"""Repeated-batch episodes: the same contour trial after trial, a learning controller
improving between trials.

:func:`run_trial` runs one trial of a single or a vectorised env with any controller of the
policy protocol and records everything a learning law needs (:class:`~agents.trial.TrialRecord`).
:func:`run_batch` repeats it, calls ``controller.learn(trial)`` between trials (controllers
without ``learn`` simply repeat) and scores every trial with the project's one scoring
function (:func:`contour_env.metrics.score`). With a vectorised env the B envs are independent
batches (e.g. plant-parameter variants) learning side by side; the per-iteration metrics are
those of env 0 plus the batch mean and worst case.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable

import numpy as np

from contour_env.env.core import core_of
from contour_env.metrics import score

from .trial import TrialRecord

# An iteration counts as "error growing" (:func:`error_growing`) when its RMS contour error
# exceeds a reference by more than this factor plus an absolute allowance (fluctuations of a
# few % or of a fraction of an encoder increment at the converged floor are not divergence):
# - a jump: the reference is the previous iteration;
# - a sustained rise: the last SUSTAINED_RISE_STEPS changes were none of them a fall (each
#   iteration's RMS not lower than the one before) and the reference is the iteration
#   SUSTAINED_RISE_STEPS back, so a staircase of small steps, each within the tolerance,
#   is flagged once it has added up to more than it.
GROWTH_TOLERANCE = 1.05
GROWTH_ALLOWANCE_UM = 0.05
SUSTAINED_RISE_STEPS = 3


def _exceeds(rms: float, reference: float) -> bool:
    return rms > GROWTH_TOLERANCE * reference + GROWTH_ALLOWANCE_UM


def error_growing(rms_history) -> bool:
    """Whether the last of the RMS contour errors ``rms_history`` (µm, one per iteration,
    oldest first; None: a trial without metrics) shows growth.

    True when the last is None; when it exceeds the one before by more than 5 % + 0.05 µm
    (a jump); or when none of the last ``SUSTAINED_RISE_STEPS`` (3) changes was a fall and the
    last exceeds the value 3 iterations back by more than 5 % + 0.05 µm (a sustained rise,
    e.g. + 2 % per iteration). A fall anywhere in those 3 changes, or a rise within the noise
    allowance, is not growth; the first iteration never is.
    """
    hist = list(rms_history)
    if not hist:
        return False
    rms = hist[-1]
    if rms is None:
        return True
    if len(hist) < 2 or hist[-2] is None:
        return False
    if _exceeds(rms, hist[-2]):
        return True
    k = SUSTAINED_RISE_STEPS
    window = hist[-(k + 1) :]
    if len(window) < k + 1 or any(v is None for v in window):
        return False
    rising = all(b >= a for a, b in zip(window[:-1], window[1:], strict=True))
    return rising and _exceeds(rms, window[0])


def fingerprint_of(core) -> dict:
    """What a trial runs on: case, plant, path (hash of the reference table), N, A, T."""
    digest = hashlib.sha256(np.ascontiguousarray(core.ref_pav).tobytes()).hexdigest()[:16]
    return {
        "case": core.setup.name,
        "plant": core.setup.plant.name,
        "n_samples": int(core.n_steps - 1),
        "n_axes": int(core.dim),
        "servo_period_s": float(core.T),
        "reference_sha256": digest,
    }


def run_trial(env, controller, *, seed: int = 0) -> TrialRecord:
    """One trial from ``env.reset(seed=seed)`` to the end of the path and settle time.

    ``controller`` must already be bound to ``env`` (``controller.bind(env)``). Each sample:
    read the servo signals, ask the controller for its command, step the env through its
    public ``step`` (so the env's checks and wrappers apply), record. An env stopped by the
    crash guard is marked invalid from there on (in the vector env it is not stepped into
    its next episode: the run stops when every env has ended).
    """
    holder, core = core_of(env)
    vector = hasattr(holder, "num_envs")
    B, A, N = core.n_envs, core.dim, core.n_steps - 1
    if getattr(controller, "_core", None) is not core:
        raise ValueError("controller: bind it to this env first (controller.bind(env))")
    env.reset(seed=seed)
    controller.reset()
    T = core.T
    limit = controller.force_limit
    ref = core.ref_pav
    frame = core.frame[:N, :A, :A].copy()
    meas = np.zeros((B, N, A))
    vel = np.zeros((B, N, A))
    cmd = np.zeros((B, N, A))
    pos = np.zeros((B, N, A))
    force = np.zeros((B, N, A))
    sat = np.zeros((B, N, A), dtype=bool)
    eps = np.zeros((B, N))
    valid = np.zeros((B, N), dtype=bool)
    reasons: list = [None] * B
    running = np.ones(B, dtype=bool)
    for k in range(N):
        sig = core.signals_batch()
        u = np.asarray(controller.command(sig), dtype=np.float64)
        action = np.clip(u / limit, -1.0, 1.0).astype(np.float32)
        meas[:, k] = sig["measured_position"]
        vel[:, k] = sig["measured_velocity"]
        cmd[:, k] = u
        if vector:
            _, _, term, trunc, _ = env.step(action)
        else:
            _, _, t1, t2, _ = env.step(action[0])
            term, trunc = np.array([t1]), np.array([t2])
        valid[:, k] = running
        pos[:, k] = core.positions
        force[:, k] = core.applied_force
        sat[:, k] = core.saturated
        eps[:, k] = core.eps
        for b in np.flatnonzero(running & term):
            reasons[b] = core.info(int(b))["termination_reason"] or "terminated"
        running &= ~(term | trunc)
        if not running.any():
            break
    # samples after an env ended hold no data of this trial
    for arr in (meas, vel, cmd, pos, force, eps):
        arr[~valid] = 0.0
    eps[~np.isfinite(eps)] = np.inf
    axis_error = ref[:N, 0, :A][None] - meas
    axis_error[~valid] = 0.0
    task_error = np.einsum("nij,bni->bnj", frame, axis_error)
    kk = np.minimum(np.arange(1, N + 1), core.n_steps - 1)
    return TrialRecord(
        time_s=np.arange(N) * T,
        servo_period_s=T,
        reference_position=ref[:N, 0, :A].copy(),
        reference_velocity=ref[:N, 1, :A].copy(),
        reference_acceleration=ref[:N, 2, :A].copy(),
        frame=frame,
        curvature=core.scal[:N, 2].copy(),
        measured_position=meas,
        measured_velocity=vel,
        command=cmd,
        axis_error=axis_error,
        task_error=task_error,
        position=pos,
        reference_after=ref[kk, 0, :A].copy(),
        force=force,
        saturated=sat,
        contour_error=eps,
        valid=valid,
        termination_reason=reasons,
        force_limit=np.asarray(limit, dtype=np.float64).copy(),
        fingerprint=fingerprint_of(core),
    )


def _iteration_row(i: int, trial: TrialRecord, previous_rows: list[dict]) -> dict:
    per_env = [score(trial.episode(b)) for b in range(trial.n_envs)]
    row = {"iteration": i, **per_env[0]}
    row["completed"] = trial.termination_reason[0] is None
    row["termination_reason"] = trial.termination_reason[0]
    rms = row["rms_contour_error_um"]
    if rms is None or not row["completed"]:
        row["error_growing"] = True
    else:
        # an earlier trial that did not complete has no comparable RMS
        history = [
            r["rms_contour_error_um"] if r["completed"] else None
            for r in previous_rows[-SUSTAINED_RISE_STEPS:]
        ]
        row["error_growing"] = error_growing([*history, rms])
    if trial.n_envs > 1:
        rms_all = [m["rms_contour_error_um"] for m in per_env]
        max_all = [m["max_contour_error_um"] for m in per_env]
        finite = [r for r in rms_all if r is not None]
        row["batch"] = {
            "n_envs": trial.n_envs,
            "mean_rms_contour_error_um": float(np.mean(finite)) if finite else None,
            "worst_rms_contour_error_um": float(np.max(finite)) if finite else None,
            "worst_max_contour_error_um": max((m for m in max_all if m is not None), default=None),
            "failures": int(sum(r is not None for r in trial.termination_reason)),
        }
    return row


def run_batch(
    env,
    controller,
    iterations: int,
    *,
    seed: int = 0,
    learn: bool = True,
    progress: bool | Callable = False,
    keep_trials: tuple = (1, -1),
) -> dict:
    """Run ``iterations`` trials of ``env`` with ``controller`` (bound here if it is not).

    After every trial (the last one too, so that a saved learning state holds every lesson)
    ``controller.learn(trial)`` is called when ``learn`` and the controller has one. Trial i
    (1-based) runs with seed ``seed + i − 1``: a noise-free case repeats exactly, measurement
    noise and random disturbances are new in every trial, and the whole run is reproducible.
    ``progress``: True for a tqdm bar
    over iterations, or a callable ``progress(row)`` called after every iteration.

    Returns ``{"case", "plant", "controller", "iterations": [row, ...], "trials": {...}}``:
    a row per iteration with ``iteration`` (1-based), the metrics of
    :func:`contour_env.metrics.score` for env 0, ``completed``, ``termination_reason``,
    ``error_growing`` (:func:`error_growing`: RMS > 1.05 × previous + 0.05 µm, or a
    sustained rise — no fall over the last 3 iterations and RMS > 1.05 × the value 3
    iterations back + 0.05 µm —, or the trial did not complete), and, with a vectorised env,
    ``batch`` (mean and worst RMS over the envs, worst max, failures).
    ``trials`` holds the :class:`TrialRecord` of the iterations in ``keep_trials`` (1-based,
    negative from the end; for plots; not JSON).
    """
    if isinstance(iterations, bool) or not isinstance(iterations, (int, np.integer)):
        raise ValueError(f"iterations: must be an integer >= 1, got {iterations!r}")
    if iterations < 1:
        raise ValueError(f"iterations: must be an integer >= 1, got {iterations}")
    _, core = core_of(env)
    if getattr(controller, "_core", None) is not core:
        controller.bind(env)
    keep = {(i if i > 0 else iterations + 1 + i) for i in keep_trials}
    rows: list[dict] = []
    trials: dict = {}
    bar = None
    if progress is True:
        from tqdm.auto import tqdm

        bar = tqdm(total=iterations, desc=f"{getattr(controller, 'name', 'trial')}", unit="trial")
    for i in range(1, iterations + 1):
        trial = run_trial(env, controller, seed=seed + i - 1)
        row = _iteration_row(i, trial, rows)
        rows.append(row)
        if i in keep:
            trials[i] = trial
        if learn and hasattr(controller, "learn"):
            controller.learn(trial)
        if bar is not None:
            rms = row["rms_contour_error_um"]
            bar.set_postfix_str(f"RMS ε {rms:.3g} µm" if rms is not None else "failed")
            bar.update(1)
        elif callable(progress):
            progress(row)
    if bar is not None:
        bar.close()
    setup = core.setup
    first, last = rows[0]["rms_contour_error_um"], rows[-1]["rms_contour_error_um"]
    return {
        "case": setup.name,
        "plant": setup.plant.name,
        "controller": getattr(controller, "name", type(controller).__name__),
        "n_envs": core.n_envs,
        "seed": seed,
        # the run diverged: a trial failed, or the last trial is worse than the first
        "diverged": bool(
            any(not r["completed"] for r in rows)
            or first is None
            or last is None
            or _exceeds(last, first)
        ),
        "iterations": rows,
        "trials": trials,
    }
