"""Loop margins (agents.margins): the frequency-domain model against simulations of the
compiled plant, the project's requirement over every named plant × default controller, the
CLI and its bad input."""

from __future__ import annotations

import json
import math

import control
import numpy as np
import pytest

from agents import make_controller
from agents.margins import (
    MIN_GAIN_MARGIN_DB,
    MIN_PHASE_MARGIN_DEG,
    loop_margins,
    meets_requirement,
    requirement,
)
from contour_env.analysis.linear_plant import controller_system, discrete_plant
from contour_env.app.cli import main
from contour_env.plants import Plant
from contour_env.plants.catalog import nominal_params


def _frame(deg: float) -> np.ndarray:
    a = math.radians(deg)
    return np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])


def _linear(params):
    """The realistic plant without what the linear model leaves out (friction, ripple,
    disturbance, quantisation, saturation): the compiled kernel integrates the rest."""
    z = np.zeros(params.n_axes)
    return params.replace(
        coulomb_N=z,
        static_N=z,
        ripple_amplitude_N=z,
        disturbance_amplitude_N=z,
        encoder_resolution_m=z,
        force_limit_N=np.full(params.n_axes, 1e12),
    )


def _simulate(controller, plant: Plant, frame, *, gain=1.0, direction=None, steps=3000):
    """Closed loop of ``controller.act`` on the compiled plant (Plant.step) from a 1 µm offset,
    reference at rest, the encoder read as the env does (drive side with the two-mass mode),
    velocity by backward difference; the command along ``direction`` multiplied by ``gain``.
    Returns the measured positions (steps, A)."""
    sim = Plant(_linear(plant.params))
    n = plant.n_axes
    state = sim.initial_state(np.full((1, n), 1e-6))
    T = plant.servo_period_s
    idx = 2 if plant.params.has_structural_mode else 0
    prev = state.z[:, :, idx].copy()
    zeros = np.zeros((1, n))
    out = np.empty((steps, n))
    for k in range(steps):
        x = state.z[:, :, idx].copy()
        signals = {
            "measured_position": x,
            "measured_velocity": (x - prev) / T,
            "reference_position": zeros,
            "reference_velocity": zeros,
            "reference_acceleration": zeros,
            "frame": frame[None],
            "curvature": np.zeros(1),
            "torsion": np.zeros(1),
            "feedrate": np.zeros(1),
            "step": np.array([k]),
        }
        prev = x
        u = controller.act(signals)
        if direction is not None:
            u = u + (gain - 1.0) * (u @ direction)[:, None] * direction[None, :]
        state, _ = sim.step(state, u, k * T)
        out[k] = x[0]
    return out


def _growth_and_frequency(y: np.ndarray, T: float) -> tuple[float, float]:
    """Envelope growth factor per sample and oscillation frequency (Hz) of the second half."""
    half = y[len(y) // 2 :]
    a, b = half[: len(half) // 4], half[-len(half) // 4 :]
    growth = (np.max(np.abs(b)) / np.max(np.abs(a))) ** (1.0 / (len(half) * 3 / 4))
    # frequency from the zero crossings (the mode decays or grows by many decades over the
    # window, which smears a spectrum)
    crossings = np.nonzero(np.diff(np.signbit(half)))[0]
    span = (crossings[-1] - crossings[0]) * T if crossings.size > 1 else math.inf
    return growth, float((crossings.size - 1) / (2.0 * span)) if crossings.size > 1 else 0.0


@pytest.mark.parametrize(
    ("plant_name", "spec", "deg", "structural"),
    [("hsm2", "ccc:wp=6e4:wi=0", 0.0, False), ("hsm2", "ccc", 45.0, False),
     ("friction-table", "pd:w=200", 45.0, False), ("hsm2", "pd", 0.0, True)],
)  # fmt: skip
def test_model_poles_match_the_compiled_plant(plant_name, spec, deg, structural):
    """The dominant closed-loop pole of the frequency-domain model (ZOH, delay, current lag,
    two-mass mode, backward-difference velocity) equals the decay rate and frequency of a
    simulation of the compiled kernel with the controller's own act()."""
    plant = Plant(plant_name, structural_mode=structural)
    ctrl = make_controller(spec).configure_for(plant)
    frame = _frame(deg)
    G = controller_system(*ctrl.loop_gains(frame), plant.servo_period_s) * discrete_plant(
        plant.params
    )
    poles = np.linalg.eigvals(control.feedback(G, np.eye(2)).A)
    lam = poles[np.argmax(np.abs(poles))]
    y = _simulate(ctrl, plant, frame, steps=4000)
    growth, freq = _growth_and_frequency(y @ frame[:, 1] + y @ frame[:, 0], plant.servo_period_s)
    assert growth == pytest.approx(abs(lam), abs=2e-4)
    f_model = abs(np.angle(lam)) / (2 * math.pi * plant.servo_period_s)
    assert freq == pytest.approx(f_model, rel=0.03)


@pytest.mark.parametrize(
    ("plant_name", "spec", "loop"),
    [("friction-table", "pd", "axis y"), ("hsm2", "ccc:wp=3e4:wi=1e5", "normal"),
     ("linear-motor", "pd", "axis x")],
)  # fmt: skip
def test_gain_raised_by_the_margin_oscillates_at_the_phase_crossover(plant_name, spec, loop):
    """Raise the loop gain of the reported worst loop by its gain margin (×1.03 beyond): the
    simulated loop grows, at the reported phase-crossover frequency within 10 %; ×0.97 of
    the margin decays."""
    rep = loop_margins(spec, plant_name, mass_variation=0.0)
    row = next(r for r in rep["loops"] if r["loop"] == loop)
    assert row["gain_margin_db"] is not None and row["phase_crossover_hz"] is not None
    g = 10 ** (row["gain_margin_db"] / 20)
    plant = Plant(plant_name)
    n = plant.n_axes
    where = row["gain_margin_at"]["direction"]
    if n == 2:
        frame = _frame(float(where.rstrip("°")))
    else:
        frame = np.eye(3)
        assert where == "t=(1.00,0.00,0.00)" or loop.startswith("axis")
    if loop.startswith("axis"):
        direction = np.eye(n)[["x", "y", "z"].index(loop[-1])]
    else:
        direction = frame[:, {"tangential": 0, "normal": 1, "binormal": 2}[loop]]
    ctrl = make_controller(spec).configure_for(plant)
    steps = 6000 if plant.servo_period_s >= 1e-3 else 20000
    up = _simulate(ctrl, plant, frame, gain=1.03 * g, direction=direction, steps=steps)
    ctrl.reset()
    down = _simulate(ctrl, plant, frame, gain=0.97 * g, direction=direction, steps=steps)
    g_up, f_up = _growth_and_frequency(up @ direction, plant.servo_period_s)
    g_down, _ = _growth_and_frequency(down @ direction, plant.servo_period_s)
    assert g_up > 1.0 > g_down
    assert f_up == pytest.approx(row["phase_crossover_hz"], rel=0.10)


def _applicable():
    out = []
    for plant in ("hsm2", "friction-table", "linear-motor", "jee-triaxial"):
        for name in ("pd", "ccc", "adaptive-ccc", "jee-ccc"):
            if name == "jee-ccc" and plant != "jee-triaxial":
                continue
            out.append((plant, name))
    return out


@pytest.mark.parametrize(("plant", "name"), _applicable())
def test_every_default_gain_set_meets_the_requirement(plant, name):
    """Gain margin ≥ 6 dB and phase margin ≥ 30° on the realistic plant over the ±20 % mass
    corners; with the plant's two-mass mode, stable with ≥ 2 dB / 10°."""
    rep = loop_margins(name, plant)
    assert rep["stable"]
    assert rep["min_gain_margin_db"] >= MIN_GAIN_MARGIN_DB
    assert rep["min_phase_margin_deg"] >= MIN_PHASE_MARGIN_DEG
    assert meets_requirement(rep)
    if nominal_params(plant)[1].structural_mode_hz:
        rep = loop_margins(name, plant, structural_mode=True)
        gm, pm = requirement(structural_mode=True)
        assert rep["stable"] and meets_requirement(rep)
        assert rep["min_gain_margin_db"] >= gm and rep["min_phase_margin_deg"] >= pm


def test_margins_cli_writes_the_documented_json(tmp_path, capsys):
    out = tmp_path / "m.json"
    assert main(["margins", "--plant", "friction-table", "--controller", "pd", "--json",
                 str(out), "--check"]) == 0  # fmt: skip
    data = json.loads(out.read_text())
    for key in ("plant", "controller", "loops", "min_gain_margin_db", "min_phase_margin_deg"):
        assert key in data
    assert data["plant"] == "friction-table" and data["controller"] == "pd"
    names = [r["loop"] for r in data["loops"]]
    assert names == ["axis x", "axis y", "tangential", "normal"]
    for r in data["loops"]:
        assert {"loop", "gain_margin_db", "phase_margin_deg", "crossover_hz"} <= set(r)
        assert r["crossover_hz"] > 0
    assert "meets the requirement" in capsys.readouterr().out


def test_margins_cli_flags_an_unstable_gain_set(capsys):
    """The old friction-table CCC (W_p = 6e4 on PD at 200 rad/s) has a pole outside the unit
    circle: reported, and --check exits 1."""
    assert main(["margins", "--plant", "friction-table", "--controller", "ccc:w=200:wp=6e4",
                 "--check"]) == 1  # fmt: skip
    assert "UNSTABLE" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["--controller", "nosuch"], "unknown controller"),
        (["--controller", "pd:foo=1"], "foo"),
        (["--plant", "nosuch"], "unknown plant"),
        (["--mass-variation", "1.5"], "mass_variation"),
        (["--plant", "hsm2", "--controller", "jee-ccc"], "velocity-command"),
        (["--plant", "jee-triaxial", "--structural-mode"], "structural_mode"),
    ],
)
def test_margins_bad_input_is_a_clear_error(argv, needle, capsys):
    assert main(["margins", *argv]) == 2
    assert needle in capsys.readouterr().err


@pytest.mark.parametrize("plant", ["five-axis", "nxv560a"])
def test_margins_of_the_five_axis_plant_are_its_joint_loops(plant, capsys):
    # issue 36 item 14 said "no margins tool yet"; issue 38 added one (agents.five_axis_margins,
    # tests/agents/test_five_axis_pid.py, tests/app/test_margins_five_axis.py): the default
    # controller pd is there the paper's joint PD
    assert main(["margins", "--plant", plant, "--mass-variation", "0"]) == 0
    out = capsys.readouterr().out
    assert "poses (joint loops)" in out and "joint C" in out and "unknown plant" not in out
    from agents.five_axis_margins import five_axis_loop_margins

    rep = five_axis_loop_margins("pd", plant, mass_variation=0.0)
    assert rep["plant"] == "five-axis" and rep["stable"] and meets_requirement(rep)
    with pytest.raises(ValueError, match="analysed joint by joint"):
        loop_margins("pd", plant)
