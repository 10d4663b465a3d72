"""Plant parameters: custom mappings, validation messages, the catalogue's ideal and realistic
plants, and the input checks of Plant.step."""

import numpy as np
import pytest

from contour_env.plants import Plant, PlantParams, params_from_mapping, plant_names

BASE = {"mass": [10.0, 12.0], "force_limit": 100.0, "servo_period": 1e-3}


def test_params_from_mapping_broadcasts_scalars_and_keeps_per_axis_lists():
    p = params_from_mapping(
        {
            "axes": ["x", "y", "z"],
            "mass": [1.0, 2.0, 3.0],
            "viscous": 5.0,
            "coulomb": [1.0, 2.0, 3.0],
            "static": [1.5, 2.0, 4.0],
            "force_limit": 50.0,
            "servo_period": 2e-4,
            "current_loop_time_constant": [1e-4, 2e-4, 3e-4],
            "computation_delay": True,
            "name": "my-rig",
        }
    )
    assert isinstance(p, PlantParams)
    assert p.name == "my-rig" and p.axis_names == ("x", "y", "z") and p.n_axes == 3
    np.testing.assert_array_equal(p.mass_kg, [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(p.viscous_Ns_m, [5.0, 5.0, 5.0])
    np.testing.assert_array_equal(p.force_limit_N, [50.0, 50.0, 50.0])
    np.testing.assert_array_equal(p.static_N, [1.5, 2.0, 4.0])
    np.testing.assert_array_equal(p.current_loop_time_constant_s, [1e-4, 2e-4, 3e-4])
    assert p.servo_period_s == 2e-4 and p.computation_delay and p.has_friction
    # arrays are float64 and read-only (the dataclass is frozen)
    assert p.mass_kg.dtype == np.float64
    with pytest.raises(ValueError):
        p.mass_kg[0] = 7.0


def test_params_from_mapping_defaults():
    p = params_from_mapping({**BASE, "coulomb": 3.0})
    assert p.axis_names == ("x", "y") and p.name == "custom"
    np.testing.assert_array_equal(p.static_N, [3.0, 3.0])  # static defaults to coulomb
    for field in ("viscous_Ns_m", "ripple_amplitude_N", "disturbance_amplitude_N"):
        np.testing.assert_array_equal(getattr(p, field), 0.0)
    np.testing.assert_array_equal(p.current_loop_time_constant_s, 0.0)
    assert not p.computation_delay and not p.has_structural_mode
    assert not params_from_mapping(BASE).has_friction
    # the full field names work too
    q = params_from_mapping({"mass_kg": 4.0, "force_limit_N": 9.0, "servo_period_s": 1e-3})
    np.testing.assert_array_equal(q.mass_kg, [4.0, 4.0])


def test_custom_mapping_plant_is_its_own_nominal_and_steps():
    plant = Plant({**BASE, "viscous": [1.0, 2.0]})
    assert plant.params is plant.nominal and plant.effects.get("ideal") is True
    state = plant.initial_state(np.zeros((1, 2)))
    state, applied = plant.step(state, np.array([[10.0, -12.0]]), 0.0)
    np.testing.assert_array_equal(applied, [[10.0, -12.0]])
    # a = F / m = 1 m/s² on both axes (opposite signs); x ≈ a T² / 2
    np.testing.assert_allclose(state.position[0], [0.5e-6, -0.5e-6], rtol=1e-3)


# one line: "plant: <key>: must be <what is allowed>, got <the value as the file holds it>"
@pytest.mark.parametrize(
    "change, match",
    [
        ({"mass": [0.0, 1.0]}, r"^plant: mass: must be a number in \[1e-06, 1e\+06\] kg, or one "
         r"per axis \(2 per-axis values\), got \[0.0, 1.0\]$"),
        ({"mass": -2.0}, r"^plant: mass: must be a number in \[1e-06, 1e\+06\] kg.*, got -2.0$"),
        ({"servo_period": 0.0}, r"^plant: servo_period: must be a number in \[1e-06, 0.1\] s, "
         r"got 0.0$"),
        ({"servo_period": -1e-3}, r"^plant: servo_period: .*, got -0.001$"),
        ({"viscous": [1.0, -1.0]}, r"^plant: viscous: must be a number in \[0, 1e\+07\] N s/m"),
        ({"coulomb": 5.0, "static": 1.0}, r"^plant: static_N must be >= coulomb_N"),
        ({"coulomb": [1.0, 5.0], "static": [2.0, 4.0]}, r"static_N must be >= coulomb_N"),
        ({"mass": [1.0, 2.0, 3.0]}, r"^plant: mass: .*\(2 per-axis values\), "
         r"got \[1.0, 2.0, 3.0\]"),
        ({"viscous": [1.0]}, r"^plant: viscous: .*\(2 per-axis values\), got \[1.0\]"),
        ({"force_limit": 0.0}, r"^plant: force_limit: must be a number in \[1e-06, 1e\+07\] N"),
        ({"mass": [1.0, np.nan]}, r"^plant: mass: .*, got \[1.0, NaN\]$"),
        ({"stribeck_velocity": 0.0}, r"^plant: stribeck_velocity: must be a number in "
         r"\[1e-06, 10\]"),
        ({"axes": ["x"]}, r"^plant: axes: must be a list of 2 or 3 axis names"),
        ({"input_kind": "torque"}, r'^plant: input_kind: must be one of "force", '
         r'"velocity-command", got "torque"$'),
        ({"friction_substeps": 0}, r"^plant: friction_substeps: must be an integer in \[1, 1000\], "
         r"got 0$"),
        ({"friction_substeps": 2.5}, r"^plant: friction_substeps: must be an integer.*, got 2.5$"),
        ({"computation_delay": "yes"}, r'^plant: computation_delay: must be true or false, '
         r'got "yes"$'),
        ({"servo_period": "1ms"}, r'^plant: servo_period: must be a number.*, got "1ms"$'),
        ({"mass": ["heavy", 1.0]}, r'^plant: mass: must be a number.*, got \["heavy", 1.0\]$'),
        ({"axes": 3}, r"^plant: axes: must be a list of strings, got 3$"),
        ({"axes": "xyz"}, r'^plant: axes: must be a list of strings, got "xyz"$'),
        ({"load_mass_fraction": 1.0}, r"^plant: load_mass_fraction: must be a number in "
         r"\[0.01, 0.99\]"),
        ({"force_limit": None}, r"^plant: force_limit: must be a number .* per axis, got null$"),
    ],
)  # fmt: skip
def test_invalid_custom_parameters_raise_naming_the_parameter(change, match):
    with pytest.raises(ValueError, match=match):
        params_from_mapping({**BASE, **change})


def test_unknown_key_error_lists_the_allowed_keys():
    with pytest.raises(ValueError, match=r'^plant: unknown key "colour"; allowed: ') as info:
        params_from_mapping({**BASE, "colour": "red"})
    msg = str(info.value)
    assert "allowed:" in msg
    for key in ("mass", "force_limit", "servo_period", "viscous", "coulomb", "static", "axes"):
        assert key in msg


@pytest.mark.parametrize("missing", ["mass", "force_limit", "servo_period"])
def test_missing_required_key_is_named(missing):
    mapping = {k: v for k, v in BASE.items() if k != missing}
    with pytest.raises(ValueError, match=rf"^plant: {missing}: required \(a number .*\), missing$"):
        params_from_mapping(mapping)


def test_mapping_of_wrong_type_is_rejected():
    with pytest.raises(ValueError, match="must hold a JSON object"):
        params_from_mapping([("mass", 1.0)])
    with pytest.raises(ValueError, match=r"^plant must hold a JSON object .*, got a list"):
        params_from_mapping([1, 2, 3])
    with pytest.raises(ValueError, match="plant: expected a plant name"):
        Plant(42)


def test_unknown_plant_lists_the_known_plants():
    with pytest.raises(ValueError, match=r"unknown plant 'nope'") as info:
        Plant("nope")
    names = plant_names()
    assert set(names) >= {"hsm2", "jee-triaxial", "linear-motor", "friction-table"}
    for name in names:
        assert name in str(info.value)


def test_plant_aliases():
    assert Plant("jee", ideal=True).name == "jee-triaxial"
    assert Plant("lm", ideal=True).name == "linear-motor"
    assert Plant("table", ideal=True).name == "friction-table"


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_step_rejects_non_finite_commands(bad):
    plant = Plant("hsm2")
    state = plant.initial_state(np.zeros((1, 2)))
    with pytest.raises(ValueError, match="command: must be finite"):
        plant.step(state, np.array([[bad, 0.0]]), 0.0)


def test_step_and_initial_state_reject_wrong_shapes():
    plant = Plant("hsm2", ideal=True)
    state = plant.initial_state(np.zeros((2, 2)))
    with pytest.raises(ValueError, match="command: expected shape"):
        plant.step(state, np.zeros((1, 2)), 0.0)
    with pytest.raises(ValueError, match="command: expected shape"):
        plant.step(state, np.zeros((2, 3)), 0.0)
    with pytest.raises(ValueError, match="position: expected 2 axes"):
        plant.initial_state(np.zeros((1, 3)))


def test_step_is_pure():
    plant = Plant("friction-table")
    state = plant.initial_state(np.zeros((1, 2)))
    before = state.copy()
    plant.step(state, np.array([[500.0, -500.0]]), 0.0)
    np.testing.assert_array_equal(state.z, before.z)
    np.testing.assert_array_equal(state.stuck, before.stuck)
    np.testing.assert_array_equal(state.u_pending, before.u_pending)


def test_realistic_hsm2_has_its_documented_effects():
    plant = Plant("hsm2")
    true, nominal = plant.params, plant.nominal
    assert true.computation_delay and not nominal.computation_delay
    np.testing.assert_array_equal(true.current_loop_time_constant_s, [0.5e-3, 0.5e-3])
    assert np.all(nominal.current_loop_time_constant_s == 0)
    assert true.has_friction and np.all(true.static_N > 0) and np.all(true.coulomb_N > 0)
    assert not nominal.has_friction
    assert np.all(true.mass_kg != nominal.mass_kg)
    np.testing.assert_allclose(true.mass_kg / nominal.mass_kg, [1.08, 0.94], rtol=1e-14)
    np.testing.assert_allclose(true.viscous_Ns_m / nominal.viscous_Ns_m, [0.90, 1.10], rtol=1e-14)
    assert plant.effects["ideal"] is False
    # nominal: the paper's numbers; x through the lead ℓ = 4.4 mm/rad (m = J/ℓ², b = B/ℓ²)
    np.testing.assert_allclose(nominal.mass_kg, [0.05916 / 4.4e-3**2, 1144.0], rtol=1e-14)
    np.testing.assert_allclose(nominal.viscous_Ns_m, [0.01725 / 4.4e-3**2, 967.0], rtol=1e-14)
    np.testing.assert_allclose(nominal.force_limit_N, [60.0 / 4.4e-3, 6000.0], rtol=1e-14)
    # the delay is what the plant does: the first command is applied one period late
    state = plant.initial_state(np.zeros((1, 2)))
    state, applied = plant.step(state, np.array([[1000.0, 1000.0]]), 0.0)
    np.testing.assert_array_equal(applied, 0.0)
    np.testing.assert_array_equal(state.u_pending, [[1000.0, 1000.0]])


def test_ideal_hsm2_is_the_paper_model():
    plant = Plant("hsm2", ideal=True)
    true, nominal = plant.params, plant.nominal
    assert not true.computation_delay
    assert np.all(true.current_loop_time_constant_s == 0)
    assert not true.has_friction and not true.has_structural_mode
    assert true.to_dict() == nominal.to_dict()
    state = plant.initial_state(np.zeros((1, 2)))
    _, applied = plant.step(state, np.array([[1000.0, -1000.0]]), 0.0)
    np.testing.assert_array_equal(applied, [[1000.0, -1000.0]])  # no delay


@pytest.mark.parametrize("name", ["hsm2", "jee-triaxial", "linear-motor", "friction-table"])
def test_every_catalogue_plant_ideal_equals_nominal_and_realistic_differs(name):
    ideal = Plant(name, ideal=True)
    assert ideal.params.to_dict() == ideal.nominal.to_dict()
    assert not ideal.params.computation_delay
    real = Plant(name)
    assert real.params.computation_delay
    assert real.nominal.to_dict() == ideal.nominal.to_dict()
    assert real.params.to_dict() != real.nominal.to_dict()


def test_structural_mode_needs_a_realistic_plant_with_mode_data():
    with pytest.raises(ValueError, match="structural_mode"):
        Plant("hsm2", ideal=True, structural_mode=True)
    with pytest.raises(ValueError, match="structural_mode"):
        Plant("jee-triaxial", structural_mode=True)
    p = Plant("hsm2", structural_mode=True).params
    assert p.has_structural_mode and np.all(p.structural_damping_Ns_m > 0)


def test_scaled_multiplies_per_axis_fields_and_rejects_unknown_ones():
    p = Plant("hsm2", ideal=True).params
    q = p.scaled({"mass_kg": [2.0, 0.5], "viscous_Ns_m": 3.0})
    np.testing.assert_allclose(q.mass_kg, p.mass_kg * [2.0, 0.5])
    np.testing.assert_allclose(q.viscous_Ns_m, 3.0 * p.viscous_Ns_m)
    with pytest.raises(ValueError, match="scaled: unknown per-axis parameter 'servo_period_s'"):
        p.scaled({"servo_period_s": 2.0})
    with pytest.raises(ValueError, match="mass_kg: must be > 0"):
        p.scaled({"mass_kg": -1.0})
