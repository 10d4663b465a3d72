"""Cosine S-curve feed profile: limits, exact stops, short sections, closed form."""

import math

import numpy as np
import pytest

from contour_env.paths import FeedProfile, circle, line, polyline
from contour_env.paths.feed import Section, fitting_feed, ramp_time


def sampled(profile, dt=1e-5, tail=0.05):
    t = np.arange(-0.01, profile.duration + tail, dt)
    s, v, a = profile.sample(t)
    return t, s, v, a


@pytest.mark.parametrize(
    "F, amax, jmax",
    [(0.4, 2.0, 40.0), (0.4, 20.0, 40.0), (0.05, 0.5, 1000.0)],  # jerk- and accel-limited
)
def test_limits_and_end(F, amax, jmax):
    path = circle((0, 0), 0.1)
    prof = FeedProfile.build(path, F, max_accel_m_s2=amax, max_jerk_m_s3=jmax)
    assert len(prof.sections) == 1
    t, s, v, a = sampled(prof)
    assert s[-1] == path.total_length and v[-1] == 0.0 and a[-1] == 0.0
    assert s[0] == 0.0 and v[0] == 0.0
    assert np.all(np.diff(s) >= 0)
    assert np.all(v >= 0) and np.max(v) <= F * (1 + 1e-15)
    assert np.max(np.abs(a)) <= amax * (1 + 1e-12)
    jerk = np.diff(a) / np.diff(t)
    assert np.max(np.abs(jerk)) <= jmax * (1 + 1e-3)
    # the binding limit is reached
    ta = ramp_time(F, amax, jmax)
    assert max(np.max(np.abs(a)) / amax, np.max(np.abs(jerk)) / jmax) > 0.99
    assert prof.sections[0].ramp_time == pytest.approx(ta, rel=1e-12)
    assert prof.duration == pytest.approx(path.total_length / F + ta, rel=1e-12)
    # s, v, a are consistent derivatives
    inner = slice(1, -1)
    np.testing.assert_allclose(np.gradient(s, t)[inner], v[inner], atol=1e-7)
    np.testing.assert_allclose(np.gradient(v, t)[inner], a[inner], atol=1e-5 * jmax)


def test_closed_form_values():
    F, amax, jmax = 0.2, 1.0, 1e6  # acceleration-limited: Ta = π F / (2 a)
    path = line((0, 0), (1, 0))
    prof = FeedProfile.build(path, F, max_accel_m_s2=amax, max_jerk_m_s3=jmax)
    ta = math.pi * F / (2 * amax)
    s, v, a = prof.sample(np.array([ta / 2, ta, prof.duration - ta / 2]))
    np.testing.assert_allclose(v, [F / 2, F, F / 2], rtol=1e-14)
    np.testing.assert_allclose(a, [amax, 0.0, -amax], atol=1e-14)
    assert s[0] == pytest.approx(0.5 * F * (ta / 2 - ta / math.pi), rel=1e-14)
    assert s[1] == pytest.approx(F * ta / 2, rel=1e-14)
    assert s[2] == pytest.approx(1.0 - 0.5 * F * (ta / 2 - ta / math.pi), rel=1e-14)


def test_exact_stop_at_polyline_corners():
    path = polyline([(0, 0), (0.03, 0), (0.03, 0.03), (0.05, 0.05)])
    prof = FeedProfile.build(path, 0.02, max_accel_m_s2=0.5, max_jerk_m_s3=10.0)
    assert len(prof.sections) == 3
    ends = [sec.t_end for sec in prof.sections]
    s, v, a = prof.sample(np.array(ends))
    np.testing.assert_allclose(s, np.concatenate([path.corner_arc_lengths(), [path.total_length]]))
    np.testing.assert_array_equal(v, 0.0)
    np.testing.assert_array_equal(a, 0.0)
    for prev, nxt in zip(prof.sections[:-1], prof.sections[1:], strict=True):
        assert nxt.t_start == prev.t_end and nxt.s_start == prev.s_end
    # sections are plain (s_start, s_end, peak_feed, t_start, t_end) tuples
    s_start, s_end, peak, t0, t1 = prof.sections[1]
    assert isinstance(prof.sections[1], Section)
    assert (s_start, s_end, peak) == (0.03, 0.06, 0.02) and t1 > t0


def test_smooth_junctions_do_not_stop():
    path = circle((0, 0), 0.05, sweep=math.pi)
    prof = FeedProfile.build(path, 0.1, max_accel_m_s2=1.0, max_jerk_m_s3=50.0)
    assert len(prof.sections) == 1
    # a corner below the tolerance is driven through; above it, stopped at
    slight = polyline([(0, 0), (0.1, 0), (0.2, 1e-5)])
    assert len(FeedProfile.build(slight, 0.1, max_accel_m_s2=1, max_jerk_m_s3=50).sections) == 1
    stop = FeedProfile.build(slight, 0.1, max_accel_m_s2=1, max_jerk_m_s3=50, corner_tol_rad=1e-5)
    assert len(stop.sections) == 2


@pytest.mark.parametrize("amax, jmax", [(1.0, 1e5), (1e3, 100.0)])
def test_short_section_lowers_the_peak_feed(amax, jmax):
    L = 0.001
    path = line((0, 0), (L, 0))
    prof = FeedProfile.build(path, 0.5, max_accel_m_s2=amax, max_jerk_m_s3=jmax)
    sec = prof.sections[0]
    Fp = sec.peak_feed
    assert Fp < 0.5
    assert Fp * ramp_time(Fp, amax, jmax) == pytest.approx(L, rel=1e-12)
    assert Fp == pytest.approx(fitting_feed(L, amax, jmax), rel=1e-15)
    assert sec.cruise_time == pytest.approx(0.0, abs=1e-15)
    t, s, v, a = sampled(prof, 1e-6, 0.001)
    assert s[-1] == L and v[-1] == 0.0
    assert np.max(v) <= Fp * (1 + 1e-12)
    assert np.max(np.abs(a)) <= amax * (1 + 1e-9)
    assert np.max(np.abs(np.diff(a) / np.diff(t))) <= jmax * (1 + 1e-3)


def test_fitting_feed_solves_the_ramp_equation():
    for L in np.geomspace(1e-6, 10, 15):
        for amax, jmax in [(1.0, 10.0), (5.0, 1e4), (0.1, 1.0)]:
            F = fitting_feed(L, amax, jmax)
            assert F * ramp_time(F, amax, jmax) == pytest.approx(L, rel=1e-12)


def test_segment_feeds_split_sections():
    path = polyline([(0, 0), (0.05, 0), (0.1, 0), (0.15, 0)])  # collinear: no corners
    prof = FeedProfile.build(path, 0.1, max_accel_m_s2=2.0, max_jerk_m_s3=100.0)
    assert len(prof.sections) == 1
    prof = FeedProfile.build(
        path, 0.1, max_accel_m_s2=2.0, max_jerk_m_s3=100.0, segment_feeds=[0.02, 0.02, 0.05]
    )
    assert [(s.s_start, s.s_end, s.peak_feed) for s in prof.sections] == [
        (0.0, pytest.approx(0.1), 0.02),
        (pytest.approx(0.1), pytest.approx(0.15), 0.05),
    ]
    t, s, v, _ = sampled(prof, 1e-4)
    assert np.max(v[s < 0.1 - 1e-9]) <= 0.02 * (1 + 1e-15)
    assert np.max(v) == pytest.approx(0.05)


def test_sample_outside_the_profile():
    prof = FeedProfile.build(line((0, 0), (0.1, 0)), 0.1, max_accel_m_s2=1, max_jerk_m_s3=50)
    s, v, a = prof.sample([-1.0, prof.duration, prof.duration + 5.0])
    np.testing.assert_array_equal(s, [0.0, 0.1, 0.1])
    np.testing.assert_array_equal(v, 0.0)
    np.testing.assert_array_equal(a, 0.0)
    s, v, a = prof.sample(0.01)  # scalar in, (1,) out
    assert s.shape == v.shape == a.shape == (1,)


@pytest.mark.parametrize(
    "args, kw, name",
    [
        ((0.0,), {}, "feedrate_m_s"),
        ((-0.1,), {}, "feedrate_m_s"),
        ((float("nan"),), {}, "feedrate_m_s"),
        ((0.1,), {"max_accel_m_s2": 0.0}, "max_accel_m_s2"),
        ((0.1,), {"max_accel_m_s2": float("inf")}, "max_accel_m_s2"),
        ((0.1,), {"max_jerk_m_s3": -1.0}, "max_jerk_m_s3"),
        ((0.1,), {"corner_tol_rad": -1.0}, "corner_tol_rad"),
        ((0.1,), {"segment_feeds": [0.1, 0.1]}, "segment_feeds"),
        ((0.1,), {"segment_feeds": [0.0]}, "segment_feeds"),
    ],
)
def test_bad_profile_inputs_name_the_parameter(args, kw, name):
    kwargs = {"max_accel_m_s2": 1.0, "max_jerk_m_s3": 10.0, **kw}
    with pytest.raises(ValueError, match=name):
        FeedProfile.build(circle((0, 0), 0.1), *args, **kwargs)
