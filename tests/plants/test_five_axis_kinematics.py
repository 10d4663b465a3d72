"""Five-axis A–C table kinematics (Chen, Khong & Hsieh 2022, eqs. 1–3): forward∘inverse
identity, the test paths' tool vectors through X_c, C continuity, the A = 0 singularity and
bad input."""

import math

import numpy as np
import pytest

from contour_env.plants.five_axis import FiveAxisGeometry, forward, inverse, tool_towards
from contour_env.plants.five_axis.kinematics import SINGULAR_TOL

GEOM = FiveAxisGeometry()
LINE_XC = np.array([0.0, -0.05, -0.5])
CIRCLE_XC = np.array([0.0, 0.8, -0.8])


def _random_joints(rng, n, *, c_span=4 * np.pi):
    travel = GEOM.travel()
    travel[4] = (-c_span, c_span)  # C is unlimited: sample several turns
    q = rng.uniform(travel[:, 0], travel[:, 1], size=(n, 5))
    # keep clear of the singular pose, where C is undefined
    q[:, 3] = np.where(np.abs(q[:, 3]) < 1e-3, -0.5, q[:, 3])
    return q


def _line_points(n=201):
    x1, x2 = np.array([0.08, 0.03, 0.02]), np.array([0.01, 0.05, 0.07])
    s = np.linspace(0.0, 1.0, n)[:, None]
    return x1 + (x2 - x1) * s


def _circle_points(n=401, r=0.1):
    # ε1 = x² + 2y² − r², ε2 = y − z: the r = 0.1 m circle inclined 45°
    phi = np.linspace(0.0, 2 * np.pi, n)
    y = r * np.sin(phi) / math.sqrt(2.0)
    return np.stack([r * np.cos(phi), y, y], axis=-1)


@pytest.mark.parametrize("branch", [-1, 1])
def test_inverse_of_forward_is_identity(branch):
    rng = np.random.default_rng(1600 + branch)
    q = _random_joints(rng, 5000)
    q = q[np.sign(q[:, 3]) == branch]
    tip, tool = forward(q, GEOM)
    back = inverse(tip, tool, GEOM, c_ref=q[:, 4], a_branch=branch)
    assert np.max(np.abs(back - q)) < 1e-12


def test_forward_of_inverse_is_identity():
    rng = np.random.default_rng(1601)
    n = 5000
    a = rng.uniform(math.radians(-120.0), -1e-3, n)
    c = rng.uniform(-np.pi, np.pi, n)
    tool = np.stack([np.sin(a) * np.sin(c), np.sin(a) * np.cos(c), np.cos(a)], axis=-1)
    tool /= np.linalg.norm(tool, axis=-1, keepdims=True)
    tip = rng.uniform(-0.08, 0.08, size=(n, 3))
    q = inverse(tip, tool, GEOM)
    tip2, tool2 = forward(q, GEOM)
    assert np.max(np.abs(tip2 - tip)) < 1e-12
    assert np.max(np.abs(tool2 - tool)) < 1e-12


def test_home_pose_joints_equal_workpiece_coordinates():
    q = np.array([0.01, -0.02, 0.03, 0.0, 0.0])
    tip, tool = forward(q, GEOM)
    np.testing.assert_allclose(tip, q[:3], atol=1e-15)
    np.testing.assert_allclose(tool, [0.0, 0.0, 1.0], atol=1e-15)


def test_tool_vector_matches_eq1():
    # o_w = (sin A sin C, sin A cos C, cos A): eq. 1 mirrored (its θ_A = −A, θ_C = −C)
    rng = np.random.default_rng(1602)
    q = _random_joints(rng, 100)
    _, tool = forward(q, GEOM)
    sa, ca, sc, cc = np.sin(q[:, 3]), np.cos(q[:, 3]), np.sin(q[:, 4]), np.cos(q[:, 4])
    np.testing.assert_allclose(tool, np.stack([sa * sc, sa * cc, ca], -1), atol=1e-15)


@pytest.mark.parametrize(
    ("points", "xc"),
    [(_line_points(), LINE_XC), (_circle_points(), CIRCLE_XC)],
    ids=["line", "circle"],
)
def test_test_path_tool_vectors_point_at_xc(points, xc):
    tool = tool_towards(points, xc)
    q = inverse(points, tool, GEOM)  # within the travel (checked)
    tip, tool_fk = forward(q, GEOM)
    np.testing.assert_allclose(tip, points, atol=1e-12)
    # the tool axis through the tip passes through X_c, the vector pointing away from it
    to_xc = xc - tip
    dist = np.linalg.norm(to_xc, axis=-1)
    assert np.max(np.linalg.norm(np.cross(tool_fk, to_xc), axis=-1) / dist) < 1e-12
    np.testing.assert_allclose(np.einsum("ij,ij->i", tool_fk, to_xc) / dist, -1.0, atol=1e-12)


def test_circle_path_c_continuous_with_reference():
    points = _circle_points(2001)
    tool = tool_towards(points, CIRCLE_XC)
    c_ref = 0.0
    cs = []
    for p, o in zip(points, tool, strict=True):
        c_ref = inverse(p, o, GEOM, c_ref=c_ref)[4]
        cs.append(c_ref)
    assert np.max(np.abs(np.diff(cs))) < 0.01


def test_c_unwrapped_near_reference():
    q = np.array([0.01, 0.02, 0.0, -0.7, 0.4])
    tip, tool = forward(q, GEOM)
    for turns in (-3, 5):
        ref = 0.4 + 2 * np.pi * turns + 2.5  # within π of the true C + turns
        back = inverse(tip, tool, GEOM, c_ref=ref)
        assert back[4] == pytest.approx(0.4 + 2 * np.pi * turns, abs=1e-12)
        np.testing.assert_allclose(back[:4], q[:4], atol=1e-12)
    assert inverse(tip, tool, GEOM)[4] == pytest.approx(0.4, abs=1e-12)


@pytest.mark.parametrize("c_ref", [None, 1.3, -7.0])
def test_singular_pose_keeps_c_ref(c_ref):
    tip = np.array([0.02, -0.03, 0.05])
    tool = np.array([0.0, 0.0, 1.0])
    q = inverse(tip, tool, GEOM, c_ref=c_ref)
    assert q[3] == 0.0
    assert q[4] == (0.0 if c_ref is None else c_ref)
    tip2, tool2 = forward(q, GEOM)
    np.testing.assert_allclose(tip2, tip, atol=1e-15)
    np.testing.assert_allclose(tool2, tool, atol=1e-15)
    # just below the tolerance the same handling applies
    tilt = 0.5 * SINGULAR_TOL
    tool_near = np.array([tilt, 0.0, math.sqrt(1 - tilt**2)])
    assert inverse(tip, tool_near, GEOM, c_ref=c_ref)[4] == (0.0 if c_ref is None else c_ref)


def test_branches_give_the_same_pose():
    q = np.array([0.01, 0.02, 0.01, -0.3, 0.2])
    tip, tool = forward(q, GEOM)
    other = inverse(tip, tool, GEOM, a_branch=1)
    assert other[3] == pytest.approx(0.3, abs=1e-15)
    assert other[4] == pytest.approx(0.2 - np.pi, abs=1e-12)
    tip2, tool2 = forward(other, GEOM)
    np.testing.assert_allclose(tip2, tip, atol=1e-12)
    np.testing.assert_allclose(tool2, tool, atol=1e-12)


@pytest.mark.parametrize(
    ("q", "match"),
    [
        ([0.3, 0.0, 0.0, -0.1, 0.0], r"joint x .*-0\.28…0\.28 m, got 0\.3 m"),
        ([0.0, -0.3, 0.0, -0.1, 0.0], "joint y"),
        ([0.0, 0.0, 0.5, -0.1, 0.0], "joint z"),
        ([0.0, 0.0, 0.0, math.radians(35.0), 0.0], r"joint A .*-120…30 deg, got 35 deg"),
        ([0.0, 0.0, 0.0, math.radians(-121.0), 0.0], "joint A"),
        ([0.0, 0.0, 0.0], r"q: expected shape \(\.\.\., 5\)"),
        ([0.0, 0.0, np.nan, 0.0, 0.0], "q: must be finite"),
    ],
)
def test_check_joint_errors(q, match):
    with pytest.raises(ValueError, match=match):
        GEOM.check_joint(q)


def test_c_travel_limit_checked_when_set():
    geom = FiveAxisGeometry(c_travel_rad=(-2 * np.pi, 2 * np.pi))
    with pytest.raises(ValueError, match=r"joint C .*-360…360 deg"):
        geom.check_joint([0.0, 0.0, 0.0, -0.1, 7.0])
    GEOM.check_joint([0.0, 0.0, 0.0, -0.1, 1e4])  # unlimited by default


def test_bad_inverse_input():
    tip = np.zeros(3)
    with pytest.raises(ValueError, match="tool: must be unit vectors"):
        inverse(tip, [0.0, 0.0, 2.0], GEOM)
    with pytest.raises(ValueError, match=r"tip: expected shape \(\.\.\., 3\)"):
        inverse([0.0, 0.0], [0.0, 0.0, 1.0], GEOM)
    with pytest.raises(ValueError, match="tip: must be finite"):
        inverse([np.nan, 0.0, 0.0], [0.0, 0.0, 1.0], GEOM)
    with pytest.raises(ValueError, match="a_branch"):
        inverse(tip, [0.0, 0.0, 1.0], GEOM, a_branch=0)
    with pytest.raises(ValueError, match="c_ref: must be finite"):
        inverse(tip, [0.0, 0.0, 1.0], GEOM, c_ref=np.inf)
    # a tool vector pointing down needs A = −180°: beyond the trunnion's travel
    with pytest.raises(ValueError, match="joint A"):
        inverse(tip, [0.0, 0.0, -1.0], GEOM)
    with pytest.raises(ValueError, match="xc: the fixed point"):
        tool_towards(LINE_XC, LINE_XC)
    with pytest.raises(ValueError, match=r"q: expected shape"):
        forward(np.zeros(4), GEOM)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"dtool_m": 0.0}, "dtool_m: must be > 0"),
        ({"d1_m": -0.1}, "d1_m: must be >= 0"),
        ({"d4_m": float("nan")}, "d4_m: expected a finite length"),
        ({"x_travel_m": (0.2, -0.2)}, "x_travel_m: expected min < max"),
        ({"a_travel_rad": (-4.0, 0.5)}, r"a_travel_rad: must lie within \[-pi, pi\]"),
        ({"z_travel_m": 0.3}, r"z_travel_m: expected \(min, max\)"),
    ],
)
def test_bad_geometry(kwargs, match):
    with pytest.raises(ValueError, match=match):
        FiveAxisGeometry(**kwargs)
