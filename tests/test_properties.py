"""Property-based checks (hypothesis): the G-code reader, custom plant parameters and actions
either give a clear ValueError or finite results, never another exception nor NaN/inf.

Seeded and short (``derandomize=True``, no example database): the file runs in well under
30 s."""

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from contour_env.env.contouring_env import ContouringEnv
from contour_env.env.vector_env import ContouringVectorEnv
from contour_env.paths import circle
from contour_env.paths.gcode import parse_gcode
from contour_env.plants import params_from_mapping
from contour_env.plants.params import PARAM_RANGES

FAST = settings(
    max_examples=40,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow],
)
SLOW = settings(FAST, max_examples=25)


def _finite_path(program) -> None:
    path = program.path
    assert math.isfinite(path.total_length) and path.total_length > 0
    assert np.all(np.isfinite(path.seg_data)) and np.all(np.isfinite(path.seg_bounds))
    assert np.all(np.isfinite(path.sample_points(50)))
    assert np.all(np.isfinite(program.segment_feeds_m_s)) and np.all(program.segment_feeds_m_s > 0)


# --- G-code -----------------------------------------------------------------------------------
coord = st.decimals(min_value=-500, max_value=500, places=3, allow_nan=False).map(str)
radius = st.decimals(min_value="0.5", max_value=200, places=3).map(str)
feed = st.decimals(min_value=1, max_value=20000, places=1).map(str)


@st.composite
def move(draw):
    kind = draw(st.sampled_from(["G00", "G01", "G01", "circle", "G04", "mode"]))
    if kind in ("G00", "G01"):
        words = [kind, f"X{draw(coord)}", f"Y{draw(coord)}"]
        if draw(st.booleans()):
            words.append(f"Z{draw(coord)}")
        if kind == "G01" and draw(st.booleans()):
            words.append(f"F{draw(feed)}")
        return " ".join(words)
    if kind == "circle":  # a full circle: I/J offset and no axis word ends where it starts
        g = draw(st.sampled_from(["G02", "G03"]))
        return f"{g} I{draw(radius)} J0"
    if kind == "G04":
        return f"G04 P{draw(st.decimals(min_value=0, max_value=2, places=2))}"
    return draw(st.sampled_from(["G61", "G64", "G64 P0.05", "G90", "G91", "M08", "S1000 M03"]))


@st.composite
def program(draw):
    lines = [draw(st.sampled_from(["G21", "G20"])) + " G90 G17", f"G01 F{draw(feed)}"]
    lines += draw(st.lists(move(), min_size=1, max_size=12))
    if draw(st.booleans()):
        lines.append("M30")
    sep = draw(st.sampled_from(["\n", "\r\n", "\r"]))
    return sep.join(lines) + sep


@FAST
@given(program())
def test_well_formed_programs_give_finite_paths_or_value_error(text):
    try:
        prog = parse_gcode(text)
    except ValueError:
        event("ValueError")
        return  # e.g. no motion, or a move that overruns MAX_COORDINATE_M in G91
    event("program")
    _finite_path(prog)


@FAST
@given(
    st.one_of(
        st.text(alphabet="GXYZFIJKRNMPQST0123456789.-+ ()%;/\n\t#[]eE", max_size=80),
        st.text(max_size=60),
    )
)
def test_junk_gives_value_error_or_a_finite_program(text):
    try:
        prog = parse_gcode(text)
    except ValueError:
        event("ValueError")
        return
    event("program")
    _finite_path(prog)


# --- custom plant parameters --------------------------------------------------------------------
def _value(lo, hi):
    """Mostly inside [lo, hi], sometimes far outside (down to 1e-300, up to 1e300, 0, < 0)."""
    low = max(lo, 1e-9)
    inside = st.floats(math.log10(low), math.log10(hi), allow_nan=False).map(lambda e: 10.0**e)
    outside = st.sampled_from([0.0, -1.0, 1e-300, 1e300, 1e308, hi * 1e3, low * 1e-3])
    # about one value in ten outside (hypothesis favours the ends of a range: pick the middle)
    return st.tuples(st.integers(0, 9), inside, outside).map(lambda t: t[2] if t[0] == 5 else t[1])


@st.composite
def custom_plant(draw):
    m = {
        "mass": draw(_value(*PARAM_RANGES["mass_kg"])),
        "force_limit": draw(_value(*PARAM_RANGES["force_limit_N"])),
        # inside: no finer than 0.1 ms (a finer one only makes the reference long)
        "servo_period": draw(st.one_of(st.sampled_from([1e-4, 1e-3, 5e-3]), _value(1e-6, 0.1))),
    }
    for key, field in (
        ("viscous", "viscous_Ns_m"),
        ("coulomb", "coulomb_N"),
        ("ripple_amplitude", "ripple_amplitude_N"),
        ("current_loop_time_constant", "current_loop_time_constant_s"),
        ("structural_stiffness", "structural_stiffness_N_m"),
    ):
        if draw(st.booleans()):
            m[key] = draw(_value(*PARAM_RANGES[field]))
    return m


@SLOW
@given(custom_plant(), st.sampled_from(["ones", "zeros", "alternate", "random"]))
def test_custom_plants_give_value_error_or_a_finite_episode(mapping, pattern):
    try:
        params_from_mapping(mapping)
    except ValueError as exc:
        assert any(k in str(exc) for k in ("must be", "needs")), exc
        event("ValueError")
        return
    if mapping["servo_period"] < 1e-4:
        event("valid, fine servo period: not run")
        return  # valid, but a long reference to build; the range check is what is tested
    event("episode")
    env = ContouringEnv(plant=mapping, path=circle((0, 0), 0.005), feedrate_m_s=0.05)
    obs, _ = env.reset(seed=0)
    rng = np.random.default_rng(0)
    for k in range(60):
        a = {
            "ones": np.ones(2),
            "zeros": np.zeros(2),
            "alternate": np.full(2, (-1.0) ** k),
            "random": rng.uniform(-1, 1, 2),
        }[pattern]
        obs, r, term, trunc, info = env.step(a)
        assert np.isfinite(r) and np.all(np.isfinite(obs)), (mapping, k, r)
        if term or trunc:
            break


@SLOW
@given(st.lists(st.floats(-8, 8), min_size=4, max_size=4))
def test_scaled_case_plant_params_give_value_error_or_a_finite_episode(exponents):
    base = ContouringEnv(case="sharp-corner")
    fields = ("mass_kg", "force_limit_N", "viscous_Ns_m", "coulomb_N")
    changes = {
        f: getattr(base.plant.params, f) * 10.0**e for f, e in zip(fields, exponents, strict=True)
    }
    changes["static_N"] = np.maximum(base.plant.params.static_N, changes["coulomb_N"])
    try:
        p = base.plant.params.replace(**changes)
        env = ContouringEnv(case="sharp-corner", plant_params=[p])
    except ValueError as exc:
        assert "must be" in str(exc)
        event("ValueError")
        return
    event("episode")
    env.reset(seed=0)
    for _ in range(40):
        obs, r, term, trunc, _ = env.step(np.ones(2))
        assert np.isfinite(r) and np.all(np.isfinite(obs))
        if term:
            break


# --- actions ------------------------------------------------------------------------------------
special = st.sampled_from([0.0, 1.0, -1.0, 1e308, -1e308, math.inf, -math.inf, math.nan, 1e-320])
element = st.one_of(st.floats(-10, 10), special)
shapes = st.sampled_from([(2,), (2,), (2,), (1, 2), (3,), (1,), (), (2, 1), (0,)])


@pytest.fixture(scope="module")
def envs():
    env = ContouringEnv(case="hsm2-circle-II")
    venv = ContouringVectorEnv(num_envs=3, case="hsm2-circle-II")
    return env, venv


@FAST
@given(shapes, st.lists(element, min_size=3, max_size=3))
def test_actions_give_finite_results_or_value_error_single(envs, shape, values):
    env, _ = envs
    env.reset(seed=0)
    n = int(np.prod(shape))
    a = np.array((values * 2)[:n], dtype=np.float64).reshape(shape)
    try:
        obs, r, term, trunc, info = env.step(a)
    except ValueError as exc:
        assert "action" in str(exc)
        assert a.size != 2 or not np.all(np.isfinite(a))
        return
    assert a.size == 2 and np.all(np.isfinite(a))
    assert np.isfinite(r) and np.all(np.isfinite(obs))
    assert np.all(np.abs(info["force"]) <= env.plant.params.force_limit_N * (1 + 1e-12))


@FAST
@given(
    st.sampled_from([(3, 2), (3, 2), (2, 2), (3,), (6,)]), st.lists(element, min_size=6, max_size=6)
)
def test_actions_give_finite_results_or_value_error_vector(envs, shape, values):
    _, venv = envs
    venv.reset(seed=0)
    n = int(np.prod(shape))
    a = np.array(values[:n], dtype=np.float64).reshape(shape)
    try:
        obs, r, term, trunc, info = venv.step(a)
    except ValueError as exc:
        assert "action" in str(exc)
        assert a.shape != (3, 2) or not np.all(np.isfinite(a))
        return
    assert a.shape == (3, 2) and np.all(np.isfinite(a))
    assert np.all(np.isfinite(r)) and np.all(np.isfinite(obs))
