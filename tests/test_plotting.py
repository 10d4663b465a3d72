"""Plots: the magnified deviation is the contour-error vector (not the tracking error), planar
3-D paths are drawn in their plane, non-planar ones as projections, robustness is plotted,
the render frame uses the same magnification; nearest_points agrees with the contour error."""

from __future__ import annotations

import json
import math
from pathlib import Path

import gymnasium as gym
import matplotlib.pyplot as plt
import numpy as np
import pytest

from contour_env import ENV_ID
from contour_env.app.cli import main
from contour_env.cases import build_setup
from contour_env.contour_error import nearest_points, true_contour_error
from contour_env.env.render import render_figure
from contour_env.metrics import EpisodeRecord
from contour_env.paths.builders import circle, helix, inclined_circle, spline
from contour_env.paths.gcode import read_gcode
from contour_env.paths.segments import Arc
from contour_env.plotting import (
    DEVIATION_FRACTION,
    draw_runs,
    nice_gain,
    path_polyline,
    path_view,
)

ROOT = Path(__file__).resolve().parent.parent
THREE_PLANES = ROOT / "tests" / "data" / "three_planes.nc"
ARC_DEMO = ROOT / "contour_env" / "data" / "arc_demo.nc"


def _record(position, reference, dt=1e-3) -> EpisodeRecord:
    n, d = position.shape
    return EpisodeRecord(
        time=np.arange(1, n + 1) * dt,
        contour_error=np.zeros(n),  # not used by the drawing of the path
        tracking_error=reference - position,
        force=np.zeros((n, d)),
        saturated=np.zeros((n, d), dtype=bool),
        position=position,
        reference=reference,
        force_limit=np.ones(d),
    )


def _tool_xy(ax, label) -> np.ndarray:
    lines = [ln for ln in ax.get_lines() if ln.get_gid() == f"tool:{label}"]
    assert len(lines) == 1
    return np.asarray(lines[0].get_xydata())


# ----------------------------------------------------------------------------------------
# nearest_points
# ----------------------------------------------------------------------------------------

PATHS = {
    "circle-2d": lambda: circle((0.01, -0.02), 0.05, start_angle=0.3),
    "inclined-arc": lambda: inclined_circle((0.0, 0.1, 0.2), 0.5, math.radians(30), sweep=1.5),
    "helix": lambda: helix((0.0, 0.0, 0.0), 0.03, 0.01, 2.5),
    "spline": lambda: spline([(0, 0, 0), (0.02, 0.01, 0.005), (0.04, -0.01, 0.0), (0.05, 0.02, 0)]),
    "arc-demo-gcode": lambda: read_gcode(ARC_DEMO).path,
    "three-planes-gcode": lambda: read_gcode(THREE_PLANES).path,
}


@pytest.mark.parametrize("name", sorted(PATHS))
def test_nearest_points_distance_is_the_true_contour_error(name):
    path = PATHS[name]()
    rng = np.random.default_rng(1)
    pts = path_polyline(path, 300)
    pts = pts + rng.normal(scale=2e-3, size=pts.shape)
    if path.dim == 2:
        pts = pts[:, :2]
    foot = nearest_points(path, pts)
    assert foot.shape == pts.shape
    dist = np.linalg.norm(pts - foot, axis=1)
    np.testing.assert_allclose(dist, true_contour_error(path, pts), rtol=0, atol=1e-12)
    # the foot is on the path
    assert np.max(true_contour_error(path, foot)) < 1e-12
    # a single point gives a single point
    one = nearest_points(path, pts[3])
    assert one.shape == pts[3].shape
    np.testing.assert_allclose(one, foot[3], atol=0)


def test_nearest_points_rejects_bad_input():
    path = circle((0, 0), 0.05)
    with pytest.raises(ValueError, match="points"):
        nearest_points(path, np.zeros((4, 4)))
    with pytest.raises(ValueError, match="NaN"):
        nearest_points(path, np.array([[np.nan, 0.0]]))
    with pytest.raises(ValueError, match="path"):
        nearest_points(np.zeros((3, 3)), np.zeros((1, 3)))


def test_nice_gain_is_1_2_5_and_keeps_the_deviation_within_the_fraction():
    assert nice_gain(68.7e-6, 0.2) == 200.0
    assert nice_gain(1e-6, 0.04) == 2000.0
    assert nice_gain(0.0, 0.2) == 1.0
    for peak in (3.3e-6, 2.2e-5, 7.7e-4):
        g = nice_gain(peak, 0.1)
        assert g * peak <= DEVIATION_FRACTION * 0.1 * (1 + 1e-12)
        assert g * peak > 0.4 * DEVIATION_FRACTION * 0.1
        mant = g / 10.0 ** math.floor(math.log10(g))
        assert min(abs(mant - m) for m in (1, 2, 5)) < 1e-9


# ----------------------------------------------------------------------------------------
# the acceptance test: the drawn deviation is gain × the contour-error vector
# ----------------------------------------------------------------------------------------


def test_drawn_deviation_is_gain_times_the_contour_error_vector_not_the_tracking_error():
    c, r = np.array([0.01, 0.02]), 0.05
    path = circle(c, r, start_angle=-math.pi / 2)
    th = np.linspace(-math.pi / 2, 1.2 * math.pi, 700)
    radial = 20e-6 + 10e-6 * np.sin(3 * th)  # the known contour error (outwards)
    lag = 0.05  # rad: the reference runs 2.5 mm ahead along the path
    unit = np.stack([np.cos(th), np.sin(th)], axis=1)
    pos = c + (r + radial)[:, None] * unit
    ref = c + r * np.stack([np.cos(th + lag), np.sin(th + lag)], axis=1)
    rec = _record(pos, ref)
    fig, info = draw_runs({"lagging": rec}, path, "acceptance")
    try:
        gain = info["gain"]
        drawn = _tool_xy(info["path_axes"][0], "lagging")
        assert not np.isnan(drawn).any()  # no corner, no break
        foot = c + r * unit  # the nearest point of the circle, by hand
        err = pos - foot  # the true contour-error vector, radial, |err| = radial
        np.testing.assert_allclose(drawn - foot, gain * err, rtol=0, atol=1e-12)
        np.testing.assert_allclose(
            np.linalg.norm(drawn - foot, axis=1), gain * radial, rtol=1e-9, atol=0
        )
        # ... and not the tracking error: the old picture differs by gain × the lag
        old = ref + gain * (pos - ref)
        assert np.max(np.linalg.norm(drawn - old, axis=1)) > 0.5 * r * lag * gain
        # the gain: a 1-2-5 number putting the largest deviation near a tenth of the size
        assert gain * radial.max() <= DEVIATION_FRACTION * 2 * r * (1 + 1e-12)
        assert gain * radial.max() > 0.4 * DEVIATION_FRACTION * 2 * r
        assert info["peak_m"] == pytest.approx(radial.max(), rel=1e-9)
        texts = [info["path_axes"][0].get_title()] + [t.get_text() for t in fig.texts]
        assert any(f"×{gain:g}" in t for t in texts)
        # the legend sits outside the axes: its box overlaps no data panel
        fig.canvas.draw()
        legend = fig.legends[0].get_window_extent()
        for ax in fig.axes:
            assert not legend.overlaps(ax.get_window_extent())
    finally:
        plt.close(fig)


def test_inclined_path_plan_and_elevation_show_the_whole_error_vector():
    c, r = np.array([0.02, -0.01, 0.03]), 0.05
    path = inclined_circle(c, r, math.radians(30))
    n = path.planar_normal
    th = np.linspace(0.0, 2 * math.pi, 500, endpoint=False)
    seg = path.segments[0]
    unit = np.cos(th)[:, None] * seg.u + np.sin(th)[:, None] * seg.v
    radial, normal = 15e-6 * (1 + np.cos(2 * th)), 8e-6 * np.sin(th)
    pos = c + (r + radial)[:, None] * unit + normal[:, None] * n
    ref = c + r * (np.cos(th + 0.04)[:, None] * seg.u + np.sin(th + 0.04)[:, None] * seg.v)
    fig, info = draw_runs({"tool": _record(pos, ref)}, path, "inclined")
    try:
        view, gain = info["view"], info["gain"]
        assert view.kind == "plane" and len(view.panels) == 2
        foot = c + r * unit
        err = pos - foot
        for ax, panel in zip(info["path_axes"], view.panels, strict=True):
            drawn = _tool_xy(ax, "tool")
            np.testing.assert_allclose(
                drawn - panel.project(foot), gain * err @ panel.basis.T, rtol=0, atol=1e-12
            )
        # plan (u, v) and elevation (the plane edge-on: one in-plane axis and n) together hold
        # all three components of gain × the contour-error vector
        axes3 = np.vstack([view.panels[0].basis, view.panels[1].basis])
        assert np.linalg.matrix_rank(axes3, tol=1e-9) == 3
        assert np.any(np.abs(np.abs(view.panels[1].basis @ n) - 1) < 1e-12)
    finally:
        plt.close(fig)


# ----------------------------------------------------------------------------------------
# 3-D views
# ----------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "path_of",
    [
        lambda: inclined_circle((0.01, 0.02, 0.03), 0.05, math.radians(30)),
        lambda: circle((0.0, 0.0, 0.1), 0.05, normal=(1.0, 1.0, 1.0)),
        lambda: build_setup(case="lm-circle3d").path,
        lambda: build_setup(case="jee-circle3d").path,
    ],
    ids=["inclined-30deg", "normal-111", "lm-circle3d", "jee-circle3d"],
)
def test_planar_3d_path_is_drawn_in_its_plane_as_a_circle(path_of):
    path = path_of()
    arc = path.segments[0]
    assert isinstance(arc, Arc)
    pts = path_polyline(path, 400)
    view = path_view(path, pts)
    assert view.kind == "plane"
    plan, elev = view.panels
    p2 = plan.project(pts)
    c2 = plan.project(arc.center[None])[0]
    # the radius is preserved: the drawn path is a circle (arc) of the true radius
    np.testing.assert_allclose(np.linalg.norm(p2 - c2, axis=1), arc.radius, rtol=0, atol=1e-12)
    # not edge-on: it spans the arc's own extent in both drawn directions
    ext = np.ptp(p2, axis=0)
    assert ext.min() > 0.25 * arc.radius
    # the elevation sees the plane edge-on: no extent along the normal
    e2 = elev.project(pts)
    normal_col = int(np.argmax(np.abs(elev.basis @ view.normal)))
    assert np.ptp(e2[:, normal_col]) < 1e-12
    # orthonormal in-plane axes
    np.testing.assert_allclose(plan.basis @ plan.basis.T, np.eye(2), atol=1e-12)
    np.testing.assert_allclose(plan.basis @ view.normal, 0.0, atol=1e-12)


def test_three_plane_program_reads_as_written():
    prog = read_gcode(THREE_PLANES)
    arcs = [s for s in prog.path.segments if isinstance(s, Arc)]
    assert len(arcs) == 3
    normals = [tuple(np.round(np.abs(a.w)).astype(int)) for a in arcs]
    assert normals == [(0, 0, 1), (0, 1, 0), (1, 0, 0)]  # G17, G18, G19
    for a in arcs:
        assert a.radius == pytest.approx(0.010, abs=1e-12)
        assert abs(a.sweep) == pytest.approx(2 * math.pi)
    np.testing.assert_allclose(prog.segment_feeds_m_s, 0.025)
    assert prog.path.dim == 3 and prog.path.planar_normal is None
    np.testing.assert_allclose(prog.path.segments[-1].end_point, 0.0, atol=1e-15)


def test_three_plane_program_runs_on_linear_motor():
    env = gym.make(ENV_ID, plant="linear-motor", path=str(THREE_PLANES))
    core = env.unwrapped.core
    assert core.dim == 3
    env.reset(seed=0)
    for _ in range(200):
        _, _, term, trunc, info = env.step(np.zeros(3, dtype=np.float32))
        assert not (term or trunc)
    assert np.isfinite(info["contour_error"])


def test_three_plane_program_draws_each_circle_in_true_shape():
    path = read_gcode(THREE_PLANES).path
    view = path_view(path)
    assert view.kind == "projections"
    by_plane = {tuple(np.argmax(np.abs(p.basis), axis=1)): p for p in view.panels}
    assert set(by_plane) == {(0, 1), (0, 2), (1, 2)}
    th = np.linspace(0.0, 2 * math.pi, 200)
    for arc in (s for s in path.segments if isinstance(s, Arc)):
        k = int(np.argmax(np.abs(arc.w)))
        panel = by_plane[tuple(a for a in range(3) if a != k)]
        pts = arc.center + arc.radius * (np.cos(th)[:, None] * arc.u + np.sin(th)[:, None] * arc.v)
        p2 = panel.project(pts)
        c2 = panel.project(arc.center[None])[0]
        np.testing.assert_allclose(np.linalg.norm(p2 - c2, axis=1), arc.radius, atol=1e-12)
        np.testing.assert_allclose(np.ptp(p2, axis=0), 2 * arc.radius, rtol=1e-3)
    # a tool off the path by a known 3-D vector: every projection draws gain × its projection
    rng = np.random.default_rng(3)
    pts = path_polyline(path, 900)
    pos = pts + rng.normal(scale=5e-6, size=pts.shape)
    fig, info = draw_runs({"tool": _record(pos, pts)}, path, "three planes")
    try:
        foot = nearest_points(path, pos)
        err = pos - foot
        gain = info["gain"]
        assert len(info["path_axes"]) == 3
        assert any(ax.name == "3d" for ax in fig.axes)
        for ax, panel in zip(info["path_axes"], view.panels, strict=True):
            drawn = _tool_xy(ax, "tool")
            drawn = drawn[~np.isnan(drawn).any(axis=1)]  # breaks are inserted rows
            assert len(drawn) == len(pos)
            np.testing.assert_allclose(
                drawn - panel.project(foot), gain * err @ panel.basis.T, rtol=0, atol=1e-12
            )
    finally:
        plt.close(fig)


def test_line_breaks_where_the_foot_jumps_across_a_corner():
    from contour_env.paths.builders import polyline

    path = polyline([(0.0, 0.0), (0.04, 0.0), (0.04, 0.04)])
    # the tool inside the corner, 30 µm short of the vertical leg, climbing it
    y = np.linspace(0.0, 0.01, 1000)  # 10 µm steps
    pos = np.stack([np.full_like(y, 0.04 - 30e-6), y], axis=1)
    fig, info = draw_runs({"stuck": _record(pos, pos)}, path, "corner")
    try:
        drawn = _tool_xy(info["path_axes"][0], "stuck")
        assert np.isnan(drawn).any(axis=1).sum() == 1  # one break, where the foot switches leg
        ok = drawn[~np.isnan(drawn).any(axis=1)]
        np.testing.assert_allclose(ok, info["drawn"]["stuck"][:, :2], atol=0)
    finally:
        plt.close(fig)


# ----------------------------------------------------------------------------------------
# robustness in the plot
# ----------------------------------------------------------------------------------------


def test_robustness_rows_carry_per_variation_results_and_traces():
    from agents.compare import robustness

    rows = robustness(["pd"], 0.2, 3, case="hsm2-circle-III", traces=True)
    r = rows[0]
    per = np.asarray(r["rms_contour_error_um_per_episode"])
    assert per.shape == (3,) and len(r["failed_per_episode"]) == 3
    assert np.mean(per) == pytest.approx(r["mean_rms_contour_error_um"], rel=1e-12)
    assert max(r["max_contour_error_um_per_episode"]) == pytest.approx(
        r["worst_max_contour_error_um"], rel=1e-12
    )
    tr = r["traces"]
    e = tr["contour_error_m"]
    assert e.shape == (len(tr["time_s"]), 3)
    np.testing.assert_allclose(np.sqrt(np.nanmean(e**2, axis=0)) * 1e6, per, rtol=1e-9)
    # without traces=True the rows stay JSON-friendly
    plain = robustness(["pd"], 0.2, 2, case="hsm2-circle-III")
    assert "traces" not in plain[0]
    json.dumps(plain)


def test_robustness_panels_are_drawn():
    c, r = np.zeros(2), 0.05
    path = circle(c, r)
    th = np.linspace(0, 2 * math.pi, 200)
    pos = (r + 1e-5) * np.stack([np.cos(th), np.sin(th)], axis=1)
    rec = _record(pos, pos)
    rows = []
    for k, name in enumerate(("a", "b")):
        per = [3.0 * (k + 1), 4.0 * (k + 1), 9.0 * (k + 1)]
        rows.append(
            {
                "controller": name,
                "episodes": 3,
                "randomize": 0.2,
                "mean_rms_contour_error_um": float(np.mean(per)),
                "cvar10_rms_contour_error_um": max(per),
                "worst_max_contour_error_um": 20.0,
                "failure_rate": 0.0,
                "rms_contour_error_um_per_episode": per,
                "failed_per_episode": [False] * 3,
                "traces": {"time_s": np.arange(5) * 1e-3, "contour_error_m": np.ones((5, 3))},
            }
        )
    fig, info = draw_runs({"a": rec, "b": rec}, path, "robust", robust=rows)
    try:
        titles = [ax.get_title() for ax in fig.axes]
        assert any("3 plant variations" in t for t in titles)
        assert any("over the variations" in t for t in titles)
        legend = [t.get_text() for t in fig.legends[0].get_texts()]
        assert any("mean RMS 5.33" in t and "CVaR10 9.00" in t for t in legend)
    finally:
        plt.close(fig)


# ----------------------------------------------------------------------------------------
# render frame
# ----------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("case", "shape"), [("hsm2-circle-III", (320, 640, 3)), ("jee-circle3d", (320, 800, 3))]
)
def test_render_frame_magnifies_the_contour_error_vector(case, shape):
    env = gym.make(ENV_ID, case=case, render_mode="rgb_array")
    core = env.unwrapped.core
    env.reset(seed=0)
    for _ in range(50):
        env.step(np.full(core.dim, 0.01, dtype=np.float32))
    img = env.render()
    assert img.dtype == np.uint8 and img.shape == shape and img.std() > 0
    # a history with a known lag along the path and a known offset from it
    path = core.setup.path
    s = np.linspace(0.0, 0.8 * path.total_length, 300)
    ev = path.evaluate(s)
    normal = path.frames(s, ev)[0][:, :, 1]
    pos = ev["position"] + 12e-6 * normal  # 12 µm to the left of the path (inside the circle)
    ref = path.evaluate(s + 3e-3)["position"]  # 3 mm ahead: the tracking error is ~3 mm
    d = core.dim
    history = [(0.001 * i, pos[i, :d], 12e-6) for i in range(len(s))]
    fig, info = render_figure(core, history)
    try:
        gain = info["gain"]
        foot = nearest_points(path, pos)
        np.testing.assert_allclose(foot, ev["position"], atol=1e-12)
        np.testing.assert_allclose(info["drawn"] - info["foot"], gain * (pos - foot), atol=1e-12)
        np.testing.assert_allclose(
            np.linalg.norm(info["drawn"] - info["foot"], axis=1), gain * 12e-6, rtol=1e-9
        )
        old = ref + gain * (pos - ref)  # the tracking-error magnification of the old frame
        assert np.max(np.linalg.norm(info["drawn"] - old, axis=1)) > 1e-3 * gain
        ax = fig.axes[0]
        lines = [ln for ln in ax.get_lines() if ln.get_gid() == "tool:tool"]
        panel = info["view"].panels[0]
        np.testing.assert_allclose(lines[0].get_xydata(), panel.project(info["drawn"]), atol=0)
    finally:
        plt.close(fig)


# ----------------------------------------------------------------------------------------
# command line
# ----------------------------------------------------------------------------------------


def _is_png(path) -> bool:
    data = Path(path).read_bytes()
    return data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 20_000


def test_cli_run_and_compare_write_plots(tmp_path, capsys):
    run_png, cmp_png = tmp_path / "run.png", tmp_path / "compare.png"
    assert (
        main(["run", "--case", "hsm2-circle-I", "--controller", "ccc", "--plot", str(run_png)]) == 0
    )
    assert _is_png(run_png)
    args = ["compare", "--case", "hsm2-circle-I", "--controllers", "pd,ccc", "--plot"]
    assert main([*args, str(cmp_png)]) == 0
    assert _is_png(cmp_png)
    assert f"wrote {cmp_png}" in capsys.readouterr().out


def test_cli_compare_randomize_plots_robustness_and_keeps_json_clean(tmp_path, capsys):
    png, js = tmp_path / "robust.png", tmp_path / "robust.json"
    args = ["compare", "--case", "hsm2-circle-III", "--controllers", "pd,ccc"]
    args += ["--randomize", "0.2", "--episodes", "2", "--plot", str(png), "--json", str(js)]
    assert main(args) == 0
    assert _is_png(png)
    rows = json.loads(js.read_text())["robustness"]
    for r in rows:
        assert "traces" not in r
        assert len(r["rms_contour_error_um_per_episode"]) == 2
