"""Classical controllers: the paper's ordering on HSM2, stability on every case, bad gains."""

import json

import gymnasium as gym
import numpy as np
import pytest

import contour_env  # noqa: F401
from agents import make_controller
from agents.compare import compare, robustness
from contour_env import ENV_ID
from contour_env.app.cli import main
from contour_env.cases import CASES
from contour_env.evaluation import evaluate


@pytest.mark.parametrize("case", ["hsm2-circle-I", "hsm2-circle-II", "hsm2-circle-III"])
def test_lee_2012_ordering_and_effort_on_hsm2_circles(case):
    res = {r["controller"]: r for r in compare(["pd", "ccc", "adaptive-ccc"], case=case)["results"]}
    rms = {k: v["rms_contour_error_um"] for k, v in res.items()}
    assert rms["adaptive-ccc"] < rms["ccc"] < rms["pd"]
    pd_effort = np.asarray(res["pd"]["rms_effort"])
    for name in ("ccc", "adaptive-ccc"):
        ratio = np.asarray(res[name]["rms_effort"]) / pd_effort
        assert np.all(np.abs(ratio - 1) <= 0.10), (name, ratio)


def _applies(controller, case):
    return controller != "jee-ccc" or CASES[case].plant == "jee-triaxial"


@pytest.mark.parametrize("case", list(CASES))
@pytest.mark.parametrize("controller", ["pd", "ccc", "adaptive-ccc", "jee-ccc"])
def test_every_controller_is_stable_and_bounded_on_every_case_it_applies_to(controller, case):
    env = gym.make(ENV_ID, case=case)
    if not _applies(controller, case):
        with pytest.raises(ValueError, match="velocity-command"):
            make_controller(controller).bind(env)
        return
    m = evaluate(env, make_controller(controller))
    assert m["completed"], m["termination_reason"]
    assert m["max_contour_error_um"] < 1000
    assert m["saturation_fraction"] < 0.05


@pytest.mark.parametrize("controller", ["pd", "ccc", "adaptive-ccc"])
def test_policy_residual_base_and_evaluate_give_identical_metrics(controller):
    case = "hsm2-circle-III"
    via_eval = evaluate(gym.make(ENV_ID, case=case), make_controller(controller))
    # (a) as a policy through predict()
    env = gym.make(ENV_ID, case=case)
    ctl = make_controller(controller).bind(env)
    obs, _ = env.reset(seed=0)
    eps_a = []
    while True:
        a, _ = ctl.predict(obs)
        obs, _, term, trunc, info = env.step(a)
        eps_a.append(info["contour_error"])
        if term or trunc:
            break
    # (b) as the base of a residual agent: base command + zero residual
    env = gym.make(ENV_ID, case=case)
    ctl = make_controller(controller).bind(env)
    env.reset(seed=0)
    limit = env.unwrapped.plant.params.force_limit_N
    eps_b = []
    while True:
        base = ctl.command(env.unwrapped.signals())[0]
        residual = np.zeros_like(base)
        action = np.clip((base + residual) / limit, -1, 1).astype(np.float32)
        _, _, term, trunc, info = env.step(action)
        eps_b.append(info["contour_error"])
        if term or trunc:
            break
    for eps in (eps_a, eps_b):
        assert max(eps) * 1e6 == via_eval["max_contour_error_um"]
        assert np.sqrt(np.mean(np.square(eps))) * 1e6 == via_eval["rms_contour_error_um"]


def test_destabilising_gains_end_the_episode_with_a_reason_and_compare_reports_the_rest():
    import agents.registry as reg

    class Unstable(reg.CONTROLLERS["pd"]):
        name = "unstable"

        def __init__(self):
            super().__init__(P=5e9, D=0.0)

    reg.CONTROLLERS["unstable"] = Unstable
    try:
        res = compare(["pd", "unstable"], case="hsm2-circle-I")["results"]
    finally:
        del reg.CONTROLLERS["unstable"]
    by = {r["controller"]: r for r in res}
    assert by["pd"]["stable"] and not by["unstable"]["stable"]
    assert by["unstable"]["termination_reason"] == "contour_error_limit"
    assert by["pd"]["rms_contour_error_um"] > 0


def test_two_axis_gains_on_a_three_axis_case_are_a_clear_error():
    with pytest.raises(ValueError, match="3 per-axis values"):
        make_controller("pd", P=[1e5, 1e5]).bind(gym.make(ENV_ID, case="jee-circle3d"))


def test_compare_cli_json_and_plot(tmp_path, capsys):
    js, png = tmp_path / "c.json", tmp_path / "c.png"
    assert (
        main(
            [
                "compare",
                "--case",
                "hsm2-circle-III",
                "--controllers",
                "pd,ccc",
                "--json",
                str(js),
                "--plot",
                str(png),
            ]
        )
        == 0
    )
    data = json.loads(js.read_text())
    assert data["case"] == "hsm2-circle-III"
    assert [r["controller"] for r in data["results"]] == ["pd", "ccc"]
    for r in data["results"]:
        assert {"max_contour_error_um", "rms_contour_error_um", "rms_effort"} <= set(r)
    assert png.stat().st_size > 10_000
    assert "RMS/PD" in capsys.readouterr().out


def test_compare_unknown_controller_lists_known(capsys):
    assert main(["compare", "--case", "hsm2-circle-I", "--controllers", "pd,nope"]) == 2
    assert "known: pd, ccc, adaptive-ccc, jee-ccc" in capsys.readouterr().err


def test_robustness_over_randomized_plants():
    rows = robustness(["pd", "ccc"], 0.2, 6, case="hsm2-circle-III")
    by = {r["controller"]: r for r in rows}
    assert by["ccc"]["mean_rms_contour_error_um"] < by["pd"]["mean_rms_contour_error_um"]
    for r in rows:
        assert r["failure_rate"] == 0.0
        assert r["cvar10_rms_contour_error_um"] >= r["mean_rms_contour_error_um"] - 1e-9
