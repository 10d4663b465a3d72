"""rgb_array rendering: the path and the tool so far with its contour error magnified, and the
contour error vs time; the same picture as :func:`contour_env.plotting.plot_runs`.

The tool is drawn at foot + gain·(x − foot), with foot the nearest point of the path to the
tool position x: the drawn deviation is gain × the contour-error vector (not the tracking
error, which along the path is mostly lag). A planar path is drawn in its plane, a
non-planar one as x–y, x–z and y–z projections (see :mod:`contour_env.plotting`).
"""

from __future__ import annotations

import numpy as np


def magnified_trajectory(path, positions: np.ndarray, gain: float) -> np.ndarray:
    """Foot + gain × (x − foot), (n, 3) m, with foot the nearest path point to each tool
    position x (``positions`` (n, d) m): makes µm contour errors visible on a m-scale plot."""
    from ..plotting import magnified

    return magnified(path, positions, gain)[0]


def render_figure(core, history):
    """The frame as a matplotlib Figure (not rasterised) and what it draws: ``(fig, info)``,
    ``info`` with ``gain``, ``view``, ``foot`` and ``drawn`` ((n, 3) m, as
    :func:`contour_env.plotting.draw_runs`) and ``time``, ``contour_error`` (n,) of the
    history ``[(t, position, ε), ...]``."""
    from matplotlib.figure import Figure

    from ..plotting import (
        add_path_axes,
        break_at_jumps,
        contour_error_vectors,
        draw_path_panels,
        gain_scale_text,
        nice_gain,
        path_polyline,
        path_view,
        view_size,
    )

    path = core.setup.path
    pts = path_polyline(path, 1500)
    view = path_view(path, pts)
    size = view_size(view, pts)
    figsize = {"xy": (8, 4), "plane": (10, 4)}.get(view.kind, (11, 6))
    fig = Figure(figsize=figsize, dpi=80, layout="constrained")
    grid = fig.add_gridspec(1, 2, width_ratios=[1.3 if view.kind == "plane" else 1.0, 1.0])
    axes, ax3d, _ = add_path_axes(fig, grid[0], view, pts, size, header=False)
    ax_err = fig.add_subplot(grid[1])
    gain, tools = 1.0, []
    info = {"view": view, "foot": None, "drawn": None}
    t = np.array([h[0] for h in history])
    eps = np.array([h[2] for h in history])
    if history:
        pos = np.array([np.asarray(h[1], dtype=np.float64) for h in history])
        foot, err = contour_error_vectors(path, pos)
        dist = np.linalg.norm(err, axis=1)
        peak = float(np.nanmax(dist)) if np.isfinite(dist).any() else 0.0
        gain = nice_gain(peak, size)
        drawn = foot + gain * err
        tools = [("tool", break_at_jumps(drawn, foot, pos), "r")]
        info.update(foot=foot, drawn=drawn)
        ax_err.plot(t, eps * 1e6, "r-", lw=1)
    draw_path_panels(axes, view, pts, tools, gain, size, ax3d)
    fig.suptitle(
        f"{core.setup.name}: path (black) and tool (red), contour error ×{gain:g} "
        f"({gain_scale_text(gain)})",
        fontsize=9,
    )
    ax_err.set_xlabel("time (s)", fontsize=8)
    ax_err.set_ylabel("true contour error ε (µm)", fontsize=8)
    ax_err.tick_params(labelsize=7)
    ax_err.grid(True, alpha=0.3)
    info.update(gain=gain, time=t, contour_error=eps)
    return fig, info


def render_rgb(core, history) -> np.ndarray:
    """Render the episode so far as an (H, W, 3) uint8 image."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig, _ = render_figure(core, history)
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[:, :, :3].copy()
