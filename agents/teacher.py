"""The teacher of a residual agent: iterative learning control run on top of the agent's base,
in the agent's own action space, on one part at a time (issue 48).

ILC converged on a part knows the correction the base needs there (``contour-env ilc``: on
``lm-circle3d`` ``ilc-contour`` takes the RMS contour error from 13.8 to 0.11 µm). A residual
agent can learn that correction as a function of what it sees, if the correction is written
the way the agent acts. So the teacher learns, trial after trial on one part, a table of
**agent actions** — one row per agent step (``action_repeat`` servo periods), the push p in
the agent's frame and the gate — and every trial runs the residual law of the agent itself
(:func:`agents.compiled.residual_runner.run_residual_table`: the base's compiled law, the
frame rotation and axis weights, the axis mask, the fade at rest, the bound ‖p‖ ≤ 1; the
same arithmetic as :class:`agents.residual.ResidualAgent`, period for period). What the
teacher learns is therefore exactly what a student can reproduce: the converged table
replayed through :class:`agents.residual.ResidualWrapper` gives the teacher's trial to the bit
(tested), and its observations, actions and rewards are the student's training data
(:mod:`agents.rl.teacher_data`).

The learning law (``ilc-contour``'s, :class:`agents.ilc.ILCContourController`, in the
agent's units). From trial j's true errors e = x_d − x (m, per servo period, the position
after the step), in the task frame e_l = Fᵀ e:

    δu(t) = M F Γ (ω_L² e_l + 2 ζ_L ω_L ė_l)(t + λ) + B F Γ ω_L e_l(t + λ)     (N, per axis)

(M, B the nominal masses and viscous coefficients; the second term is negligible on the
force-driven plants and the velocity term of the velocity-command drive of ``jee-triaxial``,
whose common-form "mass" and "viscous" are τ/K and 1/K), Γ = diag(γ_t, γ_n, γ_b), ω_L the
plant's PD bandwidth (the feedback's, as ilc-contour), λ = the computation delay in samples
of the recorded (after-step) error — ilc-contour's 1 + delay on the error measured before the
step. In the agent's units, per servo period:

    δp(t) = Fᵀ (δu(t) ⊘ (F_max · scale · w))      (path frame; the axes frame: δu ⊘ (F_max · scale))

averaged over each agent step's periods, and the table is

    P_{j+1} = Π[ Q( P_j + δP_j ) ],

Q the zero-phase Butterworth low-pass at the plant's ILC cutoff (:data:`agents.ilc.
DEFAULT_Q_CUTOFF_HZ`), Π the agent's bound (‖p‖ ≤ 1 in the path frame, |p_i| ≤ 1 on the
axes) and zero where the agent's residual is faded out (the reference at rest): a correction
the agent cannot apply is not learned. The gate column is 1 (fully open) wherever p ≠ 0.

Non-repeating disturbances: the generated training parts run the friction table's periodic
disturbance at a random phase. The teacher draws a new episode seed for every trial
(``vary_seed``), so it learns the correction that the part needs whatever the phase — what an
agent that cannot see the phase can learn — instead of cancelling one phase's disturbance.

The table kept is the trial with the lowest J = RMS / RMS_base + max / max_base over the
trials (the base is trial 0, an all-zero table): a part is judged on its max as well as its
RMS. Learning stops after ``max_trials`` or when J has not improved by 1 % in ``patience``
trials.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import gymnasium as gym
import numpy as np

from contour_env import ENV_ID
from contour_env.env.layout import EpisodeTrace
from contour_env.env.rollout import empty_record

from .ilc import DEFAULT_Q_CUTOFF_HZ, FALLBACK_Q_CUTOFF_HZ, shift_ahead
from .model_files import TEACHER_NAMES
from .pd import default_bandwidth
from .qfilter import ZeroPhaseLowPass

TEACHERS = TEACHER_NAMES  # agents.model_files: what agent.json may say
# learning gains per task-frame direction (tangential, normal, binormal): a third of
# ilc-contour's (0.3, 0.8, 0.8). On top of CCC, whose integral coupling and corner logic make
# the loop the learning acts on stiffer and switching, ilc-contour's gains diverged on generated
# friction-table parts (RMS 22 -> 29 um by trial 6, where they converge on PD: 69 -> 1.4 um);
# a third converges on every plant's training families (out/ notes in the closing note)
DEFAULT_GAINS = (0.1, 0.3, 0.3)
DEFAULT_MAX_TRIALS = 30
DEFAULT_PATIENCE = 8
# a trial improves on the best when its J is lower by this fraction
IMPROVEMENT = 0.01


def check_teacher(teacher) -> str:
    if teacher not in TEACHERS:
        raise ValueError(f"teacher: must be one of {', '.join(TEACHERS)}, got {teacher!r}")
    return teacher


@dataclass
class Lesson:
    """What the teacher learned on one part.

    actions (M, n_act): the agent actions of the kept trial, one row per agent step (push p in
    the agent's frame, then the gate when the agent has one). seeds: the episode seed of each
    trial. history: per trial (RMS µm, max µm) of the true contour error, trial 0 the base.
    kept: the index of the kept trial (0: the teacher found nothing better than the base).
    completed: False when the base itself did not finish the part (no lesson then)."""

    actions: np.ndarray
    history: list = field(default_factory=list)
    kept: int = 0
    seeds: list = field(default_factory=list)
    completed: bool = True
    # the largest |Fᵀ(x_d − x)| per task-frame direction (m) of the base's trial and of the
    # kept one: what the agent's envelope takes as the errors it was trained on
    error_max_m: np.ndarray | None = None
    # (table, seed) of the trials whose states the student's data covers: the base's (trial 0),
    # one half-way to the kept trial and the kept one (module docstring of
    # agents.rl.teacher_data)
    coverage: list = field(default_factory=list)

    @property
    def base_rms_um(self) -> float:
        return self.history[0][0]

    @property
    def base_max_um(self) -> float:
        return self.history[0][1]

    @property
    def rms_um(self) -> float:
        return self.history[self.kept][0]

    @property
    def max_um(self) -> float:
        return self.history[self.kept][1]

    @property
    def trials(self) -> int:
        return len(self.history)

    def summary(self) -> dict:
        return {
            "base_rms_um": self.base_rms_um,
            "base_max_um": self.base_max_um,
            "rms_um": self.rms_um,
            "max_um": self.max_um,
            "trials": self.trials,
            "kept_trial": self.kept,
        }


class ResidualTeacher:
    """ILC in a residual agent's action space on top of its base (see the module docstring).

    Parameters
    ----------
    base : str — the base controller (a registry name).
    law : dict — the residual law's keywords (:meth:`agents.rl.config.TrainConfig.
        wrapper_kwargs` without ``base``: scale, frame, gate, axis mask, fade, action repeat).
    gains : (γ_t, γ_n, γ_b) — learning gains per task-frame direction (default 0.1, 0.3, 0.3:
        see :data:`DEFAULT_GAINS`).
    max_trials : int — trials after the base's (default 30).
    patience : int — stop after this many trials without a 1 % better J (default 8).
    vary_seed : bool — a new episode seed per trial (default True; see the module doc).
    q_cutoff_hz : float — the Q-filter cutoff (default the plant's ILC cutoff).
    """

    def __init__(
        self,
        base: str,
        law: dict,
        *,
        gains=DEFAULT_GAINS,
        max_trials: int = DEFAULT_MAX_TRIALS,
        patience: int = DEFAULT_PATIENCE,
        vary_seed: bool = True,
        q_cutoff_hz: float | None = None,
    ):
        if isinstance(max_trials, bool) or not isinstance(max_trials, int) or max_trials < 1:
            raise ValueError(f"max_trials: must be an integer >= 1, got {max_trials!r}")
        if isinstance(patience, bool) or not isinstance(patience, int) or patience < 1:
            raise ValueError(f"patience: must be an integer >= 1, got {patience!r}")
        g = np.asarray(gains, dtype=np.float64)
        if g.shape != (3,) or not np.all(np.isfinite(g)) or np.any(g <= 0) or np.any(g > 2):
            raise ValueError(f"gains: three learning gains in (0, 2], got {gains!r}")
        self.base = base
        self.law = {k: v for k, v in dict(law).items() if k != "base"}
        self.gains = g
        self.max_trials = max_trials
        self.patience = patience
        self.vary_seed = bool(vary_seed)
        self.q_cutoff_hz = q_cutoff_hz

    # --- one part ---------------------------------------------------------------------------
    def wrapper(self, env_kwargs: dict):
        """The residual wrapper of the agent's law on a fresh env of the part."""
        from .residual import ResidualWrapper

        env = gym.make(ENV_ID, **env_kwargs)
        return ResidualWrapper(env, self.base, **self.law)

    def teach(self, env_kwargs: dict, seed: int = 0) -> Lesson:
        """Learn the table of one part (``env_kwargs`` as ``gym.make`` takes them; ``seed``
        the episode seed of the first trial)."""
        w = self.wrapper(env_kwargs)
        run = _TrialRunner(w)
        learner = _Learner(w, self.gains, self.q_cutoff_hz)
        M = run.n_decisions
        table = np.zeros((M, w.n_actions))
        seeds = [seed + j if self.vary_seed else seed for j in range(self.max_trials + 1)]
        history, tables, err = [], [], []
        best_j, best_J, since = 0, math.inf, 0
        for j in range(self.max_trials + 1):
            trial = run(table, seeds[j])
            if trial is None:  # the trial did not finish the part
                if j == 0:
                    return Lesson(np.zeros((M, w.n_actions)), [(math.inf, math.inf)], 0, seeds[:1],
                                  completed=False)  # fmt: skip
                history.append((math.inf, math.inf))
                tables.append(table)
                break
            rms, mx = trial["rms_um"], trial["max_um"]
            history.append((rms, mx))
            err.append(trial["error_max_m"])
            tables.append(table)
            J = rms / max(history[0][0], 1e-12) + mx / max(history[0][1], 1e-12)
            if J < best_J * (1.0 - IMPROVEMENT) or j == 0:
                best_j, best_J, since = j, J, 0
            else:
                since += 1
                if since >= self.patience:
                    break
            if j < self.max_trials:
                table = learner.update(table, trial)
        picks = sorted({0, best_j // 2, best_j})
        return Lesson(
            tables[best_j], history, best_j, seeds[: len(history)],
            error_max_m=np.maximum(err[0], err[best_j]),
            coverage=[(tables[j], seeds[j]) for j in picks],
        )  # fmt: skip


class _TrialRunner:
    """One trial of a part with a table of agent actions, compiled."""

    def __init__(self, w):
        self.w = w
        self.core = w.core
        core = self.core
        k = w.action_repeat
        self.n_max = core.n_steps - 1
        self.n_decisions = -(-self.n_max // k)

    def __call__(self, table: np.ndarray, seed: int):
        from .compiled import compiled_form
        from .compiled.residual_runner import run_residual_table

        w, core = self.w, self.core
        w.env.reset(seed=seed)
        w.base.reset(np.ones(1, dtype=bool))
        form = compiled_form(w.base)
        if form is None:
            raise ValueError(
                f"base: {w.base.name!r} has no compiled form; the teacher runs pd, ccc, "
                "adaptive-ccc, jee-ccc, rfnn or fnn"
            )
        rec = empty_record(core)
        trace = EpisodeTrace(
            rec["time"], rec["contour_error"], rec["position"], rec["reference"], rec["force"]
        )
        weights = w._weights if w._weights is not None else np.ones(core.dim)
        n, bad = run_residual_table(
            *form._core_args(core), trace, np.ascontiguousarray(table, dtype=np.float64),
            w.scale, np.ascontiguousarray(w._axis_mask(), dtype=np.float64),
            np.ascontiguousarray(weights, dtype=np.float64), w.residual_frame == "path",
            w.gate, w._v_rest, w.action_repeat,
        )  # fmt: skip
        form.store()
        if bad or n < self.n_max or bool(core.terminated[0]):
            return None
        eps = rec["contour_error"][:n]
        if not np.all(np.isfinite(eps)):
            return None
        pos, ref = rec["position"][:n], rec["reference"][:n]
        A = core.dim
        kk = np.minimum(np.arange(1, n + 1), core.n_steps - 1)
        e_l = np.einsum("nij,ni->nj", core.frame[kk, :A, :A], ref - pos)
        return {
            "rms_um": float(np.sqrt(np.mean(eps * eps))) * 1e6,
            "max_um": float(np.max(eps)) * 1e6,
            "position": pos,
            "reference": ref,
            "error_max_m": np.abs(e_l).max(axis=0),
        }


class _Learner:
    """The table update P ← Π[Q(P + δP)] of one part (module docstring)."""

    def __init__(self, w, gains, q_cutoff_hz):
        core = w.core
        self.w = w
        nominal = core.setup.plant.nominal
        A = core.dim
        self.A = A
        self.T = float(core.T)
        self.k = int(w.action_repeat)
        self.n_max = core.n_steps - 1
        self.M = -(-self.n_max // self.k)
        self.gains = np.asarray(gains[:A], dtype=np.float64)
        self.mass = np.asarray(nominal.mass_kg, dtype=np.float64)
        self.viscous = np.asarray(nominal.viscous_Ns_m, dtype=np.float64)
        self.omega = default_bandwidth(nominal)[0]
        self.zeta = 1.0
        self.lead = int(core.setup.plant.params.computation_delay)
        fc = q_cutoff_hz or DEFAULT_Q_CUTOFF_HZ.get(nominal.name, FALLBACK_Q_CUTOFF_HZ)
        self.q = ZeroPhaseLowPass(fc, self.T * self.k)
        flim = np.asarray(nominal.force_limit_N, dtype=np.float64)
        weights = w._weights if w._weights is not None else np.ones(A)
        self.unit = flim * w.scale * weights  # force (N) of a unit push per axis
        self.mask = np.asarray(w._axis_mask(), dtype=np.float64)
        self.path_frame = w.residual_frame == "path"
        # the frame of the residual at decision step n (before the step: kk = n) and of the
        # recorded error at row t (after the step: kk = t + 1)
        kk = np.minimum(np.arange(self.n_max + 1), core.n_steps - 1)
        self.frame_all = np.asarray(core.frame[kk, :A, :A], dtype=np.float64)
        self.fade = self._fade(core, w)

    def _fade(self, core, w) -> np.ndarray:
        """(M,) 1 where the agent's residual acts in the agent step (any period of it with the
        fade > 0), 0 where the reference stands still throughout."""
        feed = np.asarray(core.scal[: self.n_max, 0], dtype=np.float64)
        moving = feed > 0 if w._v_rest > 0 else np.ones(self.n_max, dtype=bool)
        pad = self.M * self.k - self.n_max
        moving = np.concatenate([moving, np.zeros(pad, dtype=bool)])
        return moving.reshape(self.M, self.k).any(axis=1).astype(np.float64)

    def update(self, table: np.ndarray, trial: dict) -> np.ndarray:
        A, T = self.A, self.T
        e = trial["reference"] - trial["position"]  # (N, A) true error after each step
        n = e.shape[0]
        F_err = self.frame_all[1 : n + 1]
        e_l = np.einsum("nij,ni->nj", F_err, e)
        de = np.gradient(e_l, T, axis=0) if n > 1 else np.zeros_like(e_l)
        w, z = self.omega, self.zeta
        acc = self.gains * (w * w * e_l + 2.0 * z * w * de)
        vel = self.gains * (w * e_l)
        du = self.mass * np.einsum("nij,nj->ni", F_err, acc) + self.viscous * np.einsum(
            "nij,nj->ni", F_err, vel
        )
        du = shift_ahead(du[None], self.lead)[0] * self.mask
        scaled = du / self.unit
        if self.path_frame:
            dp = np.einsum("nij,ni->nj", self.frame_all[:n], scaled)
        else:
            dp = scaled
        # mean over each agent step's periods
        pad = self.M * self.k - n
        if pad:
            dp = np.concatenate([dp, np.repeat(dp[-1:], pad, axis=0)])
        dP = dp.reshape(self.M, self.k, A).mean(axis=1)
        P = table[:, :A] + dP
        P = self.q(P, axis=0) * self.fade[:, None]
        P = _bound(P, self.path_frame)
        out = np.zeros_like(table)
        out[:, :A] = P
        if table.shape[1] > A:  # the gate: open where the teacher pushes
            out[:, A] = self.fade
        return out


def _bound(P: np.ndarray, path_frame: bool) -> np.ndarray:
    """Π: ‖p‖ ≤ 1 per row (path frame), |p_i| ≤ 1 (axes frame)."""
    if path_frame:
        norm = np.sqrt(np.sum(P * P, axis=1, keepdims=True))
        return P / np.maximum(norm, 1.0)
    return np.clip(P, -1.0, 1.0)


__all__ = ["TEACHERS", "Lesson", "ResidualTeacher", "check_teacher"]
