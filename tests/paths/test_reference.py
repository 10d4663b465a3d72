"""Reference tables: layout, consistency with finite differences and closed forms, speed."""

import math
import time

import numpy as np
import pytest

from contour_env.paths import (
    FeedProfile,
    ReferenceTrajectory,
    circle,
    helix,
    inclined_circle,
    line,
    polyline,
    spline,
)

T = 1e-3


def build(path, F=0.2, amax=2.0, jmax=40.0, settle=0.0, T=T):
    prof = FeedProfile.build(path, F, max_accel_m_s2=amax, max_jerk_m_s3=jmax)
    return prof, ReferenceTrajectory.build(path, prof, T, settle_time_s=settle)


def test_table_layout():
    path = circle((0, 0), 0.05)
    prof, ref = build(path, settle=0.1)
    n = math.ceil((prof.duration + 0.1) / T) + 1
    assert ref.n_steps == n and ref.servo_period_s == T and ref.dim == 2
    np.testing.assert_array_equal(ref.time, np.arange(n) * T)
    shapes = {
        "time": (n,),
        "arc_length": (n,),
        "feedrate": (n,),
        "feed_accel": (n,),
        "position": (n, 3),
        "velocity": (n, 3),
        "acceleration": (n, 3),
        "frame": (n, 3, 3),
        "curvature": (n,),
        "torsion": (n,),
    }
    for name, shape in shapes.items():
        arr = getattr(ref, name)
        assert arr.shape == shape and arr.dtype == np.float64 and arr.flags.c_contiguous, name
    assert build(helix((0, 0, 0), 0.01, 0.002, 1.0))[1].dim == 3


@pytest.mark.parametrize(
    "make",
    [
        lambda: circle((0, 0), 0.06, start_angle=-math.pi / 2),
        lambda: inclined_circle((0, 0, 0), 0.06, math.radians(30)),
        lambda: helix((0, 0, 0), 0.03, 0.01, 1.5),
        lambda: spline([(0, 0), (0.03, 0.02), (0.06, -0.01), (0.1, 0.01)]),
    ],
)
def test_velocity_and_acceleration_match_finite_differences(make):
    path = make()
    _, ref = build(path, F=0.2, settle=0.02)
    vel_fd = np.gradient(ref.position, T, axis=0)[1:-1]
    np.testing.assert_allclose(vel_fd, ref.velocity[1:-1], atol=2e-5)
    acc_fd = np.gradient(ref.velocity, T, axis=0)[2:-2]
    np.testing.assert_allclose(acc_fd, ref.acceleration[2:-2], atol=0.02)
    # second differences of position: the acceleration is the true d²p/dt², also on the
    # straight-and-curved mix of the ramps
    acc2 = (ref.position[2:] - 2 * ref.position[1:-1] + ref.position[:-2]) / T**2
    np.testing.assert_allclose(acc2, ref.acceleration[1:-1], atol=0.01)
    np.testing.assert_allclose(np.linalg.norm(ref.velocity, axis=1), ref.feedrate, atol=1e-15)


def test_reference_matches_profile_and_frames():
    path = helix((0, 0, 0), 0.03, 0.01, 1.5)
    prof, ref = build(path)
    s, sd, sdd = prof.sample(ref.time)
    np.testing.assert_array_equal(ref.arc_length, s)
    np.testing.assert_array_equal(ref.feedrate, sd)
    np.testing.assert_array_equal(ref.feed_accel, sdd)
    F, k, tau = path.frames(s)
    np.testing.assert_array_equal(ref.frame, F)
    np.testing.assert_array_equal(ref.curvature, k)
    np.testing.assert_array_equal(ref.torsion, tau)
    # acceleration in the task frame: s̈ along t, ṡ² κ along n, nothing along b
    acc_f = np.einsum("nij,ni->nj", ref.frame, ref.acceleration)
    np.testing.assert_allclose(acc_f[:, 0], sdd, atol=1e-13)
    np.testing.assert_allclose(acc_f[:, 1], sd**2 * k, atol=1e-12)
    np.testing.assert_allclose(acc_f[:, 2], 0.0, atol=1e-12)


def test_centripetal_acceleration_at_cruise_and_settle_hold():
    path = circle((0, 0), 0.06, start_angle=-math.pi / 2)
    _, ref = build(path, F=0.4, settle=0.1)
    cruise = ref.feedrate == 0.4
    assert cruise.sum() > 100
    acc_n = np.einsum("ij,ij->i", ref.acceleration, ref.frame[:, :, 1])
    np.testing.assert_allclose(acc_n[cruise], 0.4**2 / 0.06, rtol=1e-12)
    held = ref.time >= ref.time[-1] - 0.1 + T
    assert held.sum() >= 99
    np.testing.assert_array_equal(ref.velocity[held], 0.0)
    np.testing.assert_array_equal(ref.acceleration[held], 0.0)
    np.testing.assert_allclose(ref.position[held], [[0, -0.06, 0]] * held.sum(), atol=1e-15)
    assert ref.arc_length[-1] == path.total_length


def test_straight_segments_and_corner_stops():
    path = polyline([(0, 0), (0.02, 0), (0.02, 0.02)])
    prof, ref = build(path, F=0.05)
    np.testing.assert_array_equal(ref.curvature, 0.0)
    # along a straight, acceleration is s̈ t only
    np.testing.assert_allclose(ref.acceleration, ref.feed_accel[:, None] * ref.frame[:, :, 0])
    # the reference passes through the corner at rest
    k = int(np.argmin(np.linalg.norm(ref.position - [0.02, 0, 0], axis=1)))
    assert np.linalg.norm(ref.velocity[k]) < 1e-3
    assert np.min(np.linalg.norm(ref.position - [0.02, 0, 0], axis=1)) < 1e-9


def test_build_is_fast_for_a_long_circle():
    path = circle((0, 0), 0.1)
    # about 160 000 servo periods of 1 ms
    prof = FeedProfile.build(path, 0.004, max_accel_m_s2=1.0, max_jerk_m_s3=20.0)
    ReferenceTrajectory.build(path, prof, T)  # warm-up
    t0 = time.perf_counter()
    ref = ReferenceTrajectory.build(path, prof, T, settle_time_s=3.0)
    elapsed = time.perf_counter() - t0
    assert ref.n_steps >= 160_000
    assert elapsed < 1.0


@pytest.mark.parametrize(
    "period, settle, name",
    [
        (0.0, 0.0, "servo_period_s"),
        (-1e-3, 0.0, "servo_period_s"),
        (float("nan"), 0.0, "servo_period_s"),
        (1e-3, -0.1, "settle_time_s"),
        (1e-3, float("inf"), "settle_time_s"),
    ],
)
def test_bad_reference_inputs_name_the_parameter(period, settle, name):
    path = circle((0, 0), 0.1)
    prof = FeedProfile.build(path, 0.1, max_accel_m_s2=1.0, max_jerk_m_s3=10.0)
    with pytest.raises(ValueError, match=name):
        ReferenceTrajectory.build(path, prof, period, settle_time_s=settle)


def test_profile_for_another_path_is_rejected():
    prof = FeedProfile.build(line((0, 0), (0.1, 0)), 0.1, max_accel_m_s2=1, max_jerk_m_s3=10)
    with pytest.raises(ValueError, match="profile"):
        ReferenceTrajectory.build(circle((0, 0), 0.1), prof, 1e-3)
