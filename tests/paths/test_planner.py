"""Look-ahead feed planner (issue 15): G64 junction speeds, G61 stops, dwells, jerk-bounded
transitions between speeds, the exact-stop profile unchanged, long programs.

Limits used unless stated: a_max = 2 m/s², j_max = 40 m/s³ (what `contour_env.cases` uses for a
custom path or G-code program), feed 0.1 m/s (F6000 mm/min).
"""

import math
import time

import numpy as np
import pytest

from contour_env.paths import (
    FeedProfile,
    PathGeometry,
    ReferenceTrajectory,
    circle,
    line,
    polyline,
    spline,
)
from contour_env.paths import reference as reference_mod
from contour_env.paths.feed import Block, fitting_feed, ramp_time
from contour_env.paths.planner import junction_speed, reach_speed, transition_distance
from contour_env.paths.segments import Line

A_MAX, J_MAX, FEED = 2.0, 40.0, 0.1


def bent_polyline(n=100, seg_m=0.005, bend_deg=1.0, alternate=True):
    """n segments of seg_m m, turning by bend_deg at every joint (alternating or constant)."""
    sign = np.where(np.arange(n - 1) % 2 == 0, 1.0, -1.0) if alternate else np.ones(n - 1)
    heading = np.concatenate([[0.0], np.cumsum(sign * math.radians(bend_deg))])
    steps = seg_m * np.c_[np.cos(heading), np.sin(heading)]
    return polyline(np.vstack([[0.0, 0.0], np.cumsum(steps, axis=0)]))


def build(path, feed=FEED, a=A_MAX, j=J_MAX, **kw):
    return FeedProfile.build(path, feed, max_accel_m_s2=a, max_jerk_m_s3=j, **kw)


def dense(profile, dt=1e-4, tail=0.02):
    t = np.arange(-0.01, profile.duration + tail, dt)
    s, v, a = profile.sample(t)
    return t, s, v, a


def assert_limits(profile, a_max, j_max, dt=1e-4, feed_max=None):
    """|s̈| ≤ a_max and |s⃛| ≤ j_max by finite differences of sampled s(t); the sampled ṡ, s̈
    match; s, ṡ continuous; ends at rest at the path end."""
    t, s, v, a = dense(profile, dt)
    acc = np.diff(s, 2) / dt**2
    jerk = np.diff(s, 3) / dt**3
    assert np.max(np.abs(acc)) <= a_max * (1 + 1e-6)
    assert np.max(np.abs(jerk)) <= j_max * (1 + 2e-3)
    assert np.max(np.abs(a)) <= a_max * (1 + 1e-12)
    assert np.max(np.abs(np.diff(a) / dt)) <= j_max * (1 + 1e-9)
    assert np.all(np.diff(s) >= 0) and np.all(v >= 0)
    if feed_max is not None:
        assert np.max(v) <= feed_max * (1 + 1e-12)
    # continuity: per step, s moves by at most v_max dt and ṡ by at most a_max dt
    v_top = max(b.peak_feed for b in profile.sections)
    assert np.max(v) <= v_top * (1 + 1e-12)
    assert np.max(np.diff(s)) <= v_top * dt * (1 + 1e-9) + 1e-15
    assert np.max(np.abs(np.diff(v))) <= a_max * dt * (1 + 1e-9)
    np.testing.assert_allclose(np.gradient(s, t)[1:-1], v[1:-1], atol=j_max * dt**2)
    assert s[-1] == profile.total_length and v[-1] == 0.0 and a[-1] == 0.0
    assert s[0] == 0.0 and v[0] == 0.0
    # continuity exactly at every block boundary (just before vs at it)
    bounds = np.array([b.t_start for b in profile.sections[1:]])
    if bounds.size:
        s0, v0, a0 = profile.sample(np.nextafter(bounds, -np.inf))
        s1, v1, a1 = profile.sample(bounds)
        np.testing.assert_allclose(s0, s1, rtol=0, atol=1e-12)
        np.testing.assert_allclose(v0, v1, rtol=0, atol=1e-9)
        np.testing.assert_allclose(a0, a1, rtol=0, atol=1e-6)


# ------------------------------------------------------------------ acceptance: issue 15
@pytest.mark.parametrize("alternate", [True, False])
def test_g64_polyline_of_1deg_bends_runs_at_the_programmed_feed(alternate):
    path = bent_polyline(alternate=alternate)
    n = path.n_segments
    prof = build(path, segment_blend_m=np.full(n, 1e-5))
    L = path.total_length
    assert L == pytest.approx(0.5)
    assert prof.duration <= 1.2 * (L / FEED + 2 * FEED / A_MAX)
    # in fact one ramp up, 0.5 m at the feed, one ramp down: grbl allows far more than the
    # feed at a 1° bend, so the bends constrain nothing and the polyline is one block
    assert junction_speed(math.radians(1), 1e-5, A_MAX, J_MAX) > FEED
    assert len(prof.sections) == 1
    assert prof.duration == pytest.approx(L / FEED + ramp_time(FEED, A_MAX, J_MAX), rel=1e-12)
    s_j = path.seg_s0[1:]
    t, s, v, _ = dense(prof)
    at_j = np.interp(s_j, s, v)
    np.testing.assert_allclose(at_j[1:-1], FEED, rtol=1e-9)
    assert min(at_j[0], at_j[-1]) > 0.9 * FEED  # still on the ramps
    assert_limits(prof, A_MAX, J_MAX, feed_max=FEED)
    # the same with the junction speed just below the feed: every bend is a junction, passed
    # at its grbl speed without stopping
    delta = 1e-5 * (0.099 / float(junction_speed(math.radians(1), 1e-5, A_MAX, 1e12))) ** 2
    prof = build(path, j=1e12, segment_blend_m=np.full(n, delta))
    assert len(prof.sections) == n
    v_j = float(junction_speed(math.radians(1), delta, A_MAX, 1e12))
    assert v_j == pytest.approx(0.099, rel=1e-9)
    inner = prof.sections[3:-3]  # the ramps up and down span a few blocks
    assert all(b.v_in == pytest.approx(v_j, rel=1e-12) for b in inner)
    assert all(b.peak_feed <= FEED for b in prof.sections)
    assert prof.duration <= 1.2 * (L / FEED + 2 * FEED / A_MAX)


@pytest.mark.parametrize("alternate", [True, False])
def test_g61_polyline_stops_at_every_bend(alternate):
    path = bent_polyline(alternate=alternate)
    n = path.n_segments
    prof = build(path, segment_blend_m=np.zeros(n))
    assert len(prof.sections) == n
    s_j = path.seg_s0[1:]
    # at each block end: exactly at the junction's arc length, at rest
    ends = np.array([b.t_end for b in prof.sections[:-1]])
    s, v, a = prof.sample(ends)
    np.testing.assert_allclose(s, s_j, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(v, 0.0)
    # and sampled densely, the speed is ~0 wherever the tool passes a junction: at the samples
    # just before and after it reaches each junction's arc length
    t, s, v, _ = dense(prof, 1e-4)
    i = np.searchsorted(s, s_j)
    assert np.all(s[i - 1] < s_j) and np.all(s[i] >= s_j)
    assert np.max(v[i - 1]) < 1e-3 * FEED and np.max(v[i]) < 1e-3 * FEED
    # G61 everywhere is the exact-stop profile: same blocks and duration
    legacy = build(path)
    assert prof.duration == pytest.approx(legacy.duration, rel=1e-12)
    g64 = build(path, segment_blend_m=np.full(n, 1e-5))
    assert prof.duration > 2 * g64.duration
    assert_limits(prof, A_MAX, J_MAX, feed_max=FEED)


def test_dwell_adds_its_time_at_rest_at_that_point():
    path = polyline([(0, 0), (0.05, 0), (0.1, 0)])  # collinear: no corner
    plain = build(path, segment_blend_m=[1e-5, 1e-5])
    assert len(plain.sections) == 1
    dwell = 0.25
    prof = build(path, segment_blend_m=[1e-5, 1e-5], segment_dwell_s=[dwell, 0.0])
    assert len(prof.sections) == 2
    b0, b1 = prof.sections
    assert (b0.v_out, b0.dwell_s, b1.v_in) == (0.0, dwell, 0.0)
    assert b1.t_start == pytest.approx(b0.t_end + dwell, rel=1e-15)
    # two rest-to-rest stretches of 0.05 m at the feed, plus the dwell
    one = 0.05 / FEED + ramp_time(FEED, A_MAX, J_MAX)
    assert prof.duration == pytest.approx(2 * one + dwell, rel=1e-12)
    t = np.linspace(b0.t_end, b0.t_end + dwell, 101)
    s, v, a = prof.sample(t)
    np.testing.assert_array_equal(s, 0.05)
    np.testing.assert_array_equal(v, 0.0)
    np.testing.assert_array_equal(a, 0.0)
    assert_limits(prof, A_MAX, J_MAX, feed_max=FEED)
    # a dwell after the last segment: at rest at the end, counted in the duration
    tail = build(path, segment_blend_m=[1e-5, 1e-5], segment_dwell_s=[0.0, 0.5])
    assert tail.duration == pytest.approx(plain.duration + 0.5, rel=1e-12)
    s, v, _ = tail.sample([plain.duration, plain.duration + 0.25])
    np.testing.assert_array_equal(s, path.total_length)
    np.testing.assert_array_equal(v, 0.0)
    # a dwell without blend tolerances: the exact-stop rules plus the dwell
    g61 = build(path, segment_dwell_s=[dwell, 0.0])
    assert g61.duration == pytest.approx(prof.duration, rel=1e-12)


def grbl_speed(theta, delta, a):
    """grbl planner.c: v² = a δ sin(φ/2) / (1 − sin(φ/2)), φ = π − θ."""
    sin_half = math.sin((math.pi - theta) / 2)
    return math.sqrt(a * delta * sin_half / (1 - sin_half))


def corner_path(theta):
    return polyline([(0, 0), (0.05, 0), (0.05 + 0.05 * math.cos(theta), 0.05 * math.sin(theta))])


def junction_of(prof, path):
    """The speed the sampled profile has at the corner's arc length."""
    (b0, b1) = prof.sections
    s, v, _ = prof.sample([b0.t_end])
    assert s[0] == pytest.approx(path.seg_s0[1], abs=1e-15)
    assert b0.v_out == b1.v_in == v[0]
    return v[0]


def test_junction_speed_is_grbls_on_a_90_degree_corner():
    path = corner_path(math.pi / 2)
    delta = 1e-4
    # with a generous jerk limit the acceleration rule (grbl's) binds
    prof = build(path, j=1e4, segment_blend_m=[delta, delta])
    expect = grbl_speed(math.pi / 2, delta, A_MAX)
    assert expect == pytest.approx(math.sqrt(A_MAX * delta * (1 + math.sqrt(2))), rel=1e-12)
    assert junction_of(prof, path) == pytest.approx(expect, rel=1e-12)
    assert_limits(prof, A_MAX, 1e4, dt=1e-5, feed_max=FEED)
    # with j_max = 40 m/s³ the jerk of uniform motion on grbl's arc binds: v³ / R² = j_max
    prof = build(path, segment_blend_m=[delta, delta])
    R = delta * math.sin(math.pi / 4) / (1 - math.sin(math.pi / 4))
    v = junction_of(prof, path)
    assert v == pytest.approx((J_MAX * R * R) ** (1 / 3), rel=1e-12)
    assert v < expect and v**2 / R < A_MAX
    # a large tolerance: capped by the feed; the axis velocity jumps by 2 v sin(θ/2)
    # (then the corner constrains nothing: one block, the corner passed at the feed)
    prof = build(path, segment_blend_m=[1.0, 1.0])
    assert len(prof.sections) == 1
    s, v, _ = prof.sample(np.linspace(0, prof.duration, 20001))
    assert np.interp(0.05, s, v) == pytest.approx(FEED, rel=1e-12)
    # zero tolerance at that corner: exact stop
    prof = build(path, segment_blend_m=[0.0, 1.0])
    assert junction_of(prof, path) == 0.0


@pytest.mark.parametrize("deg", [1.0, 10.0, 45.0, 120.0, 179.0])
def test_junction_speed_formula(deg):
    theta = math.radians(deg)
    delta = 2e-5
    v = float(junction_speed(theta, delta, A_MAX, 1e12))
    assert v == pytest.approx(grbl_speed(theta, delta, A_MAX), rel=1e-9)
    # reversal: stop; straight: unbounded
    assert float(junction_speed(math.pi, delta, A_MAX, J_MAX)) == pytest.approx(0.0, abs=1e-9)
    assert float(junction_speed(0.0, delta, A_MAX, J_MAX)) == math.inf


def test_feed_change_without_corner_does_not_stop_under_g64():
    path = polyline([(0, 0), (0.05, 0), (0.1, 0), (0.15, 0)])
    feeds = [0.1, 0.04, 0.08]
    prof = build(path, segment_feeds=feeds, segment_blend_m=np.full(3, 1e-5))
    assert [round(b.v_in, 12) for b in prof.sections] == [0.0, 0.04, 0.04]
    assert [b.peak_feed for b in prof.sections] == [0.1, 0.04, 0.08]
    t, s, v, _ = dense(prof, 1e-5)
    seg_of = path.segment_index(s)
    assert np.all(v <= np.asarray(feeds)[seg_of] * (1 + 1e-12))
    assert np.min(v[(s > 0.01) & (s < 0.14)]) >= 0.04 * (1 - 1e-9)  # never stops inside
    assert_limits(prof, A_MAX, J_MAX, feed_max=0.1)
    # under G61 (blend 0) the feed change is an exact stop, as in the exact-stop profile
    g61 = build(path, segment_feeds=feeds, segment_blend_m=np.zeros(3))
    assert g61.sections[1].v_in == 0.0
    assert g61.duration == pytest.approx(build(path, segment_feeds=feeds).duration, rel=1e-12)


def test_look_ahead_brakes_over_many_short_blocks():
    # 1 m straight, then 200 short (0.2 mm) G64 segments with 3° bends (which constrain nothing
    # at 0.5 m/s: one block with the straight), 100 with 20° bends (junctions at the grbl
    # speed, ~0.11 m/s), then a reversal (a stop), braked for over ~35 of those short blocks
    pts = [(0.0, 0.0), (1.0, 0.0)]
    heading = 0.0
    for k in range(300):
        heading += math.radians(3 if k < 200 else 20)
        x, y = pts[-1]
        pts.append((x + 2e-4 * math.cos(heading), y + 2e-4 * math.sin(heading)))
    x, y = pts[-1]
    pts.append((x - 0.05 * math.cos(heading), y - 0.05 * math.sin(heading)))  # reversal
    path = polyline(pts)
    n = path.n_segments
    prof = build(path, feed=0.5, segment_blend_m=np.full(n, 1e-4))
    assert_limits(prof, A_MAX, J_MAX, feed_max=0.5)
    blocks = prof.sections
    assert len(blocks) == 1 + 100 + 1
    assert blocks[0].s_end == pytest.approx(1.0 + 200 * 2e-4, rel=1e-12)
    assert blocks[0].peak_feed == 0.5  # the straight and the gentle bends at the feed
    v_20 = float(junction_speed(math.radians(20), 1e-4, A_MAX, J_MAX))
    assert 0.1 < v_20 < 0.13
    speeds = np.array([b.v_in for b in blocks[1:]])
    assert np.all(speeds <= v_20 * (1 + 1e-12))
    assert speeds[-1] == pytest.approx(0.0, abs=1e-9)  # the reversal is a stop
    # braking to it spans many short blocks, each junction lower than the one before
    braking = np.nonzero(speeds < v_20 * (1 - 1e-9))[0]
    assert braking.size > 20
    assert np.all(np.diff(speeds[braking[0] :]) < 0)


@pytest.mark.parametrize("seed", range(6))
def test_random_programs_respect_the_limits(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 40))
    steps = rng.uniform(1e-4, 0.02, n)
    heading = np.cumsum(rng.normal(0, 0.5, n))
    pts = np.vstack(
        [[0, 0], np.cumsum(steps[:, None] * np.c_[np.cos(heading), np.sin(heading)], 0)]
    )
    path = polyline(pts)
    feeds = rng.choice([0.02, 0.05, 0.1, 0.3], n)
    blend = np.where(rng.random(n) < 0.2, 0.0, 10 ** rng.uniform(-6, -3, n))
    dwell = np.where(rng.random(n) < 0.1, rng.uniform(0, 0.05, n), 0.0)
    a, j = float(rng.uniform(0.5, 5)), float(rng.uniform(10, 500))
    prof = build(path, 0.1, a, j, segment_feeds=feeds, segment_blend_m=blend, segment_dwell_s=dwell)
    assert_limits(prof, a, j, dt=5e-5, feed_max=float(feeds.max()))
    t, s, v, _ = dense(prof, 5e-5)
    seg_of = path.segment_index(s)
    seg_before = np.clip(np.searchsorted(path.seg_s0, s, side="left") - 1, 0, n - 1)
    cap = np.maximum(feeds[seg_of], feeds[seg_before])  # at a joint either side's feed
    assert np.all(v <= cap * (1 + 1e-12))
    for prev, nxt in zip(prof.sections[:-1], prof.sections[1:], strict=True):
        assert nxt.s_start == prev.s_end and nxt.v_in == prev.v_out
        assert nxt.t_start == pytest.approx(prev.t_end + prev.dwell_s, abs=1e-12)
        assert isinstance(nxt, Block)


def test_arcs_and_cubics_tangent_joints_are_not_junctions():
    # a circle is one segment; a spline is tangent-continuous: no junctions, one block
    for path in (circle((0, 0), 0.05), spline([(0, 0), (0.03, 0.02), (0.06, -0.01), (0.1, 0)])):
        n = path.n_segments
        prof = build(path, segment_blend_m=np.zeros(n))
        assert len(prof.sections) == 1
        legacy = build(path)
        assert prof.duration == pytest.approx(legacy.duration, rel=1e-12)


def test_transition_helpers():
    # distance of a cosine transition and the reachable speed are inverse to each other
    for v0 in (0.0, 0.01, 0.3):
        for L in (1e-6, 1e-3, 0.1):
            v = reach_speed(v0, L, A_MAX, J_MAX)
            assert v >= v0
            assert transition_distance(v0, v, A_MAX, J_MAX) == pytest.approx(L, rel=1e-9)
            assert transition_distance(v0, v, A_MAX, J_MAX) <= L
    # rest-to-rest: the exact-stop profile's fitting feed
    L = 0.002
    assert reach_speed(0.0, L / 2, A_MAX, J_MAX) == pytest.approx(
        fitting_feed(L, A_MAX, J_MAX), rel=1e-12
    )


# ------------------------------------------------------------------ exact-stop profile unchanged
def legacy_profile(path, feed, a_max, j_max, tol=1e-3, segment_feeds=None):
    """The exact-stop profile as computed before the planner (the old formula, verbatim)."""
    L = path.total_length
    cuts = {float(c) for c in path.corner_arc_lengths(tol)}
    seg_feed = None
    if segment_feeds is not None:
        seg_feed = np.asarray(segment_feeds, dtype=np.float64).reshape(-1)
        change = np.nonzero(seg_feed[1:] != seg_feed[:-1])[0] + 1
        cuts.update(float(path.seg_s0[k]) for k in change)
    bounds = [0.0] + sorted(c for c in cuts if 0.0 < c < L) + [L]
    rows = []
    t = 0.0
    for s0, s1 in zip(bounds[:-1], bounds[1:], strict=True):
        length = s1 - s0
        if not length > 0:
            continue
        if seg_feed is not None:
            k = int(path.segment_index(0.5 * (s0 + s1))[0])
            F = float(seg_feed[k])
        else:
            F = feed
        ta = ramp_time(F, a_max, j_max)
        if F * ta > length:
            F = fitting_feed(length, a_max, j_max)
            ta = length / F
        tc = max(0.0, length / F - ta)
        t_end = t + 2 * ta + tc
        rows.append((s0, s1, F, ta, tc, t, t_end))
        t = t_end
    return np.array(rows)


def legacy_sample(tab, total_length, t):
    t = np.atleast_1d(np.asarray(t, dtype=np.float64)).reshape(-1)
    k = np.clip(np.searchsorted(tab[:, 5], t, side="right") - 1, 0, len(tab) - 1)
    s0, s1, F, Ta, Tc, t0 = (tab[k, i] for i in range(6))
    tau = np.maximum(t - t0, 0.0)
    w = math.pi / Ta
    up = tau < Ta
    dn = tau >= Ta + Tc
    r = np.clip(Ta + Tc + Ta - tau, 0.0, Ta)
    tu = np.minimum(tau, Ta)
    s_up = s0 + 0.5 * F * (tu - np.sin(w * tu) / w)
    s_cr = s0 + 0.5 * F * Ta + F * (tau - Ta)
    s_dn = s1 - 0.5 * F * (r - np.sin(w * r) / w)
    s = np.where(up, s_up, np.where(dn, s_dn, s_cr))
    v = np.where(up, 0.5 * F * (1 - np.cos(w * tu)), np.where(dn, 0.5 * F * (1 - np.cos(w * r)), F))
    a = np.where(up, 0.5 * F * w * np.sin(w * tu), np.where(dn, -0.5 * F * w * np.sin(w * r), 0.0))
    ended = t >= tab[k, 6]
    s[ended], v[ended], a[ended] = s1[ended], 0.0, 0.0
    before = t < 0.0
    s[before], v[before], a[before] = 0.0, 0.0, 0.0
    return np.clip(s, 0.0, total_length), v, a


LEGACY_CASES = {
    "circle": (lambda: circle((0, 0), 0.06, start_angle=-math.pi / 2), 0.2, 2.0, 40.0, None),
    "square": (
        lambda: polyline([(0, 0), (0.04, 0), (0.04, 0.04), (0, 0.04), (0, 0)]),
        0.05,
        0.5,
        10.0,
        None,
    ),
    "bent": (lambda: bent_polyline(40, 0.002, 2.0), 0.1, 2.0, 40.0, None),
    "feeds": (
        lambda: polyline([(0, 0), (0.05, 0), (0.1, 0), (0.15, 0.01), (0.2, 0.01)]),
        0.1,
        2.0,
        100.0,
        [0.02, 0.02, 0.05, 0.01],
    ),
    "spline": (
        lambda: spline([(0, 0), (0.03, 0.02), (0.06, -0.01), (0.1, 0.01)]),
        0.2,
        2,
        40,
        None,
    ),
}


@pytest.mark.parametrize("name", sorted(LEGACY_CASES))
def test_exact_stop_profile_is_bit_identical_to_the_old_formula(name):
    make, F, a, j, feeds = LEGACY_CASES[name]
    path = make()
    old = legacy_profile(path, F, a, j, segment_feeds=feeds)
    t = np.arange(-0.005, old[-1, 6] + 0.01, 1e-4)
    want = legacy_sample(old, path.total_length, t)
    for kw in ({}, {"segment_blend_m": None, "segment_dwell_s": None}):
        prof = build(path, F, a, j, segment_feeds=feeds, **kw)
        assert prof.duration == old[-1, 6]
        got = prof.sample(t)
        for g, w in zip(got, want, strict=True):
            np.testing.assert_array_equal(g, w)
        assert [tuple(s) for s in prof.sections] == [(r[0], r[1], r[2], r[5], r[6]) for r in old]


# ------------------------------------------------------------------ bad inputs
@pytest.mark.parametrize("name", ["segment_blend_m", "segment_dwell_s"])
@pytest.mark.parametrize(
    "value, why",
    [
        ([0.0, 0.0], "3 values"),
        ([0.0, 0.0, 0.0, 0.0], "3 values"),
        ([0.0, -1e-6, 0.0], "≥ 0"),
        ([0.0, float("nan"), 0.0], "≥ 0"),
        ([0.0, float("inf"), 0.0], "≥ 0"),
        ("abc", "≥ 0"),
        ([[0.0], ["x"], [1]], "≥ 0"),
    ],
)
def test_bad_blend_and_dwell_name_the_parameter_and_the_allowed_values(name, value, why):
    path = polyline([(0, 0), (0.01, 0), (0.01, 0.01), (0.02, 0.01)])
    with pytest.raises(ValueError, match=name) as err:
        build(path, **{name: value})
    msg = str(err.value)
    assert why in msg and "per segment" in msg
    assert ("m " in msg) if name == "segment_blend_m" else ("s " in msg)


# ------------------------------------------------------------------ long programs
def test_reference_refuses_a_too_long_program_before_allocating(monkeypatch):
    path = line((0, 0), (1.0, 0))
    prof = build(path, feed=1e-4)  # 10,000 s
    t0 = time.perf_counter()
    with pytest.raises(ValueError, match="MAX_REFERENCE_STEPS") as err:
        ReferenceTrajectory.build(path, prof, 1e-3)
    assert time.perf_counter() - t0 < 0.5  # nothing was allocated
    msg = str(err.value)
    assert "servo_period_s = 0.001 s" in msg and "5,000,000" in msg and "10000" in msg
    # at the limit: accepted; one step over: refused
    monkeypatch.setattr(reference_mod, "MAX_REFERENCE_STEPS", 1001)
    short = build(line((0, 0), (0.01, 0)))
    T = short.duration / 1000
    assert ReferenceTrajectory.build(path_of(short), short, T * (1 + 1e-12)).n_steps <= 1001
    with pytest.raises(ValueError, match="reference too long"):
        ReferenceTrajectory.build(path_of(short), short, T / 1.01)


def path_of(profile):
    return line((0, 0), (profile.total_length, 0))


def long_polyline(n, seed=0):
    rng = np.random.default_rng(seed)
    heading = np.cumsum(rng.normal(0, 0.05, n))
    steps = rng.uniform(2e-4, 1e-3, n)[:, None] * np.c_[np.cos(heading), np.sin(heading)]
    return np.vstack([[0, 0], np.cumsum(steps, axis=0)])


def test_setup_of_5000_segments_is_fast_and_linear():
    def timed(n):
        pts = long_polyline(n)
        segs = [Line(a, b) for a, b in zip(pts[:-1], pts[1:], strict=True)]
        t0 = time.perf_counter()
        path = PathGeometry.from_segments(segs)
        t1 = time.perf_counter()
        build(path, segment_blend_m=np.full(path.n_segments, 1e-5))
        t2 = time.perf_counter()
        build(path)
        t3 = time.perf_counter()
        return t1 - t0, t2 - t1, t3 - t2

    small = [min(x) for x in zip(*(timed(500) for _ in range(2)), strict=True)]
    big = [min(x) for x in zip(*(timed(5000) for _ in range(2)), strict=True)]
    assert big[0] < 1.0 and big[1] < 1.0 and big[2] < 1.0, big
    # linear, not quadratic: 10x the segments, well under 100x the time
    for b, s in zip(big, small, strict=True):
        assert b < 30 * s + 0.05, (big, small)


def test_geometry_line_fast_path_matches_the_segment_kernels_bit_for_bit():
    from contour_env.paths.segments import SEG_ARC, arc_derivatives, line_derivatives

    rng = np.random.default_rng(3)
    pts = long_polyline(300)
    segs = [Line(a, b) for a, b in zip(pts[:-1], pts[1:], strict=True)]
    for path in (PathGeometry.from_segments(segs), polyline([(0, 0, 0), (0.1, 0.02, 0.01)])):
        s = np.concatenate(
            [rng.uniform(0, path.total_length, 5000), path.seg_s0, [path.total_length]]
        )
        d = path.evaluate(s)
        idx = path.segment_index(s)
        want = line_derivatives(
            path.seg_data[idx], np.clip(s - path.seg_s0[idx], 0.0, path.seg_length[idx])
        )
        for key, w in zip(("position", "d1", "d2", "d3"), want, strict=True):
            np.testing.assert_array_equal(d[key], w)
    # lines and arcs mixed: each sample as its own segment kernel gives it
    path = polyline([(0, 0), (0.02, 0), (0.02, 0.02)])
    segs = [*path.segments, *circle((0.02, 0.03), 0.01, start_angle=-math.pi / 2).segments]
    path = PathGeometry.from_segments(segs)
    s = np.concatenate([rng.uniform(0, path.total_length, 3000), path.seg_s0])
    d = path.evaluate(s)
    idx = path.segment_index(s)
    local = np.clip(s - path.seg_s0[idx], 0.0, path.seg_length[idx])
    arc = path.seg_type[idx] == SEG_ARC
    assert arc.any() and (~arc).any()
    for sel, kernel in ((arc, arc_derivatives), (~arc, line_derivatives)):
        want = kernel(path.seg_data[idx[sel]], local[sel])
        for key, w in zip(("position", "d1", "d2", "d3"), want, strict=True):
            np.testing.assert_array_equal(d[key][sel], w)


def test_reference_at_a_g64_corner_stays_on_the_path_with_a_velocity_step():
    path = corner_path(math.pi / 2)
    prof = build(path, j=1e4, segment_blend_m=[1e-4, 1e-4])
    T = 1e-4
    ref = ReferenceTrajectory.build(path, prof, T, settle_time_s=0.01)
    s, sd, _ = prof.sample(ref.time)
    np.testing.assert_array_equal(ref.arc_length, s)
    np.testing.assert_array_equal(ref.feedrate, sd)
    # on the programmed polyline: y = 0 before the corner, x = 0.05 after it
    before = ref.arc_length < 0.05
    np.testing.assert_allclose(ref.position[before, 1], 0.0, atol=1e-15)
    np.testing.assert_allclose(ref.position[~before, 0], 0.05, atol=1e-15)
    # the axis velocity turns in one servo period by about 2 v_j sin(θ/2) = sqrt(2) v_j
    v_j = prof.sections[0].v_out
    k = int(np.searchsorted(ref.arc_length, 0.05))
    jump = np.linalg.norm(ref.velocity[k] - ref.velocity[k - 1])
    assert jump == pytest.approx(math.sqrt(2) * v_j, rel=1e-3)
    steps = np.linalg.norm(np.diff(ref.velocity, axis=0), axis=1)
    assert np.argmax(steps) == k - 1
