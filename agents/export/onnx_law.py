"""A trained residual agent's whole control law as an ONNX graph (``residual.onnx``).

The graph computes what :mod:`agents.export.c_law`'s ``residual_step`` computes, with the same
inputs, state and outputs (:func:`agents.export.c_law.describe_interface`), as named tensors:
one call per servo period, the state tensors passed back in at the next call (ONNX graphs
hold no state). Every tensor is float64; the C form's scalars are tensors of shape [1]
here (the exporter types 0-d tensors as float32 scalars). Built as a PyTorch module and
written by ``torch.onnx.export`` (the TorchScript exporter, opset :data:`OPSET`); read by
ONNX Runtime or any ONNX backend.

Precision: the signal arithmetic (positions in metres, their differences, the task frame,
the envelope, the residual) is float64 — float32 resolves 0.06 µm at 0.5 m, the size of the
errors the agent reads — and from the observation on (rounded to float32 as the env stores
it) the normalisation and the network run in float32, as the Python agent's actor does; the
C law evaluates them in double.

An agent kept as its base (``"kept": "base"``) exports the zero law, as the C form.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

OPSET = 17
FILE = "residual.onnx"

INPUTS = (
    "ref_position", "ref_velocity", "ref_acceleration", "frame", "path_speed", "path_accel",
    "curvature", "preview_position", "encoder_position", "programmed_feed", "max_accel",
    "axis_mask", "base_command",
)  # fmt: skip
STATE = ("prev_encoder", "prev_applied", "held_action", "envelope_fade", "count", "first",
         "prev_valid")  # fmt: skip
OUTPUTS = ("residual", "applied", "gate", "out_envelope_fade", "rest_fade", "bad_input",
           "decided")  # fmt: skip


def _ft(F, v):
    """Fᵀ v as products and a sum (not MatMul: ONNX Runtime's extended optimisations run a
    float64 MatMul of this graph in float32, which loses the sub-µm errors of metre
    positions)."""
    return torch.sum(F * v[:, None], dim=0)


class Law(torch.nn.Module):
    """The residual law of one agent (settings ``s`` of c_law._law_settings)."""

    def __init__(self, s: dict):
        super().__init__()
        agent = s["agent"]
        d = torch.float64
        self.n = s["n"]
        self.zero = bool(s["is_base"])
        self.frame_path = agent.residual_frame == "path"
        self.gate = agent.gate
        self.observation = agent.observation
        self.observe_axes = agent.observe_axes
        self.observe_base = agent.observe_base_command
        self.repeat = int(agent.action_repeat)
        self.n_fields = s["n_fields"]
        self.k = dict(
            T=s["T"], clip=s["obs_clip"], inv_err=s["inv_err"], inv_verr=s["inv_verr"],
            curv=s["curv_scale"], err=s["err_scale"], scale=float(agent.scale),
            rest=s["rest_fraction"],
        )  # fmt: skip
        self.register_buffer("steps", torch.tensor(s["preview_steps"], dtype=d))
        self.register_buffer("w", torch.tensor(np.asarray(s["weights"]), dtype=d))
        if self.zero:
            return
        norm = agent.norm
        f32 = torch.float32
        self.register_buffer("mean", torch.tensor(norm.mean, dtype=f32))
        self.register_buffer("std", torch.tensor(np.sqrt(norm.var + norm.epsilon), dtype=f32))
        self.norm_clip = float(norm.clip_obs)
        self.layers = []
        for i, (kind, W, b) in enumerate(agent._actor.layers):
            if kind == "linear":
                self.register_buffer(f"W{i}", torch.tensor(W, dtype=torch.float32))
                self.register_buffer(f"b{i}", torch.tensor(b, dtype=torch.float32))
            self.layers.append((kind, i))
        self.squash = agent._actor.squash
        env = agent.envelope
        self.has_env = env is not None
        if self.has_env:
            self.register_buffer("env_hi", torch.tensor(env.bounds(), dtype=d))
            self.env_margin = float(env.margin)
            fr = env.feed_range
            self.env_feed = None if fr is None else (float(fr[0]), float(fr[1]))

    def actor(self, x):
        for kind, i in self.layers:
            if kind == "linear":
                x = x @ getattr(self, f"W{i}") + getattr(self, f"b{i}")
            elif kind == "relu":
                x = torch.relu(x)
            else:
                x = torch.tanh(x)
        if self.squash:
            x = torch.tanh(x)
        return torch.clamp(x.to(torch.float64), -1.0, 1.0)

    def decide(self, x, vel, prev_applied):
        """(action (n_act,), envelope fade) at this sample; ``x`` the inputs dict."""
        k, n = self.k, self.n
        F = x["frame"]
        clip = k["clip"]

        def c32(v):  # clipped, then float32 as the env stores its observation
            return torch.clamp(v, -clip, clip).to(torch.float32)

        feed, acc = x["programmed_feed"], x["max_accel"]
        e = c32(_ft(F, x["ref_position"] - x["encoder_position"]) * k["inv_err"])
        ev = c32(_ft(F, x["ref_velocity"] - vel) * k["inv_verr"])
        scal = torch.cat([x["path_speed"] / feed, x["path_accel"] / acc,
                          x["curvature"] * k["curv"]])  # fmt: skip
        prev = x["preview_position"] - x["ref_position"][None, :]
        pv = torch.sum(prev[:, :, None] * F[None, :, :], dim=1) / (
            feed * self.steps[:, None] * k["T"]
        )
        parts = [e, ev, c32(scal), c32(pv.reshape(-1))]
        if self.observation == "full":
            pa = prev_applied.to(torch.float32)
            if self.frame_path:
                pa = _ft(F, pa.to(torch.float64)).to(torch.float32)
            parts.append(pa)
        obs = torch.cat(parts)[: self.n_fields]
        extra = [obs]
        if self.observe_axes:
            extra += [c32(x["ref_velocity"] / feed), c32(x["ref_acceleration"] / acc)]
        if self.observe_base:
            extra.append(x["base_command"].to(torch.float32))
        # normalised in float32 (Python: in float64 from the float32 fields, then rounded;
        # the two differ by float32 rounding, ~1e-7 of a field). No float64 -> float32 ->
        # float64 round trip: ONNX Runtime's extended optimisations remove such cast
        # chains, and with them the rounding the agent was trained with
        xin = torch.cat(extra)
        z = torch.clamp((xin - self.mean) / self.std, -self.norm_clip, self.norm_clip)
        act = self.actor(z[None, :])[0]
        f = torch.ones(1, dtype=torch.float64)
        if self.has_env:
            worst = torch.ones(1, dtype=torch.float64)
            if self.env_feed is not None:
                lo, hi = self.env_feed
                out_of = (feed > hi) | (feed < lo)
                part = torch.maximum(torch.maximum(feed / hi, lo / feed), worst)
                worst = torch.where(out_of, part, worst)
            feats = torch.cat([
                torch.abs(x["path_speed"]), torch.abs(x["curvature"]),
                torch.abs(x["ref_velocity"]), torch.abs(x["ref_acceleration"]),
                torch.abs(e[:n].to(torch.float64)) * k["err"],
            ])  # fmt: skip
            worst = torch.maximum(worst, torch.amax(feats / self.env_hi, dim=0, keepdim=True))
            f = 1.0 - (worst - 1.0) / self.env_margin
            f = torch.where(torch.isfinite(f), f, torch.zeros_like(f))
            f = torch.clamp(f, 0.0, 1.0)
        if self.gate:
            act = torch.cat([act[:n], act[n:] * f])
        else:
            act = act * f
        return act, f

    def residual(self, x, a):
        k, n = self.k, self.n
        push = a[:n]
        if self.frame_path:
            norm = torch.clamp(torch.sqrt(torch.sum(push * push)), min=1.0)
            r = k["scale"] * (torch.sum(x["frame"] * (push / norm)[None, :], dim=1) * self.w)
        else:
            r = k["scale"] * push
        r = r * x["axis_mask"]
        g = torch.clamp(a[n:], 0.0, 1.0) if self.gate else torch.ones(1, dtype=a.dtype)
        r = r * g
        rest = torch.ones(1, dtype=a.dtype)
        if k["rest"] > 0:
            rest = torch.clamp(x["path_speed"] / (k["rest"] * x["programmed_feed"]), max=1.0)
            r = r * rest
        return r, g, rest

    def forward(self, *args):
        x = dict(zip(INPUTS, args[: len(INPUTS)], strict=True))
        st = dict(zip(STATE, args[len(INPUTS) :], strict=True))
        one = torch.ones(1, dtype=torch.float64)
        zero = torch.zeros(1, dtype=torch.float64)
        base = x["base_command"]
        finite = torch.cat([torch.isfinite(v).reshape(-1) for v in x.values()])
        bad = (
            (torch.min(finite.to(torch.float64), dim=0, keepdim=True).values < 0.5)
            | ~(x["programmed_feed"] > 0)
            | ~(x["max_accel"] > 0)
        )
        enc = x["encoder_position"]
        enc_ok = torch.min(torch.isfinite(enc).to(torch.float64), dim=0, keepdim=True).values > 0.5
        first = st["first"] > 0.5
        valid = st["prev_valid"] > 0.5
        warm = ~bad & ~first & ~valid
        ok = ~bad & ~warm
        safe = {key: torch.where(torch.isfinite(v), v, torch.zeros_like(v))
                for key, v in x.items()}  # fmt: skip
        safe["programmed_feed"] = torch.where(ok, safe["programmed_feed"], one)
        safe["max_accel"] = torch.where(ok, safe["max_accel"], one)
        vel = torch.where(
            first,
            torch.zeros_like(enc),
            (safe["encoder_position"] - st["prev_encoder"]) / self.k["T"],
        )
        decide_now = ok & (st["count"] < 0.5)
        held, fade = st["held_action"], st["envelope_fade"]
        if not self.zero:
            act, f = self.decide(safe, vel, st["prev_applied"])
            act_ok = torch.min(torch.isfinite(act).to(torch.float64), dim=0, keepdim=True)
            act = torch.where(act_ok.values > 0.5, act, torch.zeros_like(act))
            held = torch.where(decide_now, act, held)
            fade = torch.where(decide_now, f, fade)
            r, g, rest = self.residual(safe, held)
        else:
            r, g, rest = torch.zeros_like(base), zero, zero
        held = torch.where(ok, held, torch.zeros_like(held))
        r = torch.where(ok, r, torch.zeros_like(r))
        g = torch.where(ok, g, zero)
        rest = torch.where(ok, rest, zero)
        base_safe = torch.where(torch.isfinite(base), base, torch.zeros_like(base))
        applied = torch.clamp(base_safe + r, -1.0, 1.0)
        count = torch.where(ok, torch.remainder(st["count"] + 1.0, float(self.repeat)), zero)
        new_enc = torch.where(bad & ~enc_ok, st["prev_encoder"], safe["encoder_position"])
        new_valid = torch.where(bad, torch.where(enc_ok, one, zero), one)
        new_first = torch.where(bad & ~enc_ok, st["first"], torch.where(warm, st["first"], zero))
        return (
            r, applied, g, fade, rest, torch.where(bad, one, zero),
            torch.where(decide_now, zero if self.zero else one, zero),
            new_enc, applied, held, fade, count, new_first, new_valid,
        )  # fmt: skip


def example_inputs(s: dict):
    """Zero tensors of every input and state (the shapes of describe_interface), float64."""
    n, p = s["n"], len(s["preview_steps"])
    shapes = {
        "ref_position": (n,), "ref_velocity": (n,), "ref_acceleration": (n,), "frame": (n, n),
        "path_speed": (1,), "path_accel": (1,), "curvature": (1,), "preview_position": (p, n),
        "encoder_position": (n,), "programmed_feed": (1,), "max_accel": (1,), "axis_mask": (n,),
        "base_command": (n,), "prev_encoder": (n,), "prev_applied": (n,),
        "held_action": (n + 1,), "envelope_fade": (1,), "count": (1,), "first": (1,),
        "prev_valid": (1,),
    }  # fmt: skip
    t = {k: torch.zeros(v, dtype=torch.float64) for k, v in shapes.items()}
    t["frame"] = torch.eye(n, dtype=torch.float64)
    t["programmed_feed"] = torch.ones(1, dtype=torch.float64)
    t["max_accel"] = torch.ones(1, dtype=torch.float64)
    t["first"] = torch.ones(1, dtype=torch.float64)
    return [t[k] for k in INPUTS + STATE]


def reset_state(n_axes: int) -> dict:
    """The state tensors after ``residual_reset`` (NumPy float64), to pass at the first call."""
    n = int(n_axes)
    return {
        "prev_encoder": np.zeros(n), "prev_applied": np.zeros(n),
        "held_action": np.zeros(n + 1), "envelope_fade": np.ones(1),
        "count": np.zeros(1), "first": np.ones(1), "prev_valid": np.zeros(1),
    }  # fmt: skip


def write_onnx(model_dir, out_dir, *, config=None, plant=None) -> Path:
    """Write ``residual.onnx`` (opset :data:`OPSET`) of the agent in ``model_dir``; the
    file's path. ValueError where the law cannot run on a machine (as :func:`write_c`)."""
    import warnings

    from .c_law import _law_settings

    s = _law_settings(model_dir, config, plant)
    law = Law(s).eval()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = out / FILE
    tmp = out / (FILE + ".tmp")
    state_out = tuple(f"next_{k}" for k in STATE)
    with warnings.catch_warnings(), torch.no_grad():
        warnings.simplefilter("ignore")
        torch.onnx.export(
            law, tuple(example_inputs(s)), str(tmp), opset_version=OPSET, dynamo=False,
            input_names=list(INPUTS + STATE), output_names=list(OUTPUTS + state_out),
        )  # fmt: skip
    tmp.replace(path)
    return path
