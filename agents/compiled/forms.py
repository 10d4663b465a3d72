"""Gains and state of the classical controllers and rfnn / fnn as the arrays of
:mod:`agents.compiled.laws`.

:func:`compiled_form` packs a bound controller (exact classes only: a subclass may change the
law) into a :class:`CompiledForm`; :meth:`CompiledForm.store` writes the state the compiled run
advanced back into the controller's own attributes, so that after a run the object is in the
state the Python path would have left it in.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from contour_env.env.layout import EpisodeTrace

from . import laws as L


@dataclass
class CompiledForm:
    kind: int
    fp: np.ndarray  # gains (float64)
    st: np.ndarray  # state, one row per env (float64, flags 0/1)
    force_limit: np.ndarray  # the controller's (nominal) force limit, per axis
    controller: object

    def store(self) -> None:
        """Write ``st`` back into the controller's attributes."""
        _STORE[self.kind](self.controller, self.st)

    def _core_args(self, core) -> tuple:
        """The law and the env's arrays, as the compiled loops take them (:mod:`.runner`)."""
        state, path, plant = core.kernel_records()
        law = L.CompiledLaw(self.kind, self.fp, self.st, self.force_limit)
        return (
            law, core.cfg, core.icfg, state, path, plant, core.scal, core.action,
            core.step_outputs(), core.no_info,
        )  # fmt: skip

    def run_single(self, core, rec_time, rec_eps, rec_pos, rec_ref, rec_force) -> tuple:
        """Env 0 of ``core`` to the end of its episode (:func:`runner.run_single`); the state
        is written back into the controller. Returns (steps recorded, bad action flag)."""
        from .runner import run_single

        trace = EpisodeTrace(rec_time, rec_eps, rec_pos, rec_ref, rec_force)
        n, bad = run_single(*self._core_args(core), trace)
        self.store()
        return int(n), bool(bad)

    def run_batch(self, core, sq, peak, count, failed, bad, trace, steps) -> None:
        """Every env of ``core`` to the end of its episode (:func:`runner.run_batch`)."""
        from .runner import run_batch

        run_batch(*self._core_args(core), sq, peak, count, failed, bad, trace, steps)
        self.store()


def _f(*parts) -> np.ndarray:
    return np.concatenate([np.atleast_1d(np.asarray(p, dtype=np.float64)) for p in parts])


def _pd_fp(c) -> np.ndarray:
    return _f(c.P, c.D)


def _ccc_fp(c) -> np.ndarray:
    limit = float(np.min(c.force_limit / c.mass)) / max(c.W_i, 1e-300)
    return _f(c.P, c.D, c.W_p, c.W_i, c.W_d, c.mass, limit, np.cos(c.CORNER_TURN_RAD))


def _ccc_st(c) -> np.ndarray:
    return np.concatenate(
        [
            c._prev,
            c._integral,
            c._started[:, None].astype(np.float64),
            c._tangent,
            c._corner,
            c._bisector,
            c._holding[:, None].astype(np.float64),
        ],
        axis=1,
    )


def _ccc_store(c, st) -> None:
    A = c.n_axes
    c._prev[:] = st[:, 0:2]
    c._integral[:] = st[:, 2 : 2 + A]
    c._started[:] = st[:, 2 + A] != 0.0
    c._tangent[:] = st[:, 3 + A : 3 + 2 * A]
    c._corner[:] = st[:, 3 + 2 * A : 3 + 3 * A]
    c._bisector[:] = st[:, 3 + 3 * A : 3 + 4 * A]
    c._holding[:] = st[:, 3 + 4 * A] != 0.0


def _adaptive_fp(c) -> np.ndarray:
    return _f(
        c.k,
        c.alpha,
        c.coupling,
        c.kv_rho,
        float(np.any(c.kv_rho)),
        c.n_columns,
        float(c.friction),
        float(c.normalize),
        float(c.velocity_match),
        float(np.any(c.Gamma)),
        np.asarray(c.mean_squares, dtype=np.float64),
        c.Gamma,
    )


def _adaptive_store(c, st) -> None:
    c.theta_hat[:] = st


def _jee_st(c) -> np.ndarray:
    return np.concatenate([c._sum, c._prev, c._started[:, None].astype(np.float64)], axis=1)


def _jee_store(c, st) -> None:
    A = c.n_axes
    c._sum[:] = st[:, :A]
    c._prev[:] = st[:, A : 2 * A]
    c._started[:] = st[:, 2 * A] != 0.0


def _rfnn_fp(c) -> np.ndarray:
    return _f(
        c.P,
        c.D,
        c.alpha,
        c.inv_input_scale,
        c.INPUT_LIMIT,
        c.THETA_LIMIT,
        c.w_max,
        c.k_w,
        c.k_theta,
        float(c.online_update),
        float(c.recurrent),
        c.n_rules,
        float(c.online_update and c.recurrent and c.k_theta > 0.0),  # θ learns
        c.centres.reshape(-1),
        c.inv_sigma2.reshape(-1),
        c.lr_w,
        c.lr_theta / (c.w_max * c.w_max),
        float(c.eq23_instant),
        c.EQ23_INSTANT_CAP,
        0.5 * c.spread_max_N,  # inf: no spread bound
    )


def _rfnn_st(c) -> np.ndarray:
    B, R = c.n_envs, c.n_rules
    scratch = np.zeros((B, 3 * R + c.n_axes))  # 2 (u − m) O(k−1) / σ², ψ, y of the sample
    peak = np.full((B, 1), c.eq23_peak)  # the largest per-sample eq. 23 value (NaN: none)
    return np.concatenate(
        [c.w.reshape(B, -1), c.theta.reshape(B, -1), c.memory.reshape(B, -1), scratch, peak],
        axis=1,
    )


def _rfnn_store(c, st) -> None:
    B, A, R = c.n_envs, c.n_axes, c.n_rules
    c.w[:] = st[:, : A * R].reshape(B, A, R)
    c.theta[:] = st[:, A * R : 3 * A * R].reshape(B, A, 2, R)
    c.memory[:] = st[:, 3 * A * R : 5 * A * R].reshape(B, A, 2, R)
    c.eq23_peak = float(np.fmax.reduce(st[:, -1]))  # NaN only if no env has learnt yet


_STORE = {
    L.KIND_PD: lambda c, st: None,
    L.KIND_CCC: _ccc_store,
    L.KIND_ADAPTIVE_CCC: _adaptive_store,
    L.KIND_JEE_CCC: _jee_store,
    L.KIND_RFNN: _rfnn_store,
}


_PATCHABLE = ("act", "command", "action", "predict", "reset", "configure")


def compiled_form(controller) -> CompiledForm | None:
    """The compiled form of a bound ``pd``, ``ccc``, ``adaptive-ccc``, ``jee-ccc``, ``rfnn`` or
    ``fnn``, or None for any other policy. A class names its compiled law in its own
    ``COMPILED_LAW`` (``"pd"``, ``"ccc"``, ...): a subclass that does not name one again is not
    compiled (its law may differ)."""
    law = type(controller).__dict__.get("COMPILED_LAW")
    if law is None or getattr(controller, "_core", None) is None:
        return None
    # a law patched on the instance (e.g. a traced ``act``) is not the compiled one
    if any(name in vars(controller) for name in _PATCHABLE):
        return None
    kind, fp, st = _pack(controller, law)
    return CompiledForm(
        kind,
        np.ascontiguousarray(fp),
        np.ascontiguousarray(st, dtype=np.float64),
        np.asarray(controller.force_limit, dtype=np.float64).copy(),
        controller,
    )


def _pack(controller, law: str) -> tuple:
    """(kind, gains fp, state st) of ``controller`` for the compiled law named ``law``."""
    B = controller.n_envs
    if law == "pd":
        kind, fp, st = L.KIND_PD, _pd_fp(controller), np.zeros((B, 1))
    elif law == "ccc":
        kind, fp, st = L.KIND_CCC, _ccc_fp(controller), _ccc_st(controller)
    elif law == "adaptive-ccc":
        kind, fp = L.KIND_ADAPTIVE_CCC, _adaptive_fp(controller)
        st = np.array(controller.theta_hat, dtype=np.float64)
    elif law == "jee-ccc":
        kind, fp, st = (
            L.KIND_JEE_CCC,
            _f(controller.K_P, controller.C_P, controller.C_I, controller.C_D),
            _jee_st(controller),
        )
    elif law == "rfnn":
        kind, fp, st = L.KIND_RFNN, _rfnn_fp(controller), _rfnn_st(controller)
    else:
        raise ValueError(f"COMPILED_LAW {law!r}: no compiled law of that name")
    return kind, fp, st


# what each law reads of the servo signals (besides the measured and reference position and
# velocity, which every law reads)
_VELOCITIES = ("measured_velocity", "reference_velocity")
_NEEDS = {
    L.KIND_PD: _VELOCITIES,
    L.KIND_CCC: (*_VELOCITIES, "frame", "curvature"),
    L.KIND_ADAPTIVE_CCC: (
        *_VELOCITIES,
        "frame",
        "curvature",
        "torsion",
        "feedrate",
        "reference_acceleration",
    ),
    L.KIND_JEE_CCC: ("frame",),  # eqs. 11-12: positions only
    L.KIND_RFNN: (*_VELOCITIES, "frame"),
}
_ALWAYS = ("measured_position", "reference_position")


def signal_tables(signals: dict, n_axes: int, needs=()) -> tuple:
    """Batched servo signals (leading axis B) as the tables :func:`.laws.act_rows` reads, row b
    for env b: ``ax`` (AX_VEL + 1, B, A) with the measured position (m) and velocity (m/s) in
    rows AX_MEAS and AX_VEL; ``ref_pav`` (B, 3, W); ``frame`` (B, W, W) with W = max(A, 3);
    ``scal`` (B, 4).
    Signals the law does not read may be missing (zeros); a missing one it reads is a
    ``ValueError`` naming it."""
    missing = [key for key in (*_ALWAYS, *needs) if key not in signals]
    if missing:
        raise ValueError(f"signals: missing {', '.join(missing)} (see EnvCore.signals_batch)")
    A = n_axes
    meas = np.asarray(signals["measured_position"], dtype=np.float64)
    B = meas.shape[0]
    W = max(A, 3)  # the laws read 3 columns of a 2-axis frame; a view of 5 joints reads 5
    ax = np.zeros((L.AX_VEL + 1, B, A))
    ax[L.AX_MEAS] = meas
    ref_pav = np.zeros((B, 3, W))
    ref_pav[:, 0, :A] = signals["reference_position"]
    if "measured_velocity" in signals:
        ax[L.AX_VEL] = signals["measured_velocity"]
    if "reference_velocity" in signals:
        ref_pav[:, 1, :A] = signals["reference_velocity"]
    frame = np.zeros((B, W, W))
    scal = np.zeros((B, 4))
    if "reference_acceleration" in signals:
        ref_pav[:, 2, :A] = signals["reference_acceleration"]
    if "frame" in signals:
        frame[:, :A, :A] = signals["frame"]
    for col, key in ((0, "feedrate"), (2, "curvature"), (3, "torsion")):
        if key in signals:
            scal[:, col] = signals[key]
    return ax, ref_pav, frame, scal


def run_law(controller, law: str, signals: dict) -> np.ndarray:
    """The command u (B, A) (plant units) of the compiled law ``law`` (``"pd"``, ``"ccc"``,
    ``"adaptive-ccc"``, ``"jee-ccc"``, ``"rfnn"``) with ``controller``'s gains and state, for
    batched ``signals`` (B ≤ the bound batch): the Python ``act`` of those controllers. The law is
    :func:`.laws.law`, the one the fused loops run; the state it advanced is written back into
    the controller's attributes."""
    kind, fp, st = _pack(controller, law)
    st = np.ascontiguousarray(st, dtype=np.float64)
    ax, ref_pav, frame, scal = signal_tables(signals, controller.n_axes, _NEEDS[kind])
    u = np.empty((ax.shape[1], controller.n_axes))
    L.act_rows(
        kind, float(controller.servo_period_s), ax, ref_pav, frame, scal,
        np.ascontiguousarray(fp), st, u,
    )  # fmt: skip
    _STORE[kind](controller, st)
    return u
