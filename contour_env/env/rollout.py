"""Compiled episodes: a controller's law and the env kernel in one numba loop.

A policy that offers ``compiled_form()`` (the classical controllers ``pd``, ``ccc``,
``adaptive-ccc``, ``jee-ccc``: :mod:`agents.compiled`) is run by
:func:`contour_env.evaluation.run_episode` without a Python call per servo period: the loop
computes the command from the env's servo signals, steps the env with the kernel's per-env
step (:func:`contour_env.env.kernel.step_one`) and records what ``run_episode`` records. The
record is bit-identical to the Python path's (same arithmetic, same counter-based noise keyed
by the episode seed); the env and the controller are left in the state the Python path leaves
them in.

This module is the env side (which envs qualify, the record); the loop itself is compiled next
to the laws (:mod:`agents.compiled.runner`), since contour_env does not import agents.

``CONTOUR_ENV_COMPILED=0`` in the environment, or ``run_episode(..., compiled=False)``, keeps
the Python path.
"""

from __future__ import annotations

import os
from dataclasses import replace

import numpy as np

from ..metrics import EpisodeRecord

ENV_VAR = "CONTOUR_ENV_COMPILED"
# wrappers that gym.make adds and that change nothing a run records
_TRANSPARENT_WRAPPERS = ("OrderEnforcing", "PassiveEnvChecker")


def compiled_allowed(compiled: bool | None = None) -> bool:
    """Whether the compiled path may be taken: ``compiled`` if given, else not disabled by
    ``CONTOUR_ENV_COMPILED=0``."""
    if compiled is not None:
        return bool(compiled)
    return os.environ.get(ENV_VAR, "1").strip().lower() not in ("0", "false", "no", "off")


def plain_env(env):
    """The ContouringEnv under ``env`` if nothing between changes a step (only gym.make's
    checker wrappers, no ``step``/``reset`` patched on an instance, e.g. to record rewards)
    and it does not render; else None."""
    from .contouring_env import ContouringEnv

    e = env
    while type(e) is not ContouringEnv:
        if type(e).__name__ not in _TRANSPARENT_WRAPPERS or not hasattr(e, "env"):
            return None
        if "step" in vars(e) or "reset" in vars(e):  # a step patched on the instance
            return None
        e = e.env
    if "step" in vars(e) or "reset" in vars(e):
        return None
    if e.render_mode is not None:
        return None
    return e


def plain_vector_env(venv):
    """The ContouringVectorEnv ``venv`` if it is one (no wrapper); else None."""
    from .vector_env import ContouringVectorEnv

    return venv if type(venv) is ContouringVectorEnv else None


def compiled_form_of(policy):
    """The policy's compiled form (None: it has none, e.g. a learning controller or an
    agent)."""
    make = getattr(policy, "compiled_form", None)
    return make() if callable(make) else None


def episode_record(core, rec: dict, n: int, reason) -> EpisodeRecord:
    """The :class:`EpisodeRecord` of the first ``n`` recorded steps of env 0 of ``core``."""
    sl = slice(0, n)
    force = rec["force"][sl]
    limit = core.setup.plant.params.force_limit_N
    # rapid (G00) steps: the flag of the reference index each recorded step ended at
    step_is_rapid = getattr(core.setup, "step_is_rapid", None)
    rapid = None
    if step_is_rapid is not None:
        rapid = step_is_rapid[np.minimum(np.arange(1, n + 1), core.n_steps - 1)].copy()
    return EpisodeRecord(
        time=rec["time"][sl],
        contour_error=rec["contour_error"][sl],
        tracking_error=rec["tracking_error"][sl],
        force=force,
        saturated=np.abs(force) >= limit * (1 - 1e-12),
        position=rec["position"][sl],
        reference=rec["reference"][sl],
        force_limit=limit.copy(),
        termination_reason=reason,
        n_steps_planned=core.n_steps - 1,
        encoder_resolution_m=np.array(core.setup.plant.params.encoder_resolution_m, dtype=float),
        rapid=rapid,
    )


def empty_record(core) -> dict:
    n_max = core.n_steps - 1
    d = core.dim
    return {
        "time": np.empty(n_max),
        "contour_error": np.empty(n_max),
        "tracking_error": np.empty((n_max, d)),
        "force": np.empty((n_max, d)),
        "position": np.empty((n_max, d)),
        "reference": np.empty((n_max, d)),
    }


def is_five_axis_env(env) -> bool:
    """Whether ``env`` (single, wrapped or vectorised) simulates the five-axis machine."""
    core = getattr(env, "core", None) or getattr(getattr(env, "unwrapped", None), "core", None)
    return getattr(getattr(core, "setup", None), "family", None) == "five-axis"


class AxisRecorder:
    """What :func:`contour_env.evaluation.run_episode` records per step of env 0 of a
    feed-drive core (time, true contour error, position, reference, tracking error, applied
    force), and the :class:`EpisodeRecord` it makes of them."""

    def __init__(self, core):
        self.core = core
        self.rec = empty_record(core)

    def record(self, i: int, info: dict) -> None:
        core, rec, d = self.core, self.rec, self.core.dim
        kk = min(int(core.k[0]), core.n_steps - 1)
        rec["time"][i] = core.k[0] * core.T
        rec["contour_error"][i] = core.eps[0]
        pos = core.positions[0]
        ref = core.ref_pav[kk, 0, :d]
        rec["position"][i] = pos
        rec["reference"][i] = ref
        rec["tracking_error"][i] = ref - pos
        rec["force"][i] = core.applied_force[0]

    def finish(self, n: int, reason) -> EpisodeRecord:
        return episode_record(self.core, self.rec, n, reason)


class FiveAxisRecorder(AxisRecorder):
    """The five-axis machine's record: the feed-drive record's fields from the step's ``info``
    plus the orientation error θ (rad) per step; ``tracking_error`` (n, 3) is the tool-tip
    tracking error p_d − p (m, workpiece frame), the quantity of the env's tracking guard, so
    that ``completed`` applies the follow limit to the tool tip (joint errors mix m and rad).
    """

    def __init__(self, core):
        super().__init__(core)
        n_max = core.n_steps - 1
        self.rec["tracking_error"] = np.empty((n_max, 3))
        self.theta = np.empty(n_max)

    def record(self, i: int, info: dict) -> None:
        rec = self.rec
        rec["time"][i] = info["time"]
        rec["contour_error"][i] = info["contour_error"]
        rec["position"][i] = info["position"]
        rec["reference"][i] = info["reference"]
        rec["tracking_error"][i] = info["reference_tool_tip"] - info["tool_tip"]
        rec["force"][i] = info["force"]
        self.theta[i] = info["orientation_error"]

    def finish(self, n: int, reason) -> EpisodeRecord:
        # the tool tip's resolution is the linear scales' count: the rotary counts are angles
        # (rad), not comparable with a contour error in m
        params = self.core.setup.plant.params
        linear_counts = np.asarray(params.encoder_resolution_m, dtype=float)[:3]
        return replace(
            super().finish(n, reason),
            orientation_error=self.theta[:n].copy(),
            encoder_resolution_m=linear_counts,
        )


def recorder_for(core) -> AxisRecorder:
    """The episode recorder of ``core``'s plant family."""
    if getattr(core.setup, "family", None) == "five-axis":
        return FiveAxisRecorder(core)
    return AxisRecorder(core)


def _bad_action(core) -> ValueError:
    return ValueError(
        f"action: must be finite, got {core.action[0].tolist()} (env 0); the action is "
        "the per-axis command in [-1, 1] of the force limit"
    )


def prepare_compiled_episode(env, policy, seed: int):
    """``(core, form)`` with ``env`` reset to ``seed`` and ``policy`` bound and reset as the
    first ``predict`` of :func:`contour_env.evaluation.run_episode` would, when the episode
    can run compiled; None (nothing done) when ``env`` or ``policy`` does not qualify."""
    if policy is None or not callable(getattr(policy, "compiled_form", None)):
        return None
    base = plain_env(env)
    if base is None:
        return None
    if getattr(policy, "_env", None) is None:
        policy.bind(env)
    if getattr(policy, "_core", None) is not base.core or policy.n_envs != 1:
        return None
    env.reset(seed=seed)
    # as the first predict does (episode_start)
    policy.reset(np.ones(1, dtype=bool))
    form = compiled_form_of(policy)
    if form is None:
        return None
    return base.core, form


def finish_compiled_episode(core, rec: dict, n: int, bad: bool) -> EpisodeRecord:
    """The record of a compiled episode of env 0 of ``core`` that recorded ``n`` steps in
    ``rec`` (:func:`empty_record`); ``bad``: the controller's action was not finite (a
    ``ValueError``, as on the Python path)."""
    if bad:
        raise _bad_action(core)
    np.subtract(rec["reference"][:n], rec["position"][:n], out=rec["tracking_error"][:n])
    status = int(core.status[0])
    from .core import TERMINATION_REASONS

    reason = TERMINATION_REASONS.get(status) if n > 0 else None
    return episode_record(core, rec, n, reason)


def try_compiled_episode(env, policy, seed: int) -> EpisodeRecord | None:
    """Run the episode of ``run_episode(env, policy, seed=seed)`` compiled, or return None
    (nothing done) when ``env`` or ``policy`` does not qualify."""
    ready = prepare_compiled_episode(env, policy, seed)
    if ready is None:
        return None
    core, form = ready
    rec = empty_record(core)
    n, bad = form.run_single(
        core, rec["time"], rec["contour_error"], rec["position"], rec["reference"], rec["force"]
    )
    return finish_compiled_episode(core, rec, n, bad)
