"""The ISO 230-4 circular test (contour_env.circular_test): the metrics on synthetic traces with
known answers, checked against independent computations (a scipy geometric circle fit, closed
forms of an ellipse, a brute-force minimum zone, nearest-sample hysteresis); the path with its
overshoot arcs; the capture arc; the checks of the settings; and PD against CCC on hsm2."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.optimize import least_squares

from contour_env.circular_test import (
    REVERSALS,
    capture_arc,
    circle_metrics,
    circular_deviation,
    circular_hysteresis,
    circular_path,
    circular_test_errors,
    fit_lsq_circle,
    max_circle_feed_m_s,
    radial_deviation,
    reversal_spikes,
    run_circular_test,
)
from contour_env.plants import Plant

R = 0.05  # m
A, B = 3e-6, 2e-6  # semi-axes R + A (along x) and R − B (along y), m
CENTER = (1.5e-6, -1.0e-6)  # the ellipse's centre, offset from the nominal centre (0, 0), m
SPIKE_AT_DEG, SPIKE_SIGMA_DEG = 3.0, 1.0  # each spike peaks 3° after its reversal, σ = 1°
SPIKES_CCW = {0.0: 5e-6, 90.0: 3e-6, 180.0: -2e-6, 270.0: 4e-6}  # m, signed (outward > 0)
SPIKES_CW = {0.0: 2e-6, 90.0: 6e-6, 180.0: 4e-6, 270.0: -3e-6}
WINDOW_DEG = 10.0


def _wrap(deg):
    return (np.asarray(deg) + 180.0) % 360.0 - 180.0


def synthetic(direction, *, center=CENTER, spikes=None, n=36_000, uneven=False, seed=0):
    """A trace in travel order: the ellipse (semi-axes R + A along x, R − B along y) about
    ``center`` plus radial Gaussian spikes after each reversal (in the direction of travel),
    sampled evenly in the ellipse's parameter or, ``uneven``, at seeded random parameters.
    Returns x, y (m) and the spike part of the radius (m) per point."""
    if uneven:
        t = np.sort(np.random.default_rng(seed).uniform(0, 2 * np.pi, n))
    else:
        t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    ex, ey = (R + A) * np.cos(t), (R - B) * np.sin(t)
    theta = np.degrees(np.arctan2(ey, ex)) % 360.0
    sign = 1 if direction == "ccw" else -1
    bump = np.zeros(n)
    for rev, h in (spikes or {}).items():
        phi = _wrap(sign * (theta - rev))
        bump += h * np.exp(-0.5 * ((phi - SPIKE_AT_DEG) / SPIKE_SIGMA_DEG) ** 2)
    u = np.radians(theta)
    x = center[0] + ex + bump * np.cos(u)
    y = center[1] + ey + bump * np.sin(u)
    order = slice(None) if direction == "ccw" else slice(None, None, -1)
    return x[order], y[order], bump[order]


def scipy_circle(x, y):
    """An independent least-squares circle: scipy's trust-region fit of Σ (|p − c| − ρ)²."""

    def res(p):
        return np.hypot(x - p[0], y - p[1]) - p[2]

    sol = least_squares(res, [np.mean(x), np.mean(y), np.mean(np.hypot(x, y))], xtol=1e-15)
    return sol.x


def test_lsq_circle_matches_an_independent_scipy_fit():
    x, y, _ = synthetic("ccw", spikes=SPIKES_CCW, uneven=True)
    cx, cy, rho = fit_lsq_circle(x, y)
    sx, sy, srho = scipy_circle(x, y)
    assert abs(cx - sx) < 1e-10 and abs(cy - sy) < 1e-10 and abs(rho - srho) < 1e-10
    # and of a plain ellipse, its centre, by symmetry
    x, y, _ = synthetic("ccw")
    cx, cy, _ = fit_lsq_circle(x, y)
    assert math.hypot(cx - CENTER[0], cy - CENTER[1]) < 2e-8


def test_circular_deviation_of_an_ellipse_is_a_plus_b_and_the_minimum_zone():
    x, y, _ = synthetic("ccw")
    g = circular_deviation(x, y)
    # closed form: about the ellipse's centre the radius runs from R − B to R + A
    assert g == pytest.approx(A + B, abs=2e-9)
    # brute-force minimum zone over a grid of centres around the nominal one: an ellipse's
    # minimum zone is centred on its centre, so it equals G
    xs, ys = x[::10], y[::10]
    offs = np.linspace(-4e-6, 4e-6, 41)
    best = min(
        float(np.ptp(np.hypot(xs - cx, ys - cy)))
        for cx in CENTER[0] + offs
        for cy in CENTER[1] + offs
    )
    assert best == pytest.approx(g, abs=5e-9)


def test_circular_deviation_with_spikes_against_an_independent_centre():
    for direction, spikes in (("ccw", SPIKES_CCW), ("cw", SPIKES_CW)):
        x, y, _ = synthetic(direction, spikes=spikes, uneven=True)
        sx, sy, _ = scipy_circle(x, y)
        expected = float(np.ptp(np.hypot(x - sx, y - sy)))
        assert circular_deviation(x, y) == pytest.approx(expected, abs=1e-10)
        # the outward spikes add to the ellipse's range
        assert expected > A + B + 0.5 * max(spikes.values())


def test_radial_deviation_is_about_the_nominal_centre_and_radius():
    x, y, _ = synthetic("ccw")
    f_max, f_min = radial_deviation(x, y, (0.0, 0.0), R)
    # closed form on a dense parameter grid: r(t) = |c + ((R + A) cos t, (R − B) sin t)|
    t = np.linspace(0, 2 * np.pi, 2_000_001)
    r = np.hypot(CENTER[0] + (R + A) * np.cos(t), CENTER[1] + (R - B) * np.sin(t))
    assert f_max == pytest.approx(float(r.max()) - R, abs=2e-10)
    assert f_min == pytest.approx(float(r.min()) - R, abs=2e-10)
    # first order in the µm terms: r − R = A cos²t − B sin²t + c · (cos t, sin t)
    first = A * np.cos(t) ** 2 - B * np.sin(t) ** 2 + CENTER[0] * np.cos(t) + CENTER[1] * np.sin(t)
    assert f_max == pytest.approx(float(first.max()), abs=2e-9)
    assert f_min == pytest.approx(float(first.min()), abs=2e-9)
    # with spikes: the extreme radii about (0, 0)
    x, y, _ = synthetic("cw", spikes=SPIKES_CW)
    f_max, f_min = radial_deviation(x, y, (0.0, 0.0), R)
    assert f_max == float(np.hypot(x, y).max()) - R
    assert f_min == float(np.hypot(x, y).min()) - R


def _nearest_sample_profile(x, y, center, grid_deg):
    # r at the sample nearest in angle to each grid angle (no interpolation)
    th = np.degrees(np.arctan2(y - center[1], x - center[0])) % 360.0
    r = np.hypot(x - center[0], y - center[1])
    order = np.argsort(th)
    th, r = th[order], r[order]
    th_ext = np.concatenate([th - 360.0, th, th + 360.0])
    r_ext = np.concatenate([r, r, r])
    k = np.clip(np.searchsorted(th_ext, grid_deg), 1, th_ext.size - 1)
    left_closer = (grid_deg - th_ext[k - 1]) < (th_ext[k] - grid_deg)
    return np.where(left_closer, r_ext[k - 1], r_ext[k])


def test_hysteresis_of_a_shifted_ellipse_is_the_shift():
    shift = (2.0e-6, 1.0e-6)
    x1, y1, _ = synthetic("ccw")
    x2, y2, _ = synthetic("cw", center=(CENTER[0] + shift[0], CENTER[1] + shift[1]))
    # first order: about the common centre r_cw − r_ccw = shift · (cos θ, sin θ)
    assert circular_hysteresis(x2, y2, x1, y1) == pytest.approx(math.hypot(*shift), abs=1e-8)


def test_hysteresis_with_spikes_against_nearest_sample_profiles():
    shift = (2.0e-6, 1.0e-6)
    x1, y1, _ = synthetic("ccw", spikes=SPIKES_CCW, n=72_000)
    x2, y2, _ = synthetic(
        "cw", spikes=SPIKES_CW, center=(CENTER[0] + shift[0], CENTER[1] + shift[1]), n=72_000
    )
    cx, cy, _ = scipy_circle(np.concatenate([x1, x2]), np.concatenate([y1, y2]))
    grid = np.arange(0.0, 360.0, 0.1)
    expected = np.max(
        np.abs(
            _nearest_sample_profile(x2, y2, (cx, cy), grid)
            - _nearest_sample_profile(x1, y1, (cx, cy), grid)
        )
    )
    h = circular_hysteresis(x2, y2, x1, y1)
    assert h == pytest.approx(expected, abs=3e-8)
    assert h > max(abs(v) for v in SPIKES_CW.values())  # the spikes sit at different angles


@pytest.mark.parametrize("direction,spikes", [("ccw", SPIKES_CCW), ("cw", SPIKES_CW)])
def test_reversal_spike_heights(direction, spikes):
    x, y, bump = synthetic(direction, spikes=spikes)
    rows = reversal_spikes(x, y, direction, window_deg=WINDOW_DEG)
    assert [(r["angle_deg"], r["axis"]) for r in rows] == list(REVERSALS)
    # the documented definition, computed independently: d = r − ρ about scipy's circle,
    # baseline = median of d over [−W, 0) ∪ (W, 2W] past the reversal, height = d of largest
    # |d − baseline| in [0, W] minus the baseline
    sx, sy, srho = scipy_circle(x, y)
    theta = np.degrees(np.arctan2(y - sy, x - sx)) % 360.0
    d = np.hypot(x - sx, y - sy) - srho
    sign = 1 if direction == "ccw" else -1
    for row in rows:
        rev, h = row["angle_deg"], spikes[row["angle_deg"]]
        phi = _wrap(sign * (theta - rev))
        win = (phi >= 0) & (phi <= WINDOW_DEG)
        base = ((phi >= -WINDOW_DEG) & (phi < 0)) | ((phi > WINDOW_DEG) & (phi <= 2 * WINDOW_DEG))
        baseline = np.median(d[base])
        k = np.argmax(np.abs(d[win] - baseline))
        assert row["height_m"] == pytest.approx(d[win][k] - baseline, abs=1e-10)
        # and it is the spike that was put there: the ellipse varies by < 0.3 µm over the
        # windows, and the spike peaks 3° past the reversal along the travel
        assert row["height_m"] == pytest.approx(h, abs=0.3e-6)
        past = _wrap(sign * (row["peak_angle_deg"] - rev))
        assert past == pytest.approx(SPIKE_AT_DEG, abs=0.2)


def test_no_spikes_on_a_plain_circle():
    t = np.linspace(0, 2 * np.pi, 20_000, endpoint=False)
    rows = reversal_spikes(R * np.cos(t), R * np.sin(t), "ccw")
    assert all(abs(r["height_m"]) < 1e-12 for r in rows)


def test_circle_metrics_in_micrometres():
    x, y, _ = synthetic("ccw", spikes=SPIKES_CCW)
    m = circle_metrics(x, y, (0.0, 0.0), R, "ccw")
    assert m["circular_deviation_um"] == pytest.approx(circular_deviation(x, y) * 1e6, abs=1e-4)
    f_max, f_min = radial_deviation(x, y, (0.0, 0.0), R)
    assert m["radial_deviation_max_um"] == pytest.approx(f_max * 1e6, abs=1e-4)
    assert m["radial_deviation_min_um"] == pytest.approx(f_min * 1e6, abs=1e-4)
    assert [s["axis"] for s in m["reversal_spikes_um"]] == ["x", "y", "x", "y"]
    assert m["reversal_spikes_um"][0]["height_um"] == pytest.approx(5.0, abs=0.3)
    cx, cy, rho = fit_lsq_circle(x, y)
    assert m["lsq_center_offset_um"] == pytest.approx([cx * 1e6, cy * 1e6], abs=1e-4)
    assert m["lsq_radius_deviation_um"] == pytest.approx((rho - R) * 1e6, abs=1e-4)
    # the spikes pull the LSQ centre a little away from the ellipse's
    assert m["lsq_center_offset_um"] == pytest.approx([1.5, -1.0], abs=0.15)
    json.dumps(m, allow_nan=False)


@pytest.mark.parametrize("direction", ["cw", "ccw"])
def test_path_has_overshoot_arcs_around_the_capture_arc(direction):
    ov = 90.0
    path = circular_path(0.02, direction, ov)
    assert path.dim == 2 and path.n_segments == 1
    assert path.total_length == pytest.approx(0.02 * (2 * np.pi + 2 * np.radians(ov)))
    sign = 1 if direction == "ccw" else -1
    s = np.array([0.0, 0.02 * np.radians(ov), path.total_length])  # start, capture start, end
    pts = path.evaluate(s)["position"]
    ang = np.degrees(np.arctan2(pts[:, 1], pts[:, 0]))
    assert _wrap(ang[0] + sign * ov) == pytest.approx(0.0, abs=1e-9)  # ov before the capture
    assert _wrap(ang[1]) == pytest.approx(0.0, abs=1e-9)  # the capture starts at 0°
    assert _wrap(ang[2] - sign * ov) == pytest.approx(0.0, abs=1e-9)  # ov after it ends
    # the direction: a little past the capture start, the angle has grown (ccw) or shrunk (cw)
    ahead = path.evaluate([0.02 * np.radians(ov) + 1e-4])["position"][0]
    assert sign * np.arctan2(ahead[1], ahead[0]) > 0
    assert np.allclose(np.hypot(pts[:, 0], pts[:, 1]), 0.02)


@pytest.mark.parametrize("direction", ["cw", "ccw"])
def test_capture_arc_is_the_360_degrees_after_the_feed_in(direction):
    ov, sign = 180.0, (1 if direction == "ccw" else -1)
    travel = np.linspace(0.0, 2 * ov + 360.0, 7201)  # 0.1° steps along the travel
    ang = np.radians(-sign * ov + sign * travel)
    x, y = R * np.cos(ang), R * np.sin(ang)
    idx = capture_arc(x, y, (0.0, 0.0), direction, ov)
    assert idx.size == 3600
    assert travel[idx[0]] == pytest.approx(ov) and travel[idx[-1]] == pytest.approx(ov + 359.9)
    # a run that stopped before the end of the capture arc has none
    stop = travel < ov + 200
    assert capture_arc(x[stop], y[stop], (0.0, 0.0), direction, ov).size == 0


def test_settings_are_checked_with_the_callers_names():
    labels = {"radius_m": "--radius", "feed_m_s": "--feed", "overshoot_deg": "--overshoot"}
    assert circular_test_errors("hsm2", 0.05, 0.2, 180.0) == []
    errs = circular_test_errors("hsm2", -1, 0, 0, labels=labels)
    assert [e.split(":")[0] for e in errs] == ["--radius", "--feed", "--overshoot"]
    assert "must be > 0 and <= 360 degrees" in circular_test_errors("hsm2", 0.05, 0.2, 361)[0]
    # the feed the plant cannot hold on this circle, and an overshoot shorter than the ramp
    f_max = max_circle_feed_m_s(Plant("hsm2").params, 0.05)
    assert 0.3 < f_max < 0.6
    (err,) = circular_test_errors("hsm2", 0.05, 1.0, 180.0)
    assert err.startswith("feed_m_s: must be > 0 and <= 0.45") and "force limit" in err
    (err,) = circular_test_errors("hsm2", 0.05, 0.2, 5.0)
    assert "shorter than the feed ramp" in err and "use at least 18 degrees" in err
    assert "not supported" in circular_test_errors("five-axis", 0.05, 0.2)[0]
    assert "unknown plant 'nope'" in circular_test_errors("nope", 0.05, 0.2)[0]
    one_axis = {"axes": ["x"], "mass": 10, "force_limit": 100, "servo_period": 1e-3}
    assert "1 axis is not supported" in circular_test_errors(one_axis, 0.05, 0.2)[0]
    with pytest.raises(ValueError, match="radius_m: must be > 0"):
        run_circular_test("hsm2", {"zero": None}, 0.0, 0.2)


@pytest.fixture(scope="module")
def hsm2_pd_ccc():
    """PD and CCC on hsm2 (the default plant of hsm2-circle-II), r = 50 mm at 0.2 m/s."""
    from agents.compare import bound_controller

    factories = {n: (lambda env, n=n: bound_controller(n, env)) for n in ("pd", "ccc")}
    return run_circular_test("hsm2", factories, 0.05, 0.2, seed=0)


def test_ccc_has_a_smaller_circular_deviation_than_pd_on_hsm2(hsm2_pd_ccc):
    res = hsm2_pd_ccc["results"]
    for label in ("pd", "ccc"):
        for d in ("cw", "ccw"):
            assert res[label][d]["completed"]
            assert res[label][d]["samples"] > 1000  # 1 ms samples over 1.57 s of capture
    for d in ("cw", "ccw"):
        assert res["ccc"][d]["circular_deviation_um"] < res["pd"][d]["circular_deviation_um"]
        # PD's lag shows as a radius error; CCC keeps the tool on the nominal circle
        assert res["pd"][d]["radial_deviation_min_um"] > res["ccc"][d]["radial_deviation_max_um"]
    assert res["ccc"]["hysteresis_um"] < res["pd"]["hysteresis_um"]


def test_the_report_is_json_with_traces_for_the_plot(hsm2_pd_ccc):
    rep = dict(hsm2_pd_ccc)
    traces = rep.pop("traces")
    json.dumps(rep, allow_nan=False)
    assert rep["plant"] == "hsm2" and rep["overshoot_deg"] == 180.0 and rep["plane"] == "xy"
    tr = traces["ccc"]["ccw"]
    assert tr["angle_deg"].shape == tr["radial_deviation_um"].shape
    # the capture arc covers the whole circle
    assert np.ptp(tr["angle_deg"]) > 359.0
