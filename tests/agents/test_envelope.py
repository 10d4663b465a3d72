"""The envelope (agents.envelope): the fade is 1 inside the training ranges, 0 from 25 % beyond
them, linear between; the compiled factor equals the NumPy one; an agent whose envelope excludes
a part is its base there, to the bit, on the Python and the compiled loop."""

from __future__ import annotations

import json
import shutil

import gymnasium as gym
import numpy as np
import pytest

import contour_env  # noqa: F401
from agents.envelope import Envelope, envelope_factor, feature_names, features_of_core
from agents.registry import make_controller
from agents.residual import ResidualAgent
from agents.rl.models import shipped_model_for
from contour_env import ENV_ID
from contour_env.evaluation import evaluate, run_episode


def test_fade_is_one_inside_zero_beyond_the_margin_and_linear_between():
    env = Envelope(2, hi=[0.02, 100, 0.02, 0.02, 0.5, 0.5, 1e-4, 1e-4], margin=0.25)
    rows = np.zeros((5, 8))
    rows[0, 0] = 0.02  # at the bound
    rows[1, 0] = 0.02 * 1.125  # half-way into the margin
    rows[2, 0] = 0.02 * 1.25  # at its end
    rows[3, 1] = 1e6  # far beyond on the curvature
    rows[4, 6] = -0.5e-4  # a negative error inside: |x| counts
    np.testing.assert_allclose(env.factor(rows), [1.0, 0.5, 0.0, 0.0, 1.0], atol=1e-12)


def test_update_widens_and_ignores_non_finite_rows():
    env = Envelope(2)
    env.update(np.array([[1.0] * 8, [2.0] * 7 + [np.nan]]))
    np.testing.assert_array_equal(env.hi, np.ones(8))
    env.update(np.full((1, 8), 3.0))
    np.testing.assert_array_equal(env.hi, np.full(8, 3.0))


def test_round_trip_and_clear_errors():
    env = Envelope(3, hi=np.arange(11, dtype=float))
    again = Envelope.from_dict(json.loads(json.dumps(env.to_dict())), 3)
    np.testing.assert_array_equal(again.hi, env.hi)
    assert list(env.to_dict()["upper_bounds"]) == feature_names(3)
    d = env.to_dict()
    d["upper_bounds"]["feed_m_s"] = -1.0
    with pytest.raises(ValueError, match="feed_m_s: must be >= 0"):
        Envelope.from_dict(d, 3)
    d["upper_bounds"]["feed_m_s"] = float("nan")
    with pytest.raises(ValueError, match="feed_m_s: must be a finite number"):
        Envelope.from_dict(d, 3)
    with pytest.raises(ValueError, match="upper_bounds must hold exactly"):
        Envelope.from_dict(env.to_dict(), 2)
    with pytest.raises(ValueError, match="expected an object with format"):
        Envelope.from_dict([1, 2], 2)
    d = env.to_dict()
    d["margin"] = 0
    with pytest.raises(ValueError, match="margin: must be a number > 0"):
        Envelope.from_dict(d, 3)


def test_compiled_factor_equals_the_numpy_one_along_an_episode():
    env = gym.make(ENV_ID, case="corner-blend")
    core = env.unwrapped.core
    fence = Envelope(2, hi=[0.015, 50.0, 0.012, 0.012, 0.3, 0.3, 5e-6, 5e-6])
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    for _ in range(400):
        env.step(rng.uniform(-0.01, 0.01, 2).astype(np.float32))
        f_np = fence.factor(features_of_core(core))[0]
        f_nb = envelope_factor(
            2, core.k, int(core.n_steps), core.scal, core.ref_pav, core.obs,
            float(core.config.error_obs_scale_m), fence.bounds(), fence.margin, 1.0,
        )  # fmt: skip
        assert f_nb == pytest.approx(f_np, abs=1e-12)


def _agent_with(tmp_path, hi):
    src = shipped_model_for("friction-table")
    d = tmp_path / "agent"
    shutil.copytree(src, d)
    meta = json.loads((d / "agent.json").read_text())
    # the shipped network as a trained agent (whatever the release gate decided for it)
    meta["kept"] = "best-validation"
    meta.pop("release", None)
    meta["envelope"] = Envelope(2, hi=hi).to_dict()
    (d / "agent.json").write_text(json.dumps(meta))
    return d


@pytest.mark.parametrize("compiled", [True, False])
def test_an_agent_outside_its_envelope_is_its_base_to_the_bit(tmp_path, compiled):
    d = _agent_with(tmp_path, np.full(8, 1e-9))
    kw = {"plant": "friction-table", "path": "G21 G90 G64 P0.01\nG01 X6 Y2 F1200\nG01 Y6\n"}
    agent = ResidualAgent(d)
    rec = run_episode(gym.make(ENV_ID, **kw), agent, compiled=compiled)
    base = run_episode(gym.make(ENV_ID, **kw), make_controller("ccc"), compiled=compiled)
    np.testing.assert_array_equal(rec.contour_error, base.contour_error)
    # every decision but those at rest at the start (every input 0: inside)
    assert 0.99 < agent.outside_envelope_fraction() < 1.0
    m = evaluate(gym.make(ENV_ID, **kw), agent, compiled=compiled)
    assert m["outside_envelope_fraction"] == agent.outside_envelope_fraction()


def test_a_wide_envelope_changes_nothing_and_both_loops_agree(tmp_path):
    d = _agent_with(tmp_path, np.full(8, 1e9))
    kw = {"case": "sharp-corner"}
    plain_dir = _agent_with(tmp_path / "plain", np.zeros(8))
    meta = json.loads((plain_dir / "agent.json").read_text())
    meta["envelope"] = None
    (plain_dir / "agent.json").write_text(json.dumps(meta))
    plain = ResidualAgent(plain_dir)
    wide = ResidualAgent(d)
    a = run_episode(gym.make(ENV_ID, **kw), plain)
    b = run_episode(gym.make(ENV_ID, **kw), wide)
    c = run_episode(gym.make(ENV_ID, **kw), wide, compiled=False)
    np.testing.assert_array_equal(a.contour_error, b.contour_error)
    np.testing.assert_array_equal(b.contour_error, c.contour_error)
    assert wide.outside_envelope_fraction() == 0.0
    assert plain.outside_envelope_fraction() is None


def test_the_programmed_feed_has_a_lower_and_an_upper_bound():
    env = Envelope(2, hi=np.full(8, 1.0), margin=0.25)
    rows = np.zeros((1, 8))
    assert env.factor(rows, 0.001)[0] == 1.0  # no range recorded: not checked
    for f in (0.02, 0.04, 0.03):
        env.update_feed(f)
    assert env.feed_range == (0.02, 0.04)
    # inside, 12.5 % below and above (half-way into the margin), 25 % beyond
    assert env.factor(rows, 0.03)[0] == 1.0
    assert env.factor(rows, 0.02 / 1.125)[0] == pytest.approx(0.5)
    assert env.factor(rows, 0.04 * 1.125)[0] == pytest.approx(0.5)
    assert env.factor(rows, 0.04 * 1.25)[0] == 0.0 and env.factor(rows, 0.01)[0] == 0.0
    again = Envelope.from_dict(json.loads(json.dumps(env.to_dict())), 2)
    assert again.feed_range == (0.02, 0.04)
    d = env.to_dict()
    d["programmed_feed_m_s"] = [0.05, 0.01]
    with pytest.raises(ValueError, match="programmed_feed_m_s must be"):
        Envelope.from_dict(d, 2)


def test_a_part_programmed_outside_the_trained_feeds_is_run_by_the_base(tmp_path):
    d = _agent_with(tmp_path, np.full(8, 1e9))
    meta = json.loads((d / "agent.json").read_text())
    meta["envelope"]["programmed_feed_m_s"] = [0.03, 0.04]  # the part below runs at 0.02
    (d / "agent.json").write_text(json.dumps(meta))
    kw = {"plant": "friction-table", "path": "G21 G90 G64 P0.01\nG01 X6 Y2 F1200\nG01 Y6\n"}
    agent = ResidualAgent(d)
    rec = run_episode(gym.make(ENV_ID, **kw), agent)
    base = run_episode(gym.make(ENV_ID, **kw), make_controller("ccc"))
    np.testing.assert_array_equal(rec.contour_error, base.contour_error)
    assert agent.outside_envelope_fraction() == 1.0
