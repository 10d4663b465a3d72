"""A trained residual agent's whole control law as dependency-free C99.

``write_c(model_dir, out_dir)`` writes ``residual.h`` and ``residual.c``: the law of
:class:`agents.residual.ResidualAgent` for the model directory, for a CNC servo loop that calls
it once per servo period::

    residual_state st;
    residual_reset(&st);                       /* at the start of every part */
    for (;;) {                                 /* every servo period */
        residual_inputs in = ...;              /* interpolator sample, encoders, base command */
        residual_outputs out;
        residual_step(&in, &st, &out);
        apply(out.applied);                    /* fraction of each axis' force limit */
    }

What the C code computes, in the order of the Python agent (the references name the Python
that it mirrors, and ``tests/agents/test_export_c.py`` checks it against it step by step):

1. the velocity estimate: backward difference of the encoder reading, 0 at the first period
   after ``residual_reset`` (as the env's ``measure_stage``, 0 at reset);
2. at each agent decision (every ``action_repeat`` periods, the first one at the first period):
   the env observation at that sample (:func:`contour_env.env.kernel.observe` and
   ``observation_table``: task-frame position and velocity errors, scaled path speed, path
   acceleration and curvature, the preview in the task frame, each clipped to ±obs_clip and
   rounded to float32 as the env stores it), the agent's selection of it and its axis
   observation (:class:`agents.residual.AgentView`, float32), the normalisation
   (:class:`agents.rl.checkpoint.ObsNormalizer`, float32 output), the actor network
   (:func:`agents.rl.actor.numpy_actor`, evaluated in double here), clipped to [−1, 1], and the
   envelope's fade on the gate (:meth:`agents.envelope.Envelope.factor`,
   :meth:`agents.residual.ResidualAgent.fade_action`); the action is held until the next
   decision;
3. every period: the residual of the held action in the current task frame
   (:func:`agents.residual_law.residual_command`: path frame, per-axis weights, axis mask,
   gate, rest fade :func:`agents.residual_law.rest_fade`) and the applied command
   clip(base + residual, −1, 1).

All the numbers — network weights, normalisation statistics, envelope bounds, observation
scales, servo period, preview steps, path weights — are embedded as ``static const double``
arrays. The code allocates nothing and uses nothing of libc but ``math.h`` (``sqrt``,
``tanh``, ``fabs``, ``isfinite``).

An agent kept as its base (``"kept": "base"`` in ``agent.json``,
``ResidualAgent.is_base``) exports the zero law: ``residual_step`` returns a zero residual and
``applied`` = clip(base, −1, 1) always (its network is not embedded).

Bad input: a NaN or infinite value anywhere in the inputs, or a programmed feed or
acceleration limit ≤ 0, closes the gate for that period (residual 0, applied = clip(base) with
a non-finite base component replaced by 0) and sets ``out->bad_input``; the held action is
dropped, so the next good period takes a fresh decision (see the generated header for the
velocity estimate after a non-finite encoder reading).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

HEADER = "residual.h"
SOURCE = "residual.c"

# bits of residual_outputs.status
STATUS_BAD_INPUT = 1
STATUS_WARMUP = 2
STATUS_BASE = 4


def _num(v) -> str:
    """A C double literal that reads back to exactly ``v`` (shortest round-trip decimal)."""
    v = float(v)
    if not math.isfinite(v):
        raise ValueError(f"export: non-finite constant {v!r}")
    s = repr(v)
    if "e" not in s and "." not in s:
        s += ".0"
    return s


def _array(name: str, values, per_line: int = 4) -> str:
    vals = [_num(v) for v in np.asarray(values, dtype=np.float64).reshape(-1)]
    if not vals:
        vals = ["0.0"]
    lines = []
    for i in range(0, len(vals), per_line):
        lines.append("    " + ", ".join(vals[i : i + per_line]) + ",")
    return f"static const double {name}[{len(vals)}] = {{\n" + "\n".join(lines) + "\n};\n"


def plant_of(model_dir, meta: dict, plant=None):
    """The plant the agent's law runs on, as ``gym.make(plant=...)`` takes it: its named plant,
    or the plant file it was trained on (``plant``, else the run's config.json's path when that
    file is still there); ValueError naming what to give otherwise."""
    from contour_env.plants.catalog import PLANTS
    from contour_env.plants.from_file import is_plant_file

    if plant is None and meta["plant"] in PLANTS:
        plant = meta["plant"]
    if plant is None:
        cfg = Path(model_dir) / "config.json"
        given = json.loads(cfg.read_text()).get("plant") if cfg.is_file() else None
        if given and is_plant_file(given) and Path(given).is_file():
            plant = given
    if plant is None:
        raise ValueError(
            f"export: the agent was trained on a plant file ({meta.get('plant_file', '?')}, plant "
            f"{meta['plant']!r}) that is not where its config.json says; give it with --plant"
        )
    return plant


def _nominal_of(model_dir, meta: dict, plant=None):
    """The nominal plant parameters the agent's law uses (servo period, path weights)."""
    from contour_env.plants.catalog import resolve_plant

    _, nominal, _ = resolve_plant(plant_of(model_dir, meta, plant))
    if nominal.name != meta["plant"]:
        raise ValueError(
            f"export: the plant given is {nominal.name!r}; the agent was trained for "
            f"{meta['plant']!r}"
        )
    return nominal


def _law_settings(model_dir, config=None, plant=None) -> dict:
    """Everything the C law needs from a model directory, as plain numbers (``plant``: the
    plant file of an agent trained on one, when its run's config.json no longer points at
    it)."""
    from contour_env.env.core import EnvConfig

    from ..residual import REST_FADE_FEED_FRACTION, ResidualAgent
    from ..residual_law import path_weights

    agent = ResidualAgent(model_dir)
    meta = agent.meta
    cfg = EnvConfig() if config is None else config
    n = int(meta["n_axes"])
    nominal = _nominal_of(model_dir, meta, plant)
    if getattr(nominal, "family", None) == "five-axis" or nominal.n_axes != n:
        raise ValueError(
            f"export: the agent's plant {meta['plant']!r} is not a {n}-axis feed-drive plant"
        )
    T = float(nominal.servo_period_s)
    want_T = meta.get("servo_period_s")
    if want_T is not None and not math.isclose(float(want_T), T, rel_tol=1e-9):
        raise ValueError(f"export: agent servo period {want_T} s, plant's {T} s")
    preview = [max(1, round(t / T)) for t in cfg.preview_times_s]
    env_obs_dim = 3 * n + 3 + len(preview) * n
    if agent.observation == "full":
        n_fields = env_obs_dim
    elif agent.observation == "state":
        n_fields = env_obs_dim - n
    else:
        n_fields = 2 * n
    obs_dim = (
        n_fields + (2 * n if agent.observe_axes else 0) + (n if agent.observe_base_command else 0)
    )
    if obs_dim != int(meta["obs_dim"]):
        raise ValueError(
            f"export: observation size {obs_dim} (preview_times_s {cfg.preview_times_s}) "
            f"differs from the agent's {meta['obs_dim']}"
        )
    s = {
        "agent": agent,
        "meta": meta,
        "n": n,
        "n_act": n + (1 if agent.gate else 0),
        "T": T,
        "inv_T": 1.0 / T,
        "preview_times_s": [float(t) for t in cfg.preview_times_s],
        "preview_steps": preview,
        "obs_clip": float(cfg.obs_clip),
        "err_scale": float(cfg.error_obs_scale_m),
        "inv_err": 1.0 / cfg.error_obs_scale_m,
        "inv_verr": 1.0 / cfg.velocity_error_obs_scale_m_s,
        "curv_scale": float(cfg.curvature_obs_scale_m),
        "n_fields": n_fields,
        "obs_dim": obs_dim,
        "is_base": bool(agent.is_base),
        "rest_fraction": float(REST_FADE_FEED_FRACTION) if agent.fade_at_rest else 0.0,
        "weights": (path_weights(nominal) if agent.residual_frame == "path" else np.ones(n)),
    }
    return s


def describe_interface(n_axes: int, preview_times_s, is_base: bool = False) -> dict:
    """The inputs, state and outputs of the generated law (name, unit, shape, meaning)."""
    n, p = int(n_axes), len(preview_times_s)
    taus = ", ".join(f"{t:g}" for t in preview_times_s)
    inputs = [
        ("ref_position", "m", [n], "reference position x_d at this period (env ref_pav[k, 0])"),
        ("ref_velocity", "m/s", [n], "reference velocity (env ref_pav[k, 1])"),
        ("ref_acceleration", "m/s^2", [n], "reference acceleration (env ref_pav[k, 2])"),
        (
            "frame",
            "1",
            [n, n],
            "task frame: frame[i][j] = machine-axis i component of unit "
            "vector j (j = t, n, b), as env frame[k]",
        ),
        ("path_speed", "m/s", [], "path speed s_dot (env scal[k, 0])"),
        ("path_accel", "m/s^2", [], "path acceleration s_ddot (env scal[k, 1])"),
        ("curvature", "1/m", [], "signed curvature kappa (env scal[k, 2])"),
        (
            "preview_position",
            "m",
            [p, n],
            f"reference position at t + tau_j, tau = {taus} s "
            "(env ref_pav[min(k + p_j, n_steps - 1), 0])",
        ),
        ("encoder_position", "m", [n], "encoder reading of each axis at this period"),
        ("programmed_feed", "m/s", [], "the part's programmed feed (env setup.feedrate_m_s), > 0"),
        ("max_accel", "m/s^2", [], "the part's acceleration limit (env setup.max_accel_m_s2), > 0"),
        ("axis_mask", "1", [n], "1 on the axes the part moves, 0 on the others"),
        ("base_command", "fraction of force limit", [n], "the base controller's command"),
    ]
    state = [
        ("prev_encoder", "m", [n], "encoder reading of the previous period"),
        ("prev_applied", "fraction of force limit", [n], "previous applied command"),
        (
            "held_action",
            "1",
            [n + 1],
            "agent action held between decisions (after the envelope fade)",
        ),
        ("envelope_fade", "1", [], "envelope fade f of the last decision"),
        ("count", "periods", [], "periods since the last decision (mod action_repeat)"),
        ("first", "flag", [], "1 until the first period after residual_reset"),
        ("prev_valid", "flag", [], "1 when prev_encoder holds a finite reading"),
    ]
    outputs = [
        ("residual", "fraction of force limit", [n], "residual added to the base command"),
        ("applied", "fraction of force limit", [n], "clip(base + residual, -1, 1)"),
        ("gate", "1", [], "gate g in [0, 1] (0: closed)"),
        ("envelope_fade", "1", [], "envelope fade f of the held decision (1 inside)"),
        ("rest_fade", "1", [], "rest fade min(1, s_dot / v_rest) of this period"),
        ("bad_input", "flag", [], "1 when an input was not finite or feed/accel <= 0"),
        ("decided", "flag", [], "1 when the network was evaluated this period"),
        ("status", "bits", [], "1 bad input, 2 velocity warm-up, 4 base law (kept base)"),
    ]

    def rows(items):
        return [{"name": a, "unit": u, "shape": s, "description": d} for a, u, s, d in items]

    return {
        "entry_points": [
            "void residual_step(const residual_inputs *in, residual_state *st, "
            "residual_outputs *out)",
            "void residual_reset(residual_state *st)",
        ],
        "inputs": rows(inputs),
        "state": rows(state),
        "outputs": rows(outputs),
        "zero_law": bool(is_base),
    }


def _header(s: dict) -> str:
    n = s["n"]
    p = len(s["preview_steps"])
    meta = s["meta"]
    taus = ", ".join(f"{t:g}" for t in s["preview_times_s"])
    steps = ", ".join(str(k) for k in s["preview_steps"])
    law = (
        'ZERO LAW: this agent was kept as its base controller (agent.json "kept": "base");\n'
        " * residual_step always returns residual = 0 and applied = clip(base, -1, 1).\n"
        if s["is_base"]
        else f"{meta['algo']} actor, observation {s['agent'].observation!r}, residual frame "
        f"{s['agent'].residual_frame!r},\n * gate {s['agent'].gate}, action_repeat "
        f"{s['agent'].action_repeat}, scale {s['agent'].scale:g}, envelope "
        f"{s['agent'].use_envelope}, fade_at_rest {s['agent'].fade_at_rest}.\n"
    )
    return f"""/* residual.h -- the control law of the residual agent {meta["plant"]!r}
 * (generated by agents.export.c_law.write_c; do not edit).
 *
 * {law} *
 * Call residual_reset() at the start of every part, then residual_step() once per servo
 * period (T = {_num(s["T"])} s), with the interpolator's sample of that period. Every
 * command is a fraction of the axis force limit (what the env's action is).
 *
 * Units: SI (m, m/s, m/s^2, 1/m). Axes: {n} ("{"xyz"[:n]}").
 * Task frame directions: t, n{", b" if n == 3 else ""}.
 *
 * Bad input: if any input is NaN or infinite, or programmed_feed <= 0, or max_accel <= 0,
 * the gate closes for this period: residual = 0, applied = clip(base_command, -1, 1) (a
 * non-finite base component gives 0), out->bad_input = 1 (status bit 1). The held action is
 * dropped (the next good period takes a fresh decision). A finite encoder reading is still
 * stored for the velocity estimate; after a NON-finite one, the next good period has no
 * velocity estimate: it outputs residual 0 and only stores the reading (status bit 2,
 * "warm-up"), and the period after it decides.
 */
#ifndef RESIDUAL_LAW_H
#define RESIDUAL_LAW_H

#define RESIDUAL_N_AXES {n}
#define RESIDUAL_N_PREVIEW {p}
#define RESIDUAL_N_ACTION {s["n_act"]}
#define RESIDUAL_OBS_DIM {s["obs_dim"]}
#define RESIDUAL_ACTION_REPEAT {s["agent"].action_repeat}
#define RESIDUAL_SERVO_PERIOD_S {_num(s["T"])}
#define RESIDUAL_ZERO_LAW {1 if s["is_base"] else 0}

#define RESIDUAL_STATUS_BAD_INPUT {STATUS_BAD_INPUT}
#define RESIDUAL_STATUS_WARMUP {STATUS_WARMUP}
#define RESIDUAL_STATUS_BASE {STATUS_BASE}

/* preview times tau_j (s): {taus}; in servo periods p_j: {steps} */

typedef struct {{
    /* the interpolator's reference sample at this servo period (index k) */
    double ref_position[RESIDUAL_N_AXES];      /* x_d(t), m */
    double ref_velocity[RESIDUAL_N_AXES];      /* dx_d/dt, m/s */
    double ref_acceleration[RESIDUAL_N_AXES];  /* d2x_d/dt2, m/s^2 */
    /* task frame: frame[i][j] = component on machine axis i of unit vector j, j = 0 tangent t,
       1 normal n{", 2 binormal b" if n == 3 else " (left normal)"} (the env's core.frame[k]) */
    double frame[RESIDUAL_N_AXES][RESIDUAL_N_AXES];
    double path_speed;   /* s_dot, m/s (core.scal[k, 0]) */
    double path_accel;   /* s_ddot, m/s^2 (core.scal[k, 1]) */
    double curvature;    /* signed kappa, 1/m (core.scal[k, 2]) */
    /* look-ahead: x_d(t + tau_j), m, j over the preview times above (core.ref_pav[min(k + p_j,
       n_steps - 1), 0]: past the end of the program, its last point) */
    double preview_position[RESIDUAL_N_PREVIEW][RESIDUAL_N_AXES];
    double encoder_position[RESIDUAL_N_AXES];  /* encoder reading at this period, m */
    double programmed_feed;  /* the part's programmed feed F, m/s (> 0; scales the observation) */
    double max_accel;        /* the part's acceleration limit, m/s^2 (> 0) */
    double axis_mask[RESIDUAL_N_AXES];  /* 1 on the axes the part moves, 0 on the others */
    double base_command[RESIDUAL_N_AXES];  /* base controller command, fraction of force limit */
}} residual_inputs;

typedef struct {{
    /* carried from one servo period to the next; set by residual_reset() */
    double prev_encoder[RESIDUAL_N_AXES];  /* encoder reading of the previous period, m */
    double prev_applied[RESIDUAL_N_AXES];  /* previous applied command (fraction of limit) */
    double held_action[RESIDUAL_N_AXES + 1];  /* agent action held between decisions, in
                                                 [-1, 1], gate component after the envelope fade */
    double envelope_fade;  /* envelope fade f of the held decision, [0, 1] */
    int count;       /* periods since the last decision, 0 .. RESIDUAL_ACTION_REPEAT - 1 */
    int first;       /* 1 until the first period after residual_reset (velocity estimate 0) */
    int prev_valid;  /* 1 when prev_encoder holds a finite reading */
}} residual_state;

typedef struct {{
    double residual[RESIDUAL_N_AXES];  /* residual command, fraction of the force limit */
    double applied[RESIDUAL_N_AXES];   /* clip(base_command + residual, -1, 1) */
    double gate;           /* gate g in [0, 1] (1 without a gate; 0 closed) */
    double envelope_fade;  /* envelope fade f of the held decision (1 inside the envelope) */
    double rest_fade;      /* min(1, path_speed / v_rest) of this period (1 without) */
    int bad_input;         /* 1 when an input was not finite, or feed/accel <= 0 */
    int decided;           /* 1 when the network was evaluated this period */
    int status;            /* RESIDUAL_STATUS_* bits */
}} residual_outputs;

void residual_reset(residual_state *st);
void residual_step(const residual_inputs *in, residual_state *st, residual_outputs *out);

#endif /* RESIDUAL_LAW_H */
"""


def _network_code(s: dict) -> tuple[str, str]:
    """(constants, body) of the actor: x (float32-rounded, in double) -> act[]."""
    agent = s["agent"]
    actor = agent._actor
    consts = []
    body = []
    width = s["obs_dim"]
    widths = [width]
    for kind, W, _b in actor.layers:
        if kind == "linear":
            widths.append(W.shape[1])
    buf = max(widths)
    body.append(f"    double h0[{buf}], h1[{buf}];")
    body.append("    double *x = h0, *y = h1, *t;")
    body.append(f"    for (i = 0; i < {width}; ++i) x[i] = xin[i];")
    li = 0
    cur = width
    for kind, W, b in actor.layers:
        if kind == "linear":
            n_in, n_out = W.shape
            if n_in != cur:
                raise ValueError(f"export: layer {li} takes {n_in} inputs, got {cur}")
            consts.append(f"/* layer {li}: y = x W + b, W ({n_in} x {n_out}) row-major */\n")
            consts.append(_array(f"L{li}_W", W))
            consts.append(_array(f"L{li}_B", b))
            body.append(f"    for (j = 0; j < {n_out}; ++j) {{")
            body.append("        double acc = 0.0;")
            body.append(
                f"        for (i = 0; i < {n_in}; ++i) acc += x[i] * L{li}_W[i * {n_out} + j];"
            )
            body.append(f"        y[j] = acc + L{li}_B[j];")
            body.append("    }")
            body.append("    t = x; x = y; y = t;")
            cur = n_out
            li += 1
        elif kind == "relu":
            body.append(f"    for (i = 0; i < {cur}; ++i) if (!(x[i] > 0.0)) x[i] = 0.0;")
        elif kind == "tanh":
            body.append(f"    for (i = 0; i < {cur}; ++i) x[i] = tanh(x[i]);")
        else:
            raise ValueError(f"export: layer kind {kind!r} is not supported")
    if cur != s["n_act"]:
        raise ValueError(f"export: the actor outputs {cur} values, the law takes {s['n_act']}")
    if actor.squash:
        body.append(f"    for (i = 0; i < {cur}; ++i) x[i] = tanh(x[i]);")
    body.append(f"    for (i = 0; i < {cur}; ++i) act[i] = clip1(x[i]);")
    return "".join(consts), "\n".join(body)


def _source_base(s: dict) -> str:
    n = s["n"]
    return f"""/* residual.c -- the ZERO law of an agent kept as its base (generated by
 * agents.export.c_law.write_c; do not edit). See residual.h. */
#include <math.h>
#include "residual.h"

void residual_reset(residual_state *st)
{{
    int i;
    for (i = 0; i < RESIDUAL_N_AXES; ++i) {{
        st->prev_encoder[i] = 0.0;
        st->prev_applied[i] = 0.0;
        st->held_action[i] = 0.0;
    }}
    st->held_action[RESIDUAL_N_AXES] = 0.0;
    st->envelope_fade = 0.0;
    st->count = 0;
    st->first = 1;
    st->prev_valid = 0;
}}

void residual_step(const residual_inputs *in, residual_state *st, residual_outputs *out)
{{
    int i, j, bad = 0;
    const double *v = (const double *)in;
    /* every input is a double: the struct is scanned as an array */
    for (i = 0; i < (int)(sizeof(residual_inputs) / sizeof(double)); ++i)
        if (!isfinite(v[i])) bad = 1;
    if (!(in->programmed_feed > 0.0) || !(in->max_accel > 0.0)) bad = 1;
    (void)j;
    for (i = 0; i < {n}; ++i) {{
        double b = in->base_command[i];
        double a = isfinite(b) ? (b < -1.0 ? -1.0 : (b > 1.0 ? 1.0 : b)) : 0.0;
        out->residual[i] = 0.0;
        out->applied[i] = a;
        st->prev_applied[i] = a;
        if (isfinite(in->encoder_position[i])) st->prev_encoder[i] = in->encoder_position[i];
    }}
    st->first = 0;
    out->gate = 0.0;
    out->envelope_fade = 0.0;
    out->rest_fade = 0.0;
    out->bad_input = bad;
    out->decided = 0;
    out->status = RESIDUAL_STATUS_BASE | (bad ? RESIDUAL_STATUS_BAD_INPUT : 0);
}}
"""


def _consts_code(s: dict, net_consts: str) -> str:
    """The embedded constants: scales, normalisation, envelope, network."""
    agent = s["agent"]
    norm = agent.norm
    std = np.sqrt(norm.var + norm.epsilon)
    env = agent.envelope
    consts = [
        f"static const double T_S = {_num(s['T'])};\n",
        f"static const double INV_T = {_num(s['inv_T'])};  /* 1 / T */\n",
        f"static const double OBS_CLIP = {_num(s['obs_clip'])};\n",
        f"static const double INV_ERR = {_num(s['inv_err'])};  /* 1 / error_obs_scale_m */\n",
        f"static const double ERR_SCALE = {_num(s['err_scale'])};  /* error_obs_scale_m */\n",
        f"static const double INV_VERR = {_num(s['inv_verr'])};  "
        "/* 1 / velocity_error_obs_scale_m_s */\n",
        f"static const double CURV_SCALE = {_num(s['curv_scale'])};  /* curvature_obs_scale_m */\n",
        f"static const double SCALE = {_num(agent.scale)};  /* residual authority */\n",
        f"static const double REST_FRACTION = {_num(s['rest_fraction'])};  "
        "/* v_rest = this x programmed feed (0: no rest fade) */\n",
        "/* preview steps p_j (servo periods) */\n",
        _array("PREVIEW_STEPS", s["preview_steps"]),
        "/* path-frame weights w_i (agents.residual_law.path_weights) */\n",
        _array("PATH_W", s["weights"]),
        "/* observation normalisation: (x - mean) / sqrt(var + eps), clipped */\n",
        _array("NORM_MEAN", norm.mean),
        _array("NORM_STD", std),
        f"static const double NORM_CLIP = {_num(norm.clip_obs)};\n",
    ]
    if env is not None:
        b = env.bounds()
        consts.append(
            "/* envelope (agents.envelope): bounds of feed, |kappa|, |v_i|, |a_i|, |e_j| */\n"
        )
        consts.append(_array("ENV_HI", b))
        consts.append(f"static const double ENV_MARGIN = {_num(env.margin)};\n")
        if env.feed_range is not None:
            consts.append(f"static const double ENV_FEED_LO = {_num(env.feed_range[0])};\n")
            consts.append(f"static const double ENV_FEED_HI = {_num(env.feed_range[1])};\n")
    consts.append(net_consts)
    return "".join(consts)


def _observation_code(s: dict) -> str:
    """The agent's normalised observation xin (env observation, selection, axis fields)."""
    agent = s["agent"]
    n = s["n"]
    p = len(s["preview_steps"])
    # --- the observation --------------------------------------------------------------
    obs_lines = []
    full = agent.observation == "full"
    obs_lines.append(f"    float o[{3 * n + 3 + p * n}];  /* the env's observation (float32) */")
    obs_lines.append("    double xin[RESIDUAL_OBS_DIM];")
    obs_lines.append("    double inv_feed = 1.0 / in->programmed_feed;")
    obs_lines.append("    double inv_acc = 1.0 / in->max_accel;")
    obs_lines.append(f"    for (r = 0; r < {n}; ++r) {{")
    obs_lines.append("        double acc = 0.0, accv = 0.0;")
    obs_lines.append(
        f"        for (c = 0; c < {n}; ++c) acc += in->frame[c][r] * "
        "(in->ref_position[c] - in->encoder_position[c]);"
    )
    obs_lines.append(
        f"        for (c = 0; c < {n}; ++c) accv += in->frame[c][r] * "
        "(in->ref_velocity[c] - vel[c]);"
    )
    obs_lines.append("        o[r] = (float)clipc(acc * INV_ERR);")
    obs_lines.append(f"        o[{n} + r] = (float)clipc(accv * INV_VERR);")
    obs_lines.append("    }")
    obs_lines.append(f"    o[{2 * n}] = (float)clipc(in->path_speed * inv_feed);")
    obs_lines.append(f"    o[{2 * n + 1}] = (float)clipc(in->path_accel * inv_acc);")
    obs_lines.append(f"    o[{2 * n + 2}] = (float)clipc(in->curvature * CURV_SCALE);")
    obs_lines.append(f"    for (j = 0; j < {p}; ++j) {{")
    obs_lines.append(
        "        double inv_scale = 1.0 / ((in->programmed_feed * PREVIEW_STEPS[j]) * T_S);"
    )
    obs_lines.append(f"        for (r = 0; r < {n}; ++r) {{")
    obs_lines.append("            double acc = 0.0;")
    obs_lines.append(
        f"            for (c = 0; c < {n}; ++c) acc += in->frame[c][r] * "
        "(in->preview_position[j][c] - in->ref_position[c]);"
    )
    obs_lines.append(f"            o[{2 * n + 3} + j * {n} + r] = (float)clipc(acc * inv_scale);")
    obs_lines.append("        }")
    obs_lines.append("    }")
    prev_at = 3 * n + 3 + p * n - n
    if full:
        # the previous action (the env's AX_PREV: the command applied last period), in the
        # path frame F^T a_prev for a path-frame agent (AgentView.rotate_prev)
        obs_lines.append(
            f"    for (r = 0; r < {n}; ++r) o[{prev_at} + r] = (float)st->prev_applied[r];"
        )
        if agent.residual_frame == "path":
            obs_lines.append(f"    for (r = 0; r < {n}; ++r) {{")
            obs_lines.append("        double acc = 0.0;")
            obs_lines.append(
                f"        for (c = 0; c < {n}; ++c) acc += in->frame[c][r] * "
                f"(double)o[{prev_at} + c];"
            )
            obs_lines.append(f"        xin[{prev_at} + r] = (double)(float)acc;")
            obs_lines.append("    }")
            obs_lines.append(f"    for (i = 0; i < {prev_at}; ++i) xin[i] = (double)o[i];")
        else:
            obs_lines.append(f"    for (i = 0; i < {prev_at + n}; ++i) xin[i] = (double)o[i];")
    else:
        obs_lines.append(f"    for (i = 0; i < {s['n_fields']}; ++i) xin[i] = (double)o[i];")
    at = s["n_fields"]
    if agent.observe_axes:
        obs_lines.append(f"    for (i = 0; i < {n}; ++i) {{")
        obs_lines.append(
            f"        xin[{at} + i] = (double)(float)clipc(in->ref_velocity[i] / "
            "in->programmed_feed);"
        )
        obs_lines.append(
            f"        xin[{at + n} + i] = (double)(float)clipc("
            "in->ref_acceleration[i] / in->max_accel);"
        )
        obs_lines.append("    }")
        at += 2 * n
    if agent.observe_base_command:
        obs_lines.append(
            f"    for (i = 0; i < {n}; ++i) xin[{at} + i] = (double)(float)in->base_command[i];"
        )
        at += n
    assert at == s["obs_dim"]
    obs_lines.append("    /* normalisation, rounded to float32 as the Python agent does */")
    obs_lines.append("    for (i = 0; i < RESIDUAL_OBS_DIM; ++i) {")
    obs_lines.append("        double z = (xin[i] - NORM_MEAN[i]) / NORM_STD[i];")
    obs_lines.append("        z = z < -NORM_CLIP ? -NORM_CLIP : (z > NORM_CLIP ? NORM_CLIP : z);")
    obs_lines.append("        xin[i] = (double)(float)z;")
    obs_lines.append("    }")
    return "\n".join(obs_lines)


def _envelope_code(s: dict) -> str:
    """The envelope's fade of the decided action."""
    agent = s["agent"]
    n = s["n"]
    env = agent.envelope
    # --- envelope ------------------------------------------------------------------------
    env_lines = []
    if env is not None:
        env_lines.append("    {")
        env_lines.append("        /* agents.envelope.Envelope.factor */")
        if env.feed_range is not None:
            env_lines.append("        double F = in->programmed_feed, worst = 1.0, x;")
            env_lines.append("        if (F > ENV_FEED_HI || F < ENV_FEED_LO) {")
            env_lines.append("            worst = F / ENV_FEED_HI;")
            env_lines.append("            if (ENV_FEED_LO / F > worst) worst = ENV_FEED_LO / F;")
            env_lines.append("            if (worst < 1.0) worst = 1.0;")
            env_lines.append("        }")
        else:
            env_lines.append("        double worst = 1.0, x;")
        env_lines.append("        x = fabs(in->path_speed) / ENV_HI[0]; if (x > worst) worst = x;")
        env_lines.append("        x = fabs(in->curvature) / ENV_HI[1]; if (x > worst) worst = x;")
        env_lines.append(f"        for (i = 0; i < {n}; ++i) {{")
        env_lines.append(
            "            x = fabs(in->ref_velocity[i]) / ENV_HI[2 + i]; if (x > worst) worst = x;"
        )
        env_lines.append(
            f"            x = fabs(in->ref_acceleration[i]) / ENV_HI[{2 + n} + i]; "
            "if (x > worst) worst = x;"
        )
        env_lines.append(
            f"            x = fabs((double)o[i]) * ERR_SCALE / ENV_HI[{2 + 2 * n} + i]; "
            "if (x > worst) worst = x;"
        )
        env_lines.append("        }")
        env_lines.append("        f = 1.0 - (worst - 1.0) / ENV_MARGIN;")
        env_lines.append("        if (!isfinite(f)) f = 0.0;")
        env_lines.append("        f = f < 0.0 ? 0.0 : (f > 1.0 ? 1.0 : f);")
        env_lines.append("    }")
        if agent.gate:
            env_lines.append(f"    act[{n}] *= f;")
        else:
            env_lines.append(f"    for (i = 0; i < {n}; ++i) act[i] *= f;")
    env_code = "\n".join(env_lines)
    return env_code


def _residual_code(s: dict) -> str:
    """The residual of the held action in the current task frame."""
    agent = s["agent"]
    n = s["n"]
    # --- the residual of the held action -------------------------------------------------
    res = []
    res.append("    {")
    res.append("        const double *a = st->held_action;")
    res.append(f"        double push[{n}], r[{n}];")
    res.append(f"        for (i = 0; i < {n}; ++i) push[i] = a[i];")
    if agent.residual_frame == "path":
        res.append("        {")
        res.append("            double s2 = 0.0, norm;")
        res.append(f"            for (i = 0; i < {n}; ++i) s2 += push[i] * push[i];")
        res.append("            norm = sqrt(s2);")
        res.append("            if (norm < 1.0) norm = 1.0;")
        res.append(f"            for (i = 0; i < {n}; ++i) push[i] = push[i] / norm;")
        res.append("        }")
        res.append(f"        for (i = 0; i < {n}; ++i) r[i] = 0.0;")
        res.append(f"        for (j = 0; j < {n}; ++j)")
        res.append(f"            for (i = 0; i < {n}; ++i) r[i] += in->frame[i][j] * push[j];")
        res.append(f"        for (i = 0; i < {n}; ++i) r[i] = SCALE * (r[i] * PATH_W[i]);")
    else:
        res.append(f"        for (i = 0; i < {n}; ++i) r[i] = SCALE * push[i];")
    res.append(f"        for (i = 0; i < {n}; ++i) r[i] = r[i] * in->axis_mask[i];")
    if agent.gate:
        res.append(f"        g = a[{n}] < 0.0 ? 0.0 : (a[{n}] > 1.0 ? 1.0 : a[{n}]);")
        res.append(f"        for (i = 0; i < {n}; ++i) r[i] = r[i] * g;")
    else:
        res.append("        g = 1.0;")
    if s["rest_fraction"] > 0:
        res.append("        {")
        res.append("            double v_rest = REST_FRACTION * in->programmed_feed;")
        res.append("            rest = in->path_speed / v_rest;")
        res.append("            if (rest > 1.0) rest = 1.0;")
        res.append("        }")
        res.append(f"        for (i = 0; i < {n}; ++i) r[i] = r[i] * rest;")
    res.append(f"        for (i = 0; i < {n}; ++i) {{")
    res.append("            double u = in->base_command[i] + r[i];")
    res.append("            out->residual[i] = r[i];")
    res.append("            out->applied[i] = u < -1.0 ? -1.0 : (u > 1.0 ? 1.0 : u);")
    res.append("        }")
    res.append("    }")
    res_code = "\n".join(res)
    return res_code


def _source(s: dict) -> str:
    if s["is_base"]:
        return _source_base(s)
    agent = s["agent"]
    net_consts, net_body = _network_code(s)
    consts = [_consts_code(s, net_consts)]
    obs_code = _observation_code(s)
    env_code = _envelope_code(s)
    res_code = _residual_code(s)
    head = f"""/* residual.c -- the control law of the residual agent {agent.meta["plant"]!r}
 * (generated by agents.export.c_law.write_c from {agent.model_dir}; do not edit).
 * See residual.h for the interface. C99, no allocation, math.h only. */
#include <math.h>
#include "residual.h"

{"".join(consts)}
static double clipc(double v)
{{
    return v < -OBS_CLIP ? -OBS_CLIP : (v > OBS_CLIP ? OBS_CLIP : v);
}}

static double clip1(double v)
{{
    return v < -1.0 ? -1.0 : (v > 1.0 ? 1.0 : v);
}}

/* the deterministic actor: normalised observation -> action in [-1, 1] */
static void actor(const double *xin, double *act)
{{
    int i, j;
{net_body}
}}

/* the agent's decision: observation, normalisation, actor, envelope fade */
static void decide(const residual_inputs *in, const double *vel, const residual_state *st,
                   double *act, double *fade)
{{
    int i, j, r, c;
    double f = 1.0;
{obs_code}
    actor(xin, act);
{env_code}
    *fade = f;
    (void)st; (void)r; (void)c; (void)j;
}}

"""
    return head + "\n" + _step_code(res_code)


def _step_code(res_code: str) -> str:
    """residual_reset, the input check and residual_step (the held action's residual in
    ``res_code``)."""
    return f"""void residual_reset(residual_state *st)
{{
    int i;
    for (i = 0; i < RESIDUAL_N_AXES; ++i) {{
        st->prev_encoder[i] = 0.0;
        st->prev_applied[i] = 0.0;
    }}
    for (i = 0; i <= RESIDUAL_N_AXES; ++i) st->held_action[i] = 0.0;
    st->envelope_fade = 1.0;
    st->count = 0;
    st->first = 1;
    st->prev_valid = 0;
}}

static int inputs_bad(const residual_inputs *in)
{{
    int i;
    const double *v = (const double *)in;
    /* every field is a double: the struct is scanned as an array */
    for (i = 0; i < (int)(sizeof(residual_inputs) / sizeof(double)); ++i)
        if (!isfinite(v[i])) return 1;
    if (!(in->programmed_feed > 0.0) || !(in->max_accel > 0.0)) return 1;
    return 0;
}}

static void close_gate(const residual_inputs *in, residual_state *st, residual_outputs *out,
                       int status)
{{
    int i;
    for (i = 0; i < RESIDUAL_N_AXES; ++i) {{
        double b = in->base_command[i];
        out->residual[i] = 0.0;
        out->applied[i] = isfinite(b) ? clip1(b) : 0.0;
        st->prev_applied[i] = out->applied[i];
    }}
    for (i = 0; i <= RESIDUAL_N_AXES; ++i) st->held_action[i] = 0.0;
    st->count = 0;
    out->gate = 0.0;
    out->envelope_fade = st->envelope_fade;
    out->rest_fade = 0.0;
    out->bad_input = (status & RESIDUAL_STATUS_BAD_INPUT) ? 1 : 0;
    out->decided = 0;
    out->status = status;
}}

void residual_step(const residual_inputs *in, residual_state *st, residual_outputs *out)
{{
    int i, j;
    double vel[RESIDUAL_N_AXES];
    double g = 1.0, rest = 1.0;
    (void)j;
    if (inputs_bad(in)) {{
        int enc_ok = 1;
        for (i = 0; i < RESIDUAL_N_AXES; ++i)
            if (!isfinite(in->encoder_position[i])) enc_ok = 0;
        if (enc_ok) {{
            for (i = 0; i < RESIDUAL_N_AXES; ++i) st->prev_encoder[i] = in->encoder_position[i];
            st->prev_valid = 1;
            st->first = 0;
        }} else {{
            st->prev_valid = 0;
        }}
        close_gate(in, st, out, RESIDUAL_STATUS_BAD_INPUT);
        return;
    }}
    if (st->first) {{
        /* at reset the machine stands still: velocity estimate 0 (the env's reset) */
        for (i = 0; i < RESIDUAL_N_AXES; ++i) vel[i] = 0.0;
    }} else if (st->prev_valid) {{
        for (i = 0; i < RESIDUAL_N_AXES; ++i)
            vel[i] = (in->encoder_position[i] - st->prev_encoder[i]) * INV_T;
    }} else {{
        /* no previous reading to difference: store this one, no residual this period */
        for (i = 0; i < RESIDUAL_N_AXES; ++i) st->prev_encoder[i] = in->encoder_position[i];
        st->prev_valid = 1;
        close_gate(in, st, out, RESIDUAL_STATUS_WARMUP);
        return;
    }}
    out->decided = 0;
    if (st->count == 0) {{
        double act[RESIDUAL_N_ACTION], f = 1.0;
        decide(in, vel, st, act, &f);
        for (i = 0; i < RESIDUAL_N_ACTION; ++i) {{
            if (!isfinite(act[i])) {{
                for (j = 0; j < RESIDUAL_N_ACTION; ++j) act[j] = 0.0;
                break;
            }}
        }}
        for (i = 0; i < RESIDUAL_N_ACTION; ++i) st->held_action[i] = act[i];
        st->envelope_fade = f;
        out->decided = 1;
    }}
    st->count = (st->count + 1) % RESIDUAL_ACTION_REPEAT;
{res_code}
    for (i = 0; i < RESIDUAL_N_AXES; ++i) {{
        st->prev_encoder[i] = in->encoder_position[i];
        st->prev_applied[i] = out->applied[i];
    }}
    st->prev_valid = 1;
    st->first = 0;
    out->gate = g;
    out->envelope_fade = st->envelope_fade;
    out->rest_fade = rest;
    out->bad_input = 0;
    out->status = 0;
}}
"""


def write_c(model_dir, out_dir, *, config=None, plant=None) -> dict:
    """Write ``residual.h`` and ``residual.c`` (C99) for the trained agent in ``model_dir``
    into ``out_dir`` (created if needed); return the interface description (inputs, state and
    outputs with name, unit, shape and meaning, plus the law's settings and the files).

    ``config``: the :class:`contour_env.env.core.EnvConfig` the agent was trained under
    (observation scales, preview times, obs clip); None: the defaults (what ``contour-env
    train`` uses). The observation size it implies must be the agent's ``obs_dim``."""
    s = _law_settings(model_dir, config, plant)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    iface = describe_interface(s["n"], s["preview_times_s"], s["is_base"])
    (out / HEADER).write_text(_header(s))
    (out / SOURCE).write_text(_source(s))
    agent = s["agent"]
    iface.update(
        {
            "files": [str(out / HEADER), str(out / SOURCE)],
            "model_dir": str(Path(model_dir)),
            "plant": s["meta"]["plant"],
            "n_axes": s["n"],
            "servo_period_s": s["T"],
            "preview_times_s": s["preview_times_s"],
            "preview_steps": [int(k) for k in s["preview_steps"]],
            "action_repeat": int(agent.action_repeat),
            "obs_dim": s["obs_dim"],
            "compile": "cc -O2 -std=c99 -c residual.c (link with -lm)",
            "law": {
                "observation": agent.observation,
                "residual_frame": agent.residual_frame,
                "gate": agent.gate,
                "observe_axes": agent.observe_axes,
                "observe_base_command": agent.observe_base_command,
                "fade_at_rest": agent.fade_at_rest,
                "envelope": agent.use_envelope,
                "scale": agent.scale,
            },
        }
    )
    return json.loads(json.dumps(iface))


__all__ = ["describe_interface", "write_c"]
