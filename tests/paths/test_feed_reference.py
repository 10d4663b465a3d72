"""Feed profile limits and the reference table, against finite differences."""

import math

import numpy as np
import pytest

from contour_env.paths import FeedProfile, ReferenceTrajectory, circle, polyline


def _derivs(profile, dt=1e-5):
    t = np.arange(0, profile.duration + 0.05, dt)
    s, v, a = profile.sample(t)
    return t, s, v, a


def test_profile_respects_feed_acceleration_and_jerk_limits():
    path = circle((0, 0), 0.1)
    F, amax, jmax = 0.4, 2.0, 40.0
    prof = FeedProfile.build(path, F, max_accel_m_s2=amax, max_jerk_m_s3=jmax)
    t, s, v, a = _derivs(prof)
    assert s[-1] == pytest.approx(path.total_length, abs=1e-12)
    assert v[-1] == 0.0 and np.all(v <= F + 1e-12) and np.all(v >= 0)
    assert np.max(np.abs(a)) <= amax * (1 + 1e-9)
    jerk = np.diff(a) / np.diff(t)
    assert np.max(np.abs(jerk)) <= jmax * (1 + 1e-3)
    # s, v, a are consistent derivatives
    np.testing.assert_allclose(np.gradient(s, t)[1:-1], v[1:-1], atol=1e-6)
    np.testing.assert_allclose(np.gradient(v, t)[1:-1], a[1:-1], atol=2e-3)


def test_exact_stop_at_polyline_corners():
    path = polyline([(0, 0), (0.03, 0), (0.03, 0.03)])
    prof = FeedProfile.build(path, 0.02, max_accel_m_s2=0.5, max_jerk_m_s3=10.0)
    assert len(prof.sections) == 2
    t_corner = prof.sections[0].t_end
    s, v, _ = prof.sample(np.array([t_corner]))
    assert s[0] == pytest.approx(0.03) and v[0] == pytest.approx(0.0, abs=1e-12)


def test_short_section_lowers_the_peak_feed():
    path = polyline([(0, 0), (0.001, 0)])
    prof = FeedProfile.build(path, 0.5, max_accel_m_s2=1.0, max_jerk_m_s3=100.0)
    sec = prof.sections[0]
    assert sec.peak_feed < 0.5 and sec.cruise_time == pytest.approx(0.0, abs=1e-12)
    t, s, v, a = _derivs(prof, 1e-6)
    assert s[-1] == pytest.approx(0.001, abs=1e-12)
    assert np.max(np.abs(a)) <= 1.0 * (1 + 1e-9)


def test_reference_velocity_and_acceleration_match_finite_differences():
    path = circle((0, 0), 0.06, start_angle=-math.pi / 2)
    prof = FeedProfile.build(path, 0.4, max_accel_m_s2=2.0, max_jerk_m_s3=40.0)
    ref = ReferenceTrajectory.build(path, prof, 1e-3, settle_time_s=0.1)
    T = 1e-3
    assert ref.n_steps == math.ceil((prof.duration + 0.1) / T) + 1
    np.testing.assert_allclose(
        np.gradient(ref.position, T, axis=0)[1:-1], ref.velocity[1:-1], atol=5e-5
    )
    np.testing.assert_allclose(
        np.gradient(ref.velocity, T, axis=0)[2:-2], ref.acceleration[2:-2], atol=0.05
    )
    # centripetal acceleration F²/ρ at cruise
    cruise = ref.feedrate > 0.4 - 1e-12
    acc_n = np.einsum("ij,ij->i", ref.acceleration, ref.frame[:, :, 1])
    np.testing.assert_allclose(acc_n[cruise], 0.4**2 / 0.06, rtol=1e-9)
    # the settle time holds the end point at rest
    assert np.all(ref.velocity[-50:] == 0.0)
    np.testing.assert_allclose(ref.position[-1], [0, -0.06, 0], atol=1e-15)


@pytest.mark.parametrize(
    "kw, name",
    [({"max_accel_m_s2": 0.0}, "max_accel_m_s2"), ({"max_jerk_m_s3": -1.0}, "max_jerk_m_s3")],
)
def test_bad_profile_limits(kw, name):
    args = {"max_accel_m_s2": 1.0, "max_jerk_m_s3": 10.0, **kw}
    with pytest.raises(ValueError, match=name):
        FeedProfile.build(circle((0, 0), 0.1), 0.1, **args)
    with pytest.raises(ValueError, match="feedrate_m_s"):
        FeedProfile.build(circle((0, 0), 0.1), 0.0, max_accel_m_s2=1.0, max_jerk_m_s3=10.0)


def test_bad_servo_period():
    path = circle((0, 0), 0.1)
    prof = FeedProfile.build(path, 0.1, max_accel_m_s2=1.0, max_jerk_m_s3=10.0)
    with pytest.raises(ValueError, match="servo_period_s"):
        ReferenceTrajectory.build(path, prof, 0.0)
