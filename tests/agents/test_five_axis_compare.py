"""``compare`` on the five-axis cases (issue 16 acceptance): joint PD against the
equivalent-error ISMC of Chen, Khong & Hsieh (2022), tool-tip contour error and orientation
error.

The paper simulates its own model (no friction, delay, current lag or mismatch): with
``ideal=True`` ISMC beats PD by more than 10× on both errors on both cases (asserted), and
so it does on the realistic plant (the default; asserted too, docs/FIVE_AXIS.md's table)."""

import numpy as np
import pytest

from agents.compare import compare, format_table

CASES = ("five-axis-line", "five-axis-circle")
# Chen 2022 §4 text (RMS; the paper has Tables 1–2 only): tool-tip contour error µm,
# orientation error arc-seconds
PAPER = {
    "five-axis-line": {"pd": (330.7, 145.3), "ismc": (2.9, 4.8)},
    "five-axis-circle": {"pd": (668.4, 649.5), "ismc": (17.9, 2.8)},
}


def _rms(result, name):
    row = next(r for r in result["results"] if r["controller"] == name)
    return row, row["rms_contour_error_um"], row["rms_orientation_error_arcsec"]


@pytest.mark.parametrize("case", CASES)
def test_ismc_beats_pd_tenfold_on_the_papers_model(case):
    result = compare(["pd", "ismc"], case=case, ideal=True)
    table = format_table(result)
    assert "RMS θ ″" in table and "max θ ″" in table
    pd, pd_eps, pd_theta = _rms(result, "pd")
    ismc, ismc_eps, ismc_theta = _rms(result, "ismc")
    print(f"\n{table}\npaper: {PAPER[case]}")
    assert pd["completed"] and ismc["completed"]
    for row in (pd, ismc):
        assert row["max_orientation_error_arcsec"] >= row["rms_orientation_error_arcsec"] > 0
    assert ismc_eps <= 0.1 * pd_eps
    assert ismc_theta <= 0.1 * pd_theta


@pytest.mark.parametrize("case", CASES)
def test_ismc_beats_pd_tenfold_on_the_realistic_plant(case):
    # the realistic plant (default): friction, current lag, one-period computation delay,
    # +20 % table inertia. The default ISMC (Table 2 gains) predicts over its own delay with
    # the nominal model and weights the tangential error by dξ_d/ds (ṡ + F), F the peak feed
    result = compare(["pd", "ismc"], case=case)
    print(f"\n{format_table(result)}\npaper: {PAPER[case]}")
    pd, pd_eps, pd_theta = _rms(result, "pd")
    ismc, ismc_eps, ismc_theta = _rms(result, "ismc")
    assert pd["termination_reason"] is None and ismc["completed"]
    assert np.isfinite([pd_eps, pd_theta, ismc_eps, ismc_theta]).all()
    assert ismc_eps <= 0.1 * pd_eps
    assert ismc_theta <= 0.1 * pd_theta
    # no chattering near the drive limits (8, 10, 12 kN, 1.5, 0.6 kN·m): the RMS command
    # stays at what the path and gravity need (z carries the spindle head's ~4.4 kN)
    limits = np.array([8000.0, 10000.0, 12000.0, 1500.0, 600.0])
    assert np.all(np.asarray(ismc["rms_effort"]) < 0.5 * limits)


def test_orientation_metrics_in_arcsec():
    from contour_env.metrics import EpisodeRecord, score

    n = 4
    theta = np.array([0.0, 1e-5, -2e-5, 1e-5])  # rad
    rec = EpisodeRecord(
        time=np.arange(1, n + 1) * 1e-3,
        contour_error=np.full(n, 1e-6),
        tracking_error=np.zeros((n, 3)),
        force=np.zeros((n, 5)),
        saturated=np.zeros((n, 5), bool),
        position=np.zeros((n, 5)),
        reference=np.zeros((n, 5)),
        force_limit=np.ones(5),
        orientation_error=theta,
    )
    m = score(rec)
    arcsec = 180 * 3600 / np.pi
    assert m["max_orientation_error_arcsec"] == pytest.approx(2e-5 * arcsec)
    assert m["rms_orientation_error_arcsec"] == pytest.approx(np.sqrt(np.mean(theta**2)) * arcsec)
    plain = score(EpisodeRecord(**{**rec.__dict__, "orientation_error": None}))
    assert "rms_orientation_error_arcsec" not in plain


def test_five_axis_controllers_follow_the_policy_protocol():
    import gymnasium as gym

    from agents.registry import make_controller
    from contour_env import ENV_ID

    env = gym.make(ENV_ID, case="five-axis-line")
    for name in ("pd", "ismc"):
        c = make_controller(name, plant_family="five-axis").bind(env)
        obs, _ = env.reset(seed=0)
        a, state = c.predict(obs, episode_start=np.ones(1, bool))
        assert a.shape == (5,) and a.dtype == np.float32 and state is None
        u = c.command(env.unwrapped.signals())  # the residual-base interface
        assert u.shape == (1, 5) and np.all(np.isfinite(u))
    venv = gym.make_vec(
        ENV_ID, num_envs=2, vectorization_mode="vector_entry_point", case="five-axis-line"
    )
    c = make_controller("ismc", plant_family="five-axis").bind(venv)
    obs, _ = venv.reset(seed=0)
    a, _ = c.predict(obs)
    assert a.shape == (2, 5) and np.array_equal(a[0], a[1])
