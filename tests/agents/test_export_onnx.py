"""The ONNX export of a trained residual agent (agents/export/onnx_law.py) run by ONNX Runtime
against the Python agent: the residual within 1e-5 of the force limit at every step, bad input
closes the gate, a kept-base agent exports the zero law."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import agents.residual as residual_mod
import contour_env  # noqa: F401  (registers the env)
from agents.residual import ResidualAgent

ort = pytest.importorskip("onnxruntime", reason="the [deploy] extra (onnx, onnxruntime)")
pytest.importorskip("onnx", reason="the [deploy] extra (onnx, onnxruntime)")

from agents.export.onnx_law import OPSET, STATE, reset_state, write_onnx  # noqa: E402
from agents.export.replay import inputs_from_core  # noqa: E402

MODELS = Path(__file__).resolve().parents[2] / "agents" / "models"
LM, FT = MODELS / "linear-motor", MODELS / "friction-table"
TOL = 1e-5  # fraction of the force limit
CURVED = "G21 G90 G17 G64\nG01 X15 F3600\nG03 X25 Y10 R10\nG01 Y20\nG02 X15 Y30 R10\nG01 X0\n"


class OnnxLaw:
    """residual.onnx in an ONNX Runtime session, its state carried between calls."""

    def __init__(self, model_dir, out_dir: Path):
        self.path = write_onnx(model_dir, out_dir)
        self.sess = ort.InferenceSession(str(self.path), providers=["CPUExecutionProvider"])
        self.names = [o.name for o in self.sess.get_outputs()]
        self.wanted = {i.name for i in self.sess.get_inputs()}

    def reset(self, n_axes: int) -> None:
        self.state = reset_state(n_axes)

    def step(self, inputs: dict) -> dict:
        feed = {k: np.asarray(v, dtype=np.float64) for k, v in {**inputs, **self.state}.items()}
        out = dict(zip(self.names, self.sess.run(None, {k: feed[k] for k in self.wanted}),
                       strict=True))  # fmt: skip
        self.state = {k: out[f"next_{k}"] for k in STATE}
        return out


@pytest.fixture(scope="module")
def lm_onnx(tmp_path_factory):
    return OnnxLaw(LM, tmp_path_factory.mktemp("lm_onnx"))


def _parity(law, env, steps, monkeypatch):
    core = env.unwrapped.core
    agent = ResidualAgent(LM).bind(env)
    seen = {}
    real = residual_mod.residual_command

    def capture(*args, **kwargs):
        seen["res"], g = real(*args, **kwargs)
        return seen["res"], g

    monkeypatch.setattr(residual_mod, "residual_command", capture)
    real_base = agent.base.action
    agent.base.action = lambda sig: seen.setdefault("b", [None]).__setitem__(0, real_base(sig)) or (
        seen["b"][0]
    )  # fmt: skip
    env.reset(seed=0)
    agent.reset(np.ones(1, dtype=bool))
    law.reset(core.dim)
    mask = agent._axis_mask()
    worst, opened = 0.0, 0
    for k in range(min(steps, core.n_steps - 1)):
        applied = agent.applied_action(core.signals_batch())
        out = law.step(inputs_from_core(core, mask, np.asarray(seen["b"][0])[0]))
        d = float(np.max(np.abs(out["residual"] - seen["res"][0])))
        assert d <= TOL, f"step {k}: ONNX {out['residual']} vs Python {seen['res'][0]}"
        worst = max(worst, d)
        opened += float(out["gate"][0]) > 0
        _, _, term, trunc, _ = env.step(applied[0])
        if term or trunc:
            break
    return worst, opened


def test_the_graph_is_opset_17_with_the_c_laws_interface(lm_onnx):
    import onnx

    model = onnx.load(str(lm_onnx.path))
    assert model.opset_import[0].version == OPSET >= 17
    names = [i.name for i in model.graph.input]
    assert names[:3] == ["ref_position", "ref_velocity", "ref_acceleration"]
    assert "prev_encoder" in names and "held_action" in names


@pytest.mark.parametrize(
    "kw, steps",
    [
        (dict(case="lm-circle3d"), 20_000),
        (dict(plant="linear-motor", path=CURVED, feedrate_m_s=0.06, max_accel_m_s2=0.5), 10**6),
    ],
)
def test_onnx_residual_equals_the_python_agents_at_every_step(lm_onnx, monkeypatch, kw, steps):
    env = gym.make("contour_env/Contouring-v0", **kw)
    worst, opened = _parity(lm_onnx, env, steps, monkeypatch)
    assert worst <= TOL and opened > 100  # the gate opened: the law was exercised


def test_nan_input_closes_the_gate_and_flags_it(lm_onnx):
    env = gym.make("contour_env/Contouring-v0", plant="linear-motor", path=CURVED,
                   feedrate_m_s=0.06)  # fmt: skip
    env.reset(seed=0)
    core = env.unwrapped.core
    lm_onnx.reset(core.dim)
    x = inputs_from_core(core, np.ones(core.dim), np.full(core.dim, 0.3))
    x["encoder_position"] = np.array([np.nan, 0.0, 0.0])
    out = lm_onnx.step(x)
    assert float(out["bad_input"][0]) == 1.0 and float(out["gate"][0]) == 0.0
    np.testing.assert_array_equal(out["residual"], 0.0)
    np.testing.assert_allclose(out["applied"], 0.3)
    x["encoder_position"] = np.zeros(core.dim)
    x["programmed_feed"] = np.array([-1.0])
    out = lm_onnx.step(x)
    assert float(out["bad_input"][0]) == 1.0 and np.all(out["residual"] == 0.0)


def test_a_kept_base_agent_exports_the_zero_law(tmp_path):
    law = OnnxLaw(FT, tmp_path)
    env = gym.make("contour_env/Contouring-v0", case="sharp-corner")
    env.reset(seed=0)
    core = env.unwrapped.core
    law.reset(core.dim)
    rng = np.random.default_rng(0)
    for _ in range(50):
        base = rng.uniform(-1.5, 1.5, core.dim)
        out = law.step(inputs_from_core(core, np.ones(core.dim), base))
        np.testing.assert_array_equal(out["residual"], 0.0)
        np.testing.assert_array_equal(out["applied"], np.clip(base, -1, 1))
        env.step(np.zeros(core.dim))
