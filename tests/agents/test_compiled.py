"""The compiled controller laws and fused episode loop (agents.compiled, contour_env.env.rollout)
against the Python path: identical records, scores and controller state."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from agents import make_controller
from agents.pd import PDController
from contour_env import ENV_ID
from contour_env.cases import case_names
from contour_env.env import rollout
from contour_env.evaluation import evaluate, run_episode
from tests.agents import numpy_laws

TOL = 1e-12
LONG_CASE = "lm-circle3d"  # 159k steps: the full episode is run for pd only


def _both(spec, seed=0, **env_kwargs):
    """The fused compiled loop against the Python env path with the law's independent NumPy
    reference (tests/agents/numpy_laws.py) on the controller."""
    env = gym.make(ENV_ID, **env_kwargs)
    c_fast, c_py = make_controller(spec), numpy_laws.patch(make_controller(spec))
    fast = run_episode(env, c_fast, seed=seed)
    py = run_episode(env, c_py, seed=seed, compiled=False)
    return fast, py, c_fast, c_py


def _assert_same(fast, py):
    assert fast.time.shape == py.time.shape
    assert fast.termination_reason == py.termination_reason
    for name in ("time", "contour_error", "force", "position", "reference", "tracking_error"):
        a, b = getattr(fast, name), getattr(py, name)
        assert np.max(np.abs(a - b), initial=0.0) <= TOL, name
    np.testing.assert_array_equal(fast.saturated, py.saturated)


def _cases_for(spec):
    if spec.startswith("jee-ccc"):
        return ["jee-circle3d"]
    return [c for c in case_names() if c != LONG_CASE]


@pytest.mark.parametrize(
    ("spec", "case"),
    [(s, c) for s in ("pd", "ccc", "adaptive-ccc", "jee-ccc") for c in _cases_for(s)],
)
def test_compiled_matches_python_on_named_cases(spec, case):
    fast, py, _, _ = _both(spec, case=case, seed=1)
    _assert_same(fast, py)
    assert fast.time.size == fast.n_steps_planned or fast.termination_reason is not None


@pytest.mark.parametrize("spec", ["ccc", "adaptive-ccc"])
def test_compiled_matches_python_on_the_long_case_shortened(spec):
    # lm-circle3d at 5× its feed (a shorter episode, the same plant and path)
    fast, py, _, _ = _both(spec, case=LONG_CASE, feedrate_m_s=0.25)
    _assert_same(fast, py)


def test_compiled_full_long_episode_pd():
    fast, py, _, _ = _both("pd", case=LONG_CASE)
    assert fast.time.size == 159151
    _assert_same(fast, py)


@pytest.mark.parametrize(
    "spec",
    [
        "pd:w=60:zeta=0.8",
        "pd:p=2e6/1e6:d=1e4/5e3",
        "ccc:wi=0",
        "ccc:wp=3e4:wd=20",
        "adaptive-ccc:gamma=0",
        "adaptive-ccc:friction=false:norm=false:vmatch=false",
        "adaptive-ccc:kv_rho=2e4/1e5",
        "adaptive-ccc:gamma_m=2:c=100/200",
    ],
)
def test_compiled_variants(spec):
    fast, py, _, _ = _both(spec, case="hsm2-circle-III")
    _assert_same(fast, py)


@pytest.mark.parametrize("spec", ["jee-ccc:kp=0.5:cp=1:ci=3:cd=0.1", "adaptive-ccc:gamma=3"])
def test_compiled_variants_3d(spec):
    fast, py, _, _ = _both(spec, case="jee-circle3d")
    _assert_same(fast, py)


@pytest.mark.parametrize("spec", ["pd", "ccc", "adaptive-ccc"])
def test_compiled_structural_mode(spec):
    fast, py, _, _ = _both(spec, case="hsm2-circle-II", structural_mode=True)
    _assert_same(fast, py)


def test_noise_and_random_phase_seeds():
    # corner-blend: encoder noise and a random disturbance phase, drawn from the episode seed
    for seed in (0, 7):
        fast, py, _, _ = _both("ccc", case="corner-blend", seed=seed)
        _assert_same(fast, py)


def test_scores_identical_and_state_written_back():
    env = gym.make(ENV_ID, case="hsm2-circle-I")
    a, b = make_controller("adaptive-ccc"), make_controller("adaptive-ccc")
    assert evaluate(env, a) == evaluate(env, b, compiled=False)
    np.testing.assert_array_equal(a.theta_hat, b.theta_hat)
    c, d = make_controller("ccc"), make_controller("ccc")
    run_episode(env, c)
    run_episode(env, d, compiled=False)
    for name in ("_prev", "_integral", "_started", "_tangent", "_corner", "_holding"):
        np.testing.assert_array_equal(getattr(c, name), getattr(d, name))
    # the env ends in the same state either way
    run_episode(env, make_controller("pd"))
    z_fast = env.unwrapped.core.z.copy()
    run_episode(env, make_controller("pd"), compiled=False)
    np.testing.assert_array_equal(z_fast, env.unwrapped.core.z)


def test_unstable_run_terminates_identically():
    fast, py, _, _ = _both("pd:p=1e9:d=0", case="hsm2-circle-III")
    assert py.termination_reason is not None
    _assert_same(fast, py)


def test_fallback_to_python(monkeypatch):
    env = gym.make(ENV_ID, case="hsm2-circle-III")
    # no compiled form: learning controllers and a subclass that may change the law
    for policy in (make_controller("vilcfd"), make_controller("ilc-pd")):
        policy.bind(env)
        assert rollout.compiled_form_of(policy) is None
        assert rollout.try_compiled_episode(env, policy, 0) is None

    class Custom(PDController):
        def act(self, signals):
            return 0.5 * super().act(signals)

    custom = Custom().bind(env)
    assert rollout.compiled_form_of(custom) is None
    # an ``act`` patched on the instance (tracing) is honoured
    traced = make_controller("pd").bind(env)
    calls = []
    act = traced.act
    traced.act = lambda signals: calls.append(1) or act(signals)
    assert rollout.compiled_form_of(traced) is None
    run_episode(env, traced)
    assert len(calls) > 0
    r_custom = run_episode(env, Custom())
    r_pd = run_episode(env, make_controller("pd"))
    assert not np.array_equal(r_custom.force, r_pd.force)
    # a wrapper that may change steps, or rendering: the Python path
    wrapped = gym.wrappers.RecordEpisodeStatistics(env)
    assert rollout.try_compiled_episode(wrapped, make_controller("pd"), 0) is None
    rendering = gym.make(ENV_ID, case="hsm2-circle-III", render_mode="rgb_array")
    assert rollout.try_compiled_episode(rendering, make_controller("pd"), 0) is None


def test_forcing_the_python_path(monkeypatch):
    env = gym.make(ENV_ID, case="hsm2-circle-III")
    called = []
    real = rollout.try_compiled_episode

    def spy(*args):
        called.append(1)
        return real(*args)

    import contour_env.evaluation as ev

    monkeypatch.setattr(ev, "try_compiled_episode", spy)
    run_episode(env, make_controller("pd"), compiled=False)
    monkeypatch.setenv(rollout.ENV_VAR, "0")
    run_episode(env, make_controller("pd"))
    assert called == []
    monkeypatch.delenv(rollout.ENV_VAR)
    run_episode(env, make_controller("pd"))
    assert called == [1]


@pytest.mark.parametrize(
    ("spec", "case"), [("ccc", "hsm2-circle-III"), ("jee-ccc", "jee-circle3d")]
)
@pytest.mark.slow  # the parallel loop's first compile takes minutes
def test_robustness_batch_compiled_matches_python(spec, case, monkeypatch):
    from agents.compare import BATCH_ENV_VAR, robustness

    monkeypatch.setenv(BATCH_ENV_VAR, "1")
    fast = robustness([spec], 0.2, 6, case=case, traces=True)[0]
    monkeypatch.setenv(rollout.ENV_VAR, "0")
    py = robustness([spec], 0.2, 6, case=case, traces=True)[0]
    for key in fast:
        if key != "traces":
            assert fast[key] == py[key], key
    for key in ("time_s", "contour_error_m"):
        np.testing.assert_array_equal(fast["traces"][key], py["traces"][key])


def test_a_step_patched_on_the_env_instance_takes_the_python_path():
    """A caller that records rewards by patching ``env.step`` must see every step."""
    env = gym.make(ENV_ID, case="sharp-corner")
    calls = []
    step = env.step

    def recording_step(action):
        calls.append(1)
        return step(action)

    env.step = recording_step
    record = run_episode(env, make_controller("pd"), seed=0)
    assert len(calls) == len(record.contour_error) > 1000


@pytest.mark.parametrize(
    ("spec", "case"),
    [("pd", "hsm2-circle-III"), ("ccc", "corner-blend"), ("adaptive-ccc", "hsm2-circle-I"),
     ("jee-ccc", "jee-circle3d"), ("fnn", "sharp-corner"), ("rfnn:margin=1", "corner-blend")],
)  # fmt: skip
def test_one_definition_of_each_law_serves_both_paths(spec, case, monkeypatch):
    """The Python ``act`` runs the compiled law (:func:`agents.compiled.laws.act_rows` around
    :func:`agents.compiled.laws.law`), the fused loop runs the same ``law``; both equal the
    NumPy reference to the bit."""
    import agents.compiled.forms as forms
    from agents.compiled import laws, runner

    calls = []
    real = laws.act_rows

    def spy(*args):
        calls.append(args[0])
        return real(*args)

    monkeypatch.setattr(forms.L, "act_rows", spy)
    env = gym.make(ENV_ID, case=case)
    c = make_controller(spec)
    py = run_episode(env, c, seed=3, compiled=False)
    kind = forms.compiled_form(c).kind
    assert len(calls) == py.time.size and set(calls) == {kind}
    # the fused loop's law is the same compiled function
    assert runner.law is laws.law
    assert "law" in runner._run_single.py_func.__code__.co_names
    fast = run_episode(env, make_controller(spec), seed=3)
    ref = run_episode(env, numpy_laws.patch(make_controller(spec)), seed=3, compiled=False)
    _assert_same(fast, py)
    _assert_same(py, ref)
    np.testing.assert_array_equal(py.contour_error, ref.contour_error)


def test_the_law_refuses_signals_it_needs_and_lacks():
    env = gym.make(ENV_ID, case="hsm2-circle-III")
    env.reset(seed=0)
    c = make_controller("adaptive-ccc").bind(env)
    signals = env.unwrapped.core.signals_batch()
    del signals["curvature"]
    with pytest.raises(ValueError, match="signals: missing curvature"):
        c.act(signals)
    pd = make_controller("pd").bind(env)
    minimal = {k: signals[k] for k in numpy_laws.PD_SIGNALS}
    np.testing.assert_array_equal(pd.act(minimal), numpy_laws.pd(pd, minimal))
