"""The compiled servo loop of a residual agent between two of its decisions: per servo period
the base controller's law (:func:`agents.compiled.laws.law`), its env action, the residual of
the held agent action (:func:`agents.residual_law.residual_command`, the same arithmetic term
by term) and the kernel's step — so that an agent deciding every k periods costs one Python
call (its network) per k periods instead of a Python controller, an env step and an info
dict per period.

:class:`agents.residual.ResidualAgent` uses it through ``compiled_form()``:
``contour_env.evaluation.run_episode`` takes this path for an agent whose base has a compiled
form, with the same record as the Python path, to the bit.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from contour_env.env.borrow import borrowed
from contour_env.env.kernel import I_NSTEPS, record_step, step_one
from contour_env.env.layout import EpisodeTrace

from .laws import law
from .runner import WORK_SIZE, _action, borrowed_inputs


@njit(cache=True)
def run_residual_chunk(
    law_arrays, cfg, icfg, state, path, plant, scal, action, out, info, trace, a, scale, mask,
    weights, path_frame, gate, v_rest, n0, n_periods,
):  # fmt: skip
    """Env 0 for up to ``n_periods`` servo periods from recorded step ``n0`` with the agent's
    action ``a`` held. Returns (n, bad, ended): steps recorded so far, 1 when the base's
    action was not finite (nothing stepped then), 1 when the episode ended. The arrays as
    :func:`agents.compiled.runner.run_single` takes them."""
    B = borrowed
    return _run_residual_chunk(
        *borrowed_inputs(law_arrays, cfg, icfg, state, path, plant, scal, action, out, info, trace),
        B(a), scale, B(mask), B(weights), path_frame, gate, v_rest, n0, n_periods, np.zeros(3),
    )  # fmt: skip


@njit(cache=True)
def _run_residual_chunk(
    law_arrays, cfg, icfg, state, path, plant, scal, action, out, info, trace, a, scale, mask,
    weights, path_frame, gate, v_rest, n0, n_periods, sums,
):  # fmt: skip
    """The chunk; ``sums`` (3,) accumulates the env's reward, Σ_i (r_i / scale)² of the
    applied residual and the periods stepped (what :class:`agents.residual.ResidualWrapper`
    sums for a step's reward)."""
    kind, fp, st, flim = law_arrays
    z, ax, k = state.z, state.ax, state.k
    ref_pav, frame = path.ref_pav, path.frame
    A = z.shape[1]
    n_steps = icfg[I_NSTEPS]
    n_max = n_steps - 1
    T = cfg[0]
    z2 = z.reshape((z.shape[0] * z.shape[1], z.shape[2]))
    u = np.zeros(A)
    work = np.zeros(WORK_SIZE)
    push = np.zeros(A)
    r = np.zeros(A)
    b = 0
    # the agent's push (norm-limited in the path frame) and gate: fixed over the chunk
    if path_frame:
        sq = 0.0
        for j in range(A):
            sq += a[j] * a[j]
        norm = math.sqrt(sq)
        div = norm if norm > 1.0 else 1.0
        for j in range(A):
            push[j] = a[j] / div
    else:
        for j in range(A):
            push[j] = a[j]
    g = 1.0
    if gate:
        g = a[A]
        if g < 0.0:
            g = 0.0
        elif g > 1.0:
            g = 1.0
    n = n0
    for _ in range(n_periods):
        if n >= n_max:
            return n, 0, 1
        kk = min(k[b], n_steps - 1)
        law(kind, A, b, kk, T, ax, ref_pav, frame, scal, fp, st, u, work)
        if not _action(A, b, u, flim, action):
            return n, 1, 0
        # residual_command, term by term
        if path_frame:
            for i in range(A):
                acc = 0.0
                for j in range(A):
                    acc = acc + frame[kk, i, j] * push[j]
                r[i] = scale * (acc * weights[i])
        else:
            for i in range(A):
                r[i] = scale * push[i]
        fade = 1.0
        if v_rest > 0.0:
            fade = scal[kk, 0] / v_rest
            if fade > 1.0:
                fade = 1.0
        pen = 0.0
        for i in range(A):
            ri = r[i] * mask[i]
            if gate:
                ri = ri * g
            if v_rest > 0.0:
                ri = ri * fade
            q = ri / scale
            pen += q * q
            x = action[b, i] + ri
            if x < -1.0:
                x = -1.0
            elif x > 1.0:
                x = 1.0
            action[b, i] = x
        if A == 2:
            step_one(2, b, cfg, icfg, state, z2, path, plant, action, out, info)
        else:
            step_one(A, b, cfg, icfg, state, z2, path, plant, action, out, info)
        record_step(n, b, A, T, n_steps, state, path, trace)
        sums[0] += out.reward[b]
        sums[1] += pen
        sums[2] += 1.0
        n += 1
        if out.terminated[b] or out.truncated[b]:
            return n, 0, 1
    return n, 0, 0


@njit(cache=True)
def run_residual_table(
    law_arrays, cfg, icfg, state, path, plant, scal, action, out, info, trace, table, scale,
    mask, weights, path_frame, gate, v_rest, repeat,
):  # fmt: skip
    """Env 0 from its current (reset) state to the end of its episode with the agent's actions
    read from ``table`` (M, n_act): row m held for the ``repeat`` periods of agent step m (the
    last row past the end), each chunk :func:`_run_residual_chunk` — the same law, period for
    period, as an agent deciding ``table[m]`` (what :mod:`agents.teacher` replays its learned
    correction with). Returns (n, bad): steps recorded, 1 when the base's action was not
    finite."""
    B = borrowed
    args = borrowed_inputs(
        law_arrays, cfg, icfg, state, path, plant, scal, action, out, info, trace
    )  # fmt: skip
    tab = B(table)
    msk, wts = B(mask), B(weights)
    n = 0
    m = 0
    last = tab.shape[0] - 1
    sums = np.zeros(3)
    while True:
        row = tab[m] if m < last else tab[last]
        n, bad, ended = _run_residual_chunk(
            *args, row, scale, msk, wts, path_frame, gate, v_rest, n, repeat, sums
        )  # fmt: skip
        m += 1
        if bad or ended:
            return n, bad


@njit(cache=True)
def replay_residual_table(
    law_arrays, cfg, icfg, state, path, plant, scal, action, out, info, trace, table, scale,
    mask, weights, path_frame, gate, v_rest, repeat, penalty, view_args, obs_out, reward_out,
    moving_out,
):  # fmt: skip
    """:func:`run_residual_table` recording what an RL episode of the agent records per agent
    step m: its raw observation before the step (``obs_out[m]``, :func:`agent_input` without
    statistics; ``obs_out[M]`` the last one), the step's reward as
    :class:`agents.residual.ResidualWrapper` computes it (the mean env reward over the step's
    periods minus ``penalty`` · Σ(r / scale)² / n, ``reward_out[m]``) and whether the
    reference moved at the decision (``moving_out[m]``). ``view_args``: :func:`agent_input`'s
    arguments from ``fields`` to ``clip`` (fields, rotate_prev, observe_axes, feed,
    acc_scale, clip). Returns (agent steps, bad, terminated)."""
    B = borrowed
    args = borrowed_inputs(
        law_arrays, cfg, icfg, state, path, plant, scal, action, out, info, trace
    )  # fmt: skip
    tab = B(table)
    msk, wts = B(mask), B(weights)
    fields, rotate_prev, observe_axes, feed, acc_scale, clip = view_args
    A = state.z.shape[1]
    size = obs_out.shape[1]
    zero = np.zeros(size)
    one = np.ones(size)
    buf = np.zeros((1, size), dtype=np.float32)
    n_steps = icfg[I_NSTEPS]
    n = 0
    m = 0
    last = tab.shape[0] - 1
    sums = np.zeros(3)
    while True:
        kk = state.k[0] if state.k[0] < n_steps - 1 else n_steps - 1
        moving_out[m] = scal[kk, 0] > 0.0
        agent_input(
            A, out.obs, state.k, n_steps, path.ref_pav, path.frame, fields, rotate_prev,
            observe_axes, feed, acc_scale, clip, zero, one, np.inf, buf,
        )  # fmt: skip
        obs_out[m, :] = buf[0]
        row = tab[m] if m < last else tab[last]
        sums[:] = 0.0
        n, bad, ended = _run_residual_chunk(
            *args, row, scale, msk, wts, path_frame, gate, v_rest, n, repeat, sums
        )  # fmt: skip
        if bad:
            return m, 1, 0
        steps = sums[2] if sums[2] > 0 else 1.0
        reward_out[m] = (sums[0] - penalty * sums[1] / A) / steps
        m += 1
        if ended:
            agent_input(
                A, out.obs, state.k, n_steps, path.ref_pav, path.frame, fields, rotate_prev,
                observe_axes, feed, acc_scale, clip, zero, one, np.inf, buf,
            )  # fmt: skip
            obs_out[m, :] = buf[0]
            return m, 0, 1 if out.terminated[0] else 0


@njit(cache=True, inline="always")
def _view_row(A, b, kk, obs, ref_pav, frame, fields, rotate_prev, observe_axes, feed, acc_scale,
              clip, x, v):  # fmt: skip
    # the agent's raw observation of env b (table row kk) into x (float32); returns its length
    m = fields.shape[0]
    for i in range(m):
        x[i] = obs[b, fields[i]]
    if rotate_prev:
        for i in range(A):
            v[i] = np.float64(x[m - A + i])
        for j in range(A):
            acc = 0.0
            for i in range(A):
                acc += frame[kk, i, j] * v[i]
            x[m - A + j] = np.float32(acc)
    o = m
    if observe_axes:
        for i in range(A):
            y = ref_pav[kk, 1, i] / feed
            x[o + i] = np.float32(min(max(y, -clip), clip))
        for i in range(A):
            y = ref_pav[kk, 2, i] / acc_scale
            x[o + A + i] = np.float32(min(max(y, -clip), clip))
        o += 2 * A
    return o


@njit(cache=True)
def agent_input(
    A, obs, k, n_steps, ref_pav, frame, fields, rotate_prev, observe_axes, feed, acc_scale,
    clip, mean, den, clip_obs, out,
):  # fmt: skip
    """Env 0's normalised agent observation into ``out`` (1, obs_dim) float32: the agent's
    view (:func:`view_rows`' row, the one definition of it) at the env's reference index, then
    (x − mean) / ``den`` clipped to ±``clip_obs`` and stored as float32 (``den`` = sqrt(var +
    ε), computed once), as :class:`agents.rl.checkpoint.ObsNormalizer` computes it.
    ``tests/agents/test_residual_frame.py`` checks it against the Python path to the bit."""
    n_steps_m1 = n_steps - 1
    kk = k[0] if k[0] < n_steps_m1 else n_steps_m1
    x = out[0]
    o = _view_row(A, 0, kk, obs, ref_pav, frame, fields, rotate_prev, observe_axes, feed,
                  acc_scale, clip, x, np.empty(A))  # fmt: skip
    for i in range(o):
        y = (np.float64(x[i]) - mean[i]) / den[i]
        x[i] = np.float32(min(max(y, -clip_obs), clip_obs))


@njit(cache=True)
def view_rows(A, obs, ref_pav, frame, fields, rotate_prev, observe_axes, feed, acc_scale, clip,
              out):  # fmt: skip
    """What a residual agent sees, for every env b of a batch, into ``out`` (B, size) float32
    (:class:`agents.residual.AgentView` runs this; the compiled episode loops run the same row
    through :func:`agent_input`): the selected env fields of ``obs`` (``fields``: their
    indices), the last A rotated into the path frame when ``rotate_prev`` (Fᵀ x, summed over
    the axes in order, in float64, stored as float32), then with ``observe_axes`` the axis
    observation (reference velocity / ``feed`` m/s, acceleration / ``acc_scale`` m/s², each
    clipped to ±``clip``). Row b reads ``ref_pav`` (B, 3, 3) and ``frame`` (B, 3, 3) at b."""
    v = np.empty(A)
    for b in range(out.shape[0]):
        _view_row(A, b, b, obs, ref_pav, frame, fields, rotate_prev, observe_axes, feed,
                  acc_scale, clip, out[b], v)  # fmt: skip


class ResidualForm:
    """The compiled form of a bound :class:`agents.residual.ResidualAgent` whose base has one:
    ``run_single`` runs env 0 to the end of its episode, the network queried every
    ``action_repeat`` periods from Python, the periods in between compiled.

    The same loop in pieces (for a caller that drives several parts): ``begin(core)``, then
    per agent step ``view()`` (the raw agent observation, before normalisation) and
    ``advance(a, n, recs)`` with the agent's action, until it reports the end.

    Per agent step, ``run_single`` builds the normalised observation compiled
    (:func:`agent_input`) when the agent has a NumPy actor and observation statistics, and
    calls only the network from Python: ~20 µs per agent step on lm-circle3d against ~45 µs
    through the signals dict, the view and the normaliser in NumPy (the same numbers to the
    bit, ``tests/agents/test_residual.py``)."""

    def __init__(self, agent, base_form):
        self.agent = agent
        self.base_form = base_form
        self._core = None

    def begin(self, core) -> None:
        agent = self.agent
        self._core = core
        self._args = self.base_form._core_args(core)
        self._mask = np.ascontiguousarray(agent._axis_mask(), dtype=np.float64)
        self._weights = np.ascontiguousarray(agent._weights, dtype=np.float64)
        self._path_frame = agent.residual_frame == "path"

    def view(self) -> np.ndarray:
        """The agent's raw observation (1, obs_dim) at the current sample (before the
        observation statistics)."""
        core = self._core
        return self.agent._view(core.obs[:1], core.signals_batch(), None)

    def advance(self, a, n: int, recs) -> tuple:
        """Hold the agent's action ``a`` (n_act,) for up to ``action_repeat`` periods from
        recorded step ``n``; ``recs``: (time, contour error, position, reference, force)
        arrays. Returns (n, bad, ended) as :func:`run_residual_chunk`."""
        agent = self.agent
        return run_residual_chunk(
            *self._args, EpisodeTrace(*recs), np.ascontiguousarray(a, dtype=np.float64),
            agent.scale,
            self._mask, self._weights, self._path_frame, agent.gate, agent._v_rest, n,
            agent.action_repeat,
        )  # fmt: skip

    def finish(self) -> None:
        """Write the base controller's state back into it."""
        self.base_form.store()

    def input_args(self):
        """The arguments of :func:`agent_input` for the bound core (its last one the output
        array), or None when the agent needs the NumPy path (no NumPy actor — a stochastic
        agent —, no :class:`~agents.rl.checkpoint.ObsNormalizer`, or the base command in the
        observation)."""
        from ..rl.checkpoint import ObsNormalizer

        agent, core = self.agent, self._core
        view, norm = agent._view, agent.norm
        if agent._actor is None or not isinstance(norm, ObsNormalizer):
            return None
        if view.observe_base_command:
            return None
        A = int(core.dim)
        fields = np.arange(core.obs_dim) if view.fields is None else np.asarray(view.fields)
        size = len(fields) + (2 * A if view.observe_axes else 0)
        if norm.mean.shape != (size,) or norm.var.shape != (size,):
            return None
        return (
            A, core.obs, core.k, int(core.n_steps), core.ref_pav, core.frame,
            np.ascontiguousarray(fields, dtype=np.int64), bool(view.rotate_prev),
            bool(view.observe_axes), float(view.feed), float(view.acc), float(view.clip),
            np.ascontiguousarray(norm.mean, dtype=np.float64),
            np.sqrt(norm.var + norm.epsilon), float(norm.clip_obs),
            np.zeros((1, size), dtype=np.float32),
        )  # fmt: skip

    def envelope_args(self):
        """The arguments of :func:`agents.envelope.envelope_factor` for the bound core, or None
        when the agent has no envelope (or does not use it)."""
        agent, core = self.agent, self._core
        if not agent.use_envelope:
            return None
        env = agent.envelope
        return (
            int(core.dim), core.k, int(core.n_steps), core.scal, core.ref_pav, core.obs,
            float(core.config.error_obs_scale_m), env.bounds(), float(env.margin),
            float(env.part_excess(core.setup.feedrate_m_s)),
        )  # fmt: skip

    def run_single(self, core, rec_time, rec_eps, rec_pos, rec_ref, rec_force) -> tuple:
        from ..envelope import envelope_factor

        agent = self.agent
        self.begin(core)
        recs = (rec_time, rec_eps, rec_pos, rec_ref, rec_force)
        n, bad, ended = 0, 0, 0
        fast = self.input_args()
        fence = self.envelope_args()
        if fast is not None:
            actor, x = agent._actor, fast[-1]
            while not (bad or ended):
                agent_input(*fast)
                a = actor(x)
                if fence is not None:
                    a = agent.fade_action(a, envelope_factor(*fence))
                n, bad, ended = self.advance(a[0], n, recs)
        else:
            while not (bad or ended):
                sig = core.signals_batch()
                a = agent.agent_action(core.obs[:1], sig, None)
                if fence is not None:
                    a = agent.fade_action(a, envelope_factor(*fence))
                n, bad, ended = self.advance(a[0], n, recs)
        self.finish()
        return int(n), bool(bad)


def warm_up() -> None:
    """Compile :func:`run_residual_chunk`, :func:`run_residual_table` and :func:`agent_input`
    for 2- and 3-axis plants (``contour-env warm``)."""
    import gymnasium as gym

    from contour_env import ENV_ID
    from contour_env.env.rollout import empty_record

    from ..registry import make_controller
    from .forms import compiled_form

    for case in ("sharp-corner", "lm-circle3d"):
        env = gym.make(ENV_ID, case=case)
        core = env.unwrapped.core
        ctrl = make_controller("ccc").bind(env)
        env.reset(seed=0)
        form = compiled_form(ctrl)
        rec = empty_record(core)
        A = core.dim
        trace = EpisodeTrace(
            rec["time"], rec["contour_error"], rec["position"], rec["reference"], rec["force"]
        )
        run_residual_chunk(
            *form._core_args(core), trace, np.zeros(A + 1), 0.05, np.ones(A), np.ones(A), True,
            True, 0.001, 0, 3,
        )  # fmt: skip
        env.reset(seed=0)
        run_residual_table(
            *form._core_args(core), trace, np.zeros((2, A + 1)), 0.05, np.ones(A), np.ones(A),
            True, True, 0.001, 2,
        )  # fmt: skip
        m = core.obs_dim + 2 * A
        agent_input(
            A, core.obs, core.k, int(core.n_steps), core.ref_pav, core.frame,
            np.arange(core.obs_dim, dtype=np.int64), True, True, 1.0, 1.0, 10.0, np.zeros(m),
            np.ones(m), 10.0, np.zeros((1, m), dtype=np.float32),
        )  # fmt: skip
