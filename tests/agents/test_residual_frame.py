"""The residual's frame, gate and axis observation (agents.residual_law): the law against an
independent computation, the wrappers against the agent, and the rotation test — a path-frame
agent gives the same RMS contour error on a part rotated by 0°, 30° and 60° on a plant with
no axis effects, where an axes-frame agent does not."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
import torch

import contour_env  # noqa: F401
from agents.registry import make_controller
from agents.residual import ResidualAgent, ResidualVectorWrapper, ResidualWrapper
from agents.residual_law import residual_command
from agents.rl.checkpoint import ObsNormalizer
from contour_env import ENV_ID
from contour_env.evaluation import evaluate, run_episode

SHORT = "G21 G90 G17 G61\nG01 X2 F1200\nG01 Y2\n"
# a blended 3-D part with arcs off the axes for the 0.1 ms linear motor (~9k servo periods)
LM_PART = (
    "G21 G90 G17 G64 P0.01\nG01 X0 Y0 Z0 F3000\nG01 X8 Y3\nG02 X12 Y7 R4\n"
    "G01 X10 Y12 Z1\nG03 X4 Y10 R4\nG01 X0 Y0 Z0\n"
)
# a blended five-leg part, no leg along an axis (mm, before rotation)
PART_MM = np.array([[0, 0], [100, 30], [140, 110], [50, 130], [20, 70]], dtype=float)
ANGLES_DEG = (0.0, 30.0, 60.0)


def _rotated_program(deg: float) -> str:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    pts = PART_MM @ np.array([[c, s], [-s, c]])
    lines = ["G21 G90 G17 G64 P0.01", "G01 X0 Y0 F12000"]
    lines += [f"G01 X{x:.4f} Y{y:.4f}" for x, y in pts[1:]]
    return "\n".join(lines) + "\n"


def _rotation(deg):
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[c, -s], [s, c]])


# --- the law ------------------------------------------------------------------------------


def test_path_frame_residual_is_the_weighted_frame_times_the_norm_limited_action():
    rng = np.random.default_rng(0)
    B, n, scale = 64, 3, 0.05
    # random orthonormal frames (columns t n b)
    frames = np.stack([np.linalg.qr(rng.normal(size=(n, n)))[0] for _ in range(B)])
    a = rng.uniform(-1, 1, size=(B, n))
    a[:8] *= 0.2  # some inside the unit ball, left as they are
    mask = np.array([1.0, 1.0, 0.0])
    w = np.array([1.0, 0.5, 0.8])
    r, g = residual_command(a, frames, scale, mask, "path", gate=False, weights=w)
    unit = a / np.maximum(np.linalg.norm(a, axis=1, keepdims=True), 1.0)
    expected = np.array([scale * w * (F @ u) for F, u in zip(frames, unit, strict=True)])
    np.testing.assert_allclose(r, expected * mask, rtol=0, atol=1e-15)
    assert np.all(np.abs(r) <= scale * w) and np.all(r[:, 2] == 0) and np.all(g == 1)
    # the norm of the push is invariant to the frame: rotating it rotates the residual
    r1, _ = residual_command(a, frames, scale, np.ones(3), "path", False)
    np.testing.assert_allclose(
        np.linalg.norm(r1, axis=1), scale * np.minimum(np.linalg.norm(a, axis=1), 1.0)
    )
    # the axes frame ignores the frame
    r_axes, _ = residual_command(a, frames, scale, mask, "axes", gate=False)
    np.testing.assert_array_equal(r_axes, scale * a * mask)


def test_a_push_along_the_normal_is_the_normal_in_machine_coordinates():
    """2-D: a circle's frame at angle φ has t = (−sin φ, cos φ), n = (−cos φ, −sin φ) (left
    normal, towards the centre for a CCW circle); a = (0, 1) pushes along n."""
    for phi in np.linspace(0, 2 * np.pi, 7):
        t = np.array([-np.sin(phi), np.cos(phi)])
        nrm = np.array([-np.cos(phi), -np.sin(phi)])
        F = np.stack([t, nrm], axis=1)[None]
        r, _ = residual_command(np.array([[0.0, 1.0]]), F, 0.04, np.ones(2), "path", False)
        np.testing.assert_allclose(r[0], 0.04 * nrm, atol=1e-15)


def test_path_weights_make_the_push_the_same_acceleration_on_every_axis():
    from agents.residual_law import path_weights
    from contour_env.plants import Plant

    hsm2 = Plant("hsm2").nominal
    w = path_weights(hsm2)
    accel = w * hsm2.force_limit_N / hsm2.mass_kg  # m/s² per unit of scale · (F â)
    np.testing.assert_allclose(accel, accel[0], rtol=1e-12)
    assert w.max() == 1.0 and 0.8 < w.min() < 0.9
    np.testing.assert_array_equal(path_weights(Plant("jee-triaxial").nominal), np.ones(3))
    np.testing.assert_array_equal(path_weights(Plant("linear-motor").nominal), np.ones(3))


def test_gate_multiplies_the_residual_and_starts_closed_at_zero():
    F = np.eye(2)[None].repeat(4, axis=0)
    a = np.array([[1.0, -1.0, -0.5], [1.0, -1.0, 0.0], [1.0, -1.0, 0.25], [1.0, -1.0, 1.0]])
    r, g = residual_command(a, F, 0.05, np.ones(2), "path", gate=True)
    np.testing.assert_array_equal(g, [0.0, 0.0, 0.25, 1.0])
    np.testing.assert_allclose(r, 0.05 * a[:, :2] / math.sqrt(2) * g[:, None], atol=1e-16)


def test_axis_observation_is_the_reference_velocity_and_acceleration_per_axis():
    from agents.compiled.residual_runner import view_rows

    ref_pav = np.zeros((1, 3, 3))
    ref_pav[0, 1, :2] = [0.01, -0.02]  # m/s
    ref_pav[0, 2, :2] = [0.5, -100.0]  # m/s²
    out = np.full((1, 4), np.nan, dtype=np.float32)
    no_fields = np.zeros(0, dtype=np.int64)
    obs = np.zeros((1, 1), dtype=np.float32)
    view_rows(2, obs, ref_pav, np.zeros((1, 3, 3)), no_fields, False, True, 0.02, 0.5, 10.0, out)
    np.testing.assert_allclose(out, [[0.5, -1.0, 1.0, -10.0]], rtol=1e-6)


# --- wrappers and agent ---------------------------------------------------------------------


class Zero:
    def __init__(self, n):
        self.n = n

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        return np.zeros(self.n, dtype=np.float32), state


@pytest.mark.parametrize("gate", [False, True])
def test_zero_action_in_the_path_frame_is_the_base_exactly(gate):
    kw = dict(plant="friction-table", path=SHORT)
    base = evaluate(gym.make(ENV_ID, **kw), make_controller("ccc"))
    w = ResidualWrapper(
        gym.make(ENV_ID, **kw), "ccc", residual_frame="path", gate=gate, observe_axes=True
    )
    assert w.action_space.shape == (3 if gate else 2,)
    assert w.observation_space.shape == (w.core.obs_dim + 4,)
    assert evaluate(w, Zero(w.action_space.shape[0])) == base


def test_gate_closed_is_the_base_whatever_the_push():
    kw = dict(plant="friction-table", path=SHORT)
    base = evaluate(gym.make(ENV_ID, **kw), make_controller("ccc"))

    class Closed:
        def predict(self, obs, state=None, episode_start=None, deterministic=True):
            return np.array([1.0, -1.0, -0.3], dtype=np.float32), state

    w = ResidualWrapper(gym.make(ENV_ID, **kw), "ccc", residual_frame="path", gate=True)
    assert evaluate(w, Closed()) == base


def test_path_frame_vector_wrapper_matches_the_single_wrapper():
    rng = np.random.default_rng(3)
    kw = dict(plant="friction-table", path=SHORT)
    opts = dict(residual_frame="path", gate=True, observe_axes=True, action_repeat=2)
    single = ResidualWrapper(gym.make(ENV_ID, **kw), "ccc", residual_penalty=1.0, **opts)
    venv = gym.make_vec(ENV_ID, num_envs=1, vectorization_mode="vector_entry_point", **kw)
    vec = ResidualVectorWrapper(venv, "ccc", residual_penalty=1.0, **opts)
    o1, _ = single.reset(seed=5)
    o2, _ = vec.reset(seed=5)
    np.testing.assert_array_equal(o1, o2[0])
    for _ in range(60):
        a = rng.uniform(-1, 1, size=3).astype(np.float32)
        o1, r1, *_, i1 = single.step(a)
        o2, r2, *_, i2 = vec.step(a[None])
        np.testing.assert_array_equal(o1, o2[0])
        assert r1 == pytest.approx(r2[0], rel=1e-12)
        np.testing.assert_allclose(i1["residual_action"], i2["residual_action"][0], atol=1e-15)
        assert np.all(np.abs(i1["residual_action"]) <= 0.05 + 1e-12)
        if i1["gate"] > 0:  # friction-table: w = (1, 0.98); the push is at most the scale
            assert np.linalg.norm(i1["residual_action"]) <= 0.05 * i1["gate"] + 1e-12


def _random_agent(
    env_kw, base, residual_frame, *, gain=8.0, seed=0, observe_axes=False, gate=False
):
    """An untrained agent with seeded random weights, its output layer amplified so that the
    residual is of the order of its authority (what any trained network may do)."""
    from stable_baselines3 import SAC

    w = ResidualWrapper(
        gym.make(ENV_ID, **env_kw),
        base,
        residual_frame=residual_frame,
        observe_axes=observe_axes,
        gate=gate,
    )
    torch.manual_seed(seed)
    model = SAC("MlpPolicy", w, seed=seed, device="cpu", policy_kwargs={"net_arch": [32, 32]})
    with torch.no_grad():
        model.policy.actor.mu.weight.mul_(gain)
    n_obs = w.observation_space.shape[0]
    meta = {
        "plant": w.core.setup.plant.name,
        "n_axes": w.n_axes,
        "obs_dim": n_obs,
        "algo": "sac",
        "base": base,
        "scale": w.scale,
        "observe_base_command": False,
        "observation": "full",
        "action_repeat": w.action_repeat,
        "residual_axes": "path",
        "residual_frame": residual_frame,
        "gate": gate,
        "observe_axes": observe_axes,
    }
    norm = ObsNormalizer(np.zeros(n_obs), np.ones(n_obs), 10.0, 0.0)
    return ResidualAgent.from_parts(meta, model, norm)


def test_agent_equals_the_wrapper_in_the_path_frame():
    kw = dict(plant="friction-table", path=SHORT)
    agent = _random_agent(kw, "ccc", "path", observe_axes=True)
    r_agent = run_episode(gym.make(ENV_ID, **kw), agent, seed=2)
    w = ResidualWrapper(gym.make(ENV_ID, **kw), "ccc", residual_frame="path", observe_axes=True)

    class Model:
        def predict(self, obs, state=None, episode_start=None, deterministic=True):
            return agent._actor(agent.norm(obs[None]))[0], state

    r_wrap = run_episode(w, Model(), seed=2)
    np.testing.assert_array_equal(r_agent.force, r_wrap.force)
    np.testing.assert_array_equal(r_agent.contour_error, r_wrap.contour_error)


def _rms_over_rotations(agent_frame, observe_axes=False, ideal=True):
    out = []
    for deg in ANGLES_DEG:
        kw = dict(plant="hsm2", path=_rotated_program(deg), ideal=ideal, feedrate_m_s=0.2)
        agent = _random_agent(kw, "ccc", agent_frame, observe_axes=observe_axes)
        out.append(evaluate(gym.make(ENV_ID, **kw), agent)["rms_contour_error_um"])
    return np.array(out)


def _spread(x):
    return (x.max() - x.min()) / x.mean()


def test_rotation_a_path_frame_agent_is_the_same_on_a_rotated_part_without_axis_effects():
    """hsm2 with ideal=True (no friction or ripple; the PD/CCC gains place the same poles on
    both axes): the base's RMS varies 0.3 % over the rotations; a path-frame agent's within
    5 %, while the same network acting on the machine axes varies far more."""
    base = []
    for deg in ANGLES_DEG:
        kw = dict(plant="hsm2", path=_rotated_program(deg), ideal=True, feedrate_m_s=0.2)
        m = evaluate(gym.make(ENV_ID, **kw), make_controller("ccc"))
        base.append(m["rms_contour_error_um"])
    base = np.array(base)
    path = _rms_over_rotations("path")
    axes = _rms_over_rotations("axes")
    assert _spread(base) < 0.01
    # the agent changes the result (a residual that does nothing would pass trivially)
    assert np.all(np.abs(path / base - 1) > 0.05)
    assert _spread(path) < 0.05, path
    assert _spread(axes) > 3 * _spread(path), (axes, path)
    print("rotation RMS µm: base", base, "path", path, "axes", axes)


@pytest.mark.parametrize(
    "plant, path, frame, gate",
    [
        ("friction-table", "star_exact_stop.nc", "path", True),
        ("friction-table", SHORT, "axes", False),
        ("linear-motor", LM_PART, "path", False),
    ],
)
def test_compiled_agent_episode_equals_the_python_loop_to_the_bit(plant, path, frame, gate):
    from agents.rl.heldout import HELDOUT_DIR

    if path.endswith((".nc", ".ngc")):
        path = str(HELDOUT_DIR / path)
    kw = dict(plant=plant, path=path)
    agent = _random_agent(kw, "ccc", frame, observe_axes=True, gain=3.0, gate=gate)
    assert agent.bind(gym.make(ENV_ID, **kw)).compiled_form() is not None
    rc = run_episode(gym.make(ENV_ID, **kw), agent, seed=1)
    rp = run_episode(gym.make(ENV_ID, **kw), agent, seed=1, compiled=False)
    assert len(rc.contour_error) == len(rp.contour_error) > 100
    np.testing.assert_array_equal(rc.contour_error, rp.contour_error)
    np.testing.assert_array_equal(rc.force, rp.force)
    np.testing.assert_array_equal(rc.position, rp.position)


def test_fade_at_rest_is_no_residual_while_the_reference_stands_still():
    """A G04 dwell and the settle at the end: the reference's speed is 0, the residual too;
    it is full from 5 % of the feed on."""
    from agents.residual_law import rest_fade

    np.testing.assert_array_equal(rest_fade([0.0, 0.0005, 0.001, 0.02], 0.001), [0, 0.5, 1, 1])
    np.testing.assert_array_equal(rest_fade([0.0, 0.3], 0.0), [1.0, 1.0])
    prog = "G21 G90 G17 G61\nG01 X2 F1200\nG04 P0.3\nG01 Y2\n"
    kw = dict(plant="friction-table", path=prog)
    w = ResidualWrapper(gym.make(ENV_ID, **kw), "ccc", residual_frame="path", fade_at_rest=True)
    w.reset(seed=0)
    at_rest, moving = [], []
    done = False
    while not done:
        speed = float(w.core.signals_batch()["feedrate"][0])
        _, _, term, trunc, info = w.step(np.array([1.0, 0.0], dtype=np.float32))
        (at_rest if speed == 0 else moving).append(np.abs(info["residual_action"]).max())
        done = term or trunc
    assert len(at_rest) > 300 and max(at_rest) == 0.0  # the dwell and the settle
    assert max(moving) == pytest.approx(0.05 * 1.0, rel=0.05)  # friction-table: w = (1, 0.98)


def test_compiled_agent_with_fade_at_rest_equals_the_python_loop():
    from agents.rl.heldout import HELDOUT_DIR

    kw = dict(plant="friction-table", path=str(HELDOUT_DIR / "slot_fillets.nc"))
    agent = _random_agent(kw, "ccc", "path", observe_axes=True, gain=3.0)
    agent.fade_at_rest = True
    rc = run_episode(gym.make(ENV_ID, **kw), agent, seed=1)
    assert agent._v_rest == pytest.approx(0.05 * agent._core.setup.feedrate_m_s)
    rp = run_episode(gym.make(ENV_ID, **kw), agent, seed=1, compiled=False)
    np.testing.assert_array_equal(rc.contour_error, rp.contour_error)
    np.testing.assert_array_equal(rc.force, rp.force)


@pytest.mark.parametrize(
    "case_kw, frame, observe_axes",
    [
        # lm-circle3d at 5x its feed: the case's 3-D circle in 32k servo periods (159k at 1x)
        (dict(case="lm-circle3d", feedrate_m_s=0.25), "path", True),
        (dict(case="jee-circle3d"), "axes", True),
        (dict(plant="friction-table", path=SHORT), "path", False),
    ],
)
def test_compiled_agent_input_is_the_numpy_view_and_normaliser_to_the_bit(
    case_kw, frame, observe_axes
):
    """agent_input (what the compiled evaluation builds per agent step) against
    agent.norm(agent._view(...)) at every sample of an episode, with observation statistics
    far from (0, 1); then the episodes through both paths are the same to the bit."""
    from agents.compiled.residual_runner import agent_input

    agent = _random_agent(case_kw, "ccc", frame, observe_axes=observe_axes, gain=3.0, gate=True)
    n_obs = int(agent.meta["obs_dim"])
    rng = np.random.default_rng(7)
    agent.norm = ObsNormalizer(
        rng.normal(0.0, 0.3, n_obs), rng.uniform(0.01, 4.0, n_obs), 5.0, 1e-8
    )
    env = gym.make(ENV_ID, **case_kw)
    agent.bind(env)
    env.reset(seed=3)
    form = agent.compiled_form()
    core = env.unwrapped.core
    form.begin(core)
    fast = form.input_args()
    assert fast is not None
    n, ended, checked = 0, 0, 0
    from contour_env.env.rollout import empty_record

    rec = empty_record(core)
    recs = tuple(rec[k] for k in ("time", "contour_error", "position", "reference", "force"))
    while not ended and checked < 400:
        want = agent.norm(agent._view(core.obs[:1], core.signals_batch(), None))
        agent_input(*fast)
        np.testing.assert_array_equal(fast[-1], want)
        a = rng.uniform(-1, 1, agent._actor(want).shape[1])
        n, bad, ended = form.advance(a, n, recs)
        assert not bad
        checked += 1
    form.finish()
    assert checked == 400
    rc = run_episode(gym.make(ENV_ID, **case_kw), agent, seed=1)
    rp = run_episode(gym.make(ENV_ID, **case_kw), agent, seed=1, compiled=False)
    np.testing.assert_array_equal(rc.contour_error, rp.contour_error)
    np.testing.assert_array_equal(rc.force, rp.force)
