"""Plots people would rather look at than read: the path with the tool's contour error
magnified, contour and tracking error vs time, robustness over plant variations; learning
curves.

Magnification. A µm error is invisible on a path of centimetres, so the tool is drawn at
``foot + gain·(x − foot)``, where ``foot`` is the nearest point of the path to the tool
position ``x`` (:func:`contour_env.contour_error.nearest_points`). The drawn deviation from
the path is then ``gain`` × the contour-error vector, whose length is the contour error ε the
tables report. (Magnifying the tracking error ``x − x_d`` instead would draw the lag along
the path as loops and overshoots that never happened.) One gain for all controllers of a
figure, a 1-2-5 number chosen so that the largest drawn deviation of a run the env did not
stop is at most a tenth of the path's size; the title says how many µm one drawn mm is. Where the
foot point jumps (the tool passes the bisector of a corner) the drawn line is broken rather
than joined by a straight stroke.

Views (:func:`path_view`):

- a 2-D path: x–y;
- a planar 3-D path (all of it in one plane, e.g. an inclined circle): the plan, in the
  path's plane (axes ``u``, ``v``; the machine axes when the plane is parallel to a
  coordinate plane), and beside or below it the elevation, the plane seen edge-on, where the
  out-of-plane part of the contour-error vector shows at the same gain;
- a non-planar path (a helix, circles in several planes): three orthogonal projections x–y,
  x–z, y–z, as on an engineering drawing, plus a 3-D overview with the same magnification.
  Projections keep true lengths and shapes in the principal planes, where CAM programs put
  their arcs (each G17/G18/G19 arc is a circle in one of them), and stay readable at µm
  scale; a perspective 3-D view alone hides deviations behind the path.

Legends sit below the axes (one for the whole figure: the colours are the same in every
panel), never on the data.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .contour_error import nearest_points  # noqa: E402
from .io import atomic_save_figure  # noqa: E402
from .metrics import EpisodeRecord, format_um  # noqa: E402
from .paths.geometry import path_polyline  # noqa: E402  (re-exported: drawn points of a path)

# the largest drawn deviation (of a run the env did not stop) is at most this fraction of the
# path's size
DEVIATION_FRACTION = 0.1

_AXES = np.eye(3)
_AXIS_NAMES = "xyz"


# ----------------------------------------------------------------------------------------
# geometry of the drawing (no matplotlib): views, magnification, gain
# ----------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ViewPanel:
    """One 2-D view: drawn coordinates ``(p − origin) @ basis.T`` (m)."""

    title: str
    origin: np.ndarray  # (3,)
    basis: np.ndarray  # (2, 3), orthonormal rows: the drawn horizontal and vertical directions
    xlabel: str
    ylabel: str

    def project(self, points) -> np.ndarray:
        """(n, 3) or (n, 2) points (m) → (n, 2) drawn coordinates (m)."""
        return (_as3(points) - self.origin) @ self.basis.T


@dataclass(frozen=True)
class PathView:
    """How a path is drawn.

    ``kind``: ``"xy"`` (2-D path: one panel), ``"plane"`` (planar 3-D path: the plan, in the
    path's plane, and an edge-on elevation showing the out-of-plane part; ``layout`` says
    whether the elevation goes ``"below"`` the plan, sharing its horizontal axis, or
    ``"beside"`` it, sharing its vertical one) or ``"projections"`` (non-planar: x–y, x–z,
    y–z). ``normal``: the plane's unit normal (None for projections)."""

    kind: str
    panels: tuple[ViewPanel, ...]
    normal: np.ndarray | None
    layout: str = "single"


def _as3(points) -> np.ndarray:
    p = np.asarray(points, dtype=np.float64)
    if p.ndim == 1:
        p = p[None, :]
    if p.shape[1] == 3:
        return p
    out = np.zeros((p.shape[0], 3))
    out[:, : p.shape[1]] = p
    return out


def _fmt_vec(v) -> str:
    return "(" + ", ".join(f"{x:.3g}" if abs(x) > 5e-13 else "0" for x in v) + ")"


def _plane_normal(path, pts: np.ndarray) -> np.ndarray | None:
    """Unit normal of the path's plane, or None: the PathGeometry's own when it has one, else
    a plane fitted to the points by SVD (planar when they stray from it by ≤ 1e-9 m + 1e-9 of
    the size)."""
    if hasattr(path, "planar_normal"):
        n = path.planar_normal
        return None if n is None else np.asarray(n, dtype=np.float64)
    c = pts - pts.mean(axis=0)
    _, sv, vt = np.linalg.svd(c, full_matrices=False)
    size = float(np.ptp(pts, axis=0).max()) if len(pts) else 0.0
    if len(sv) < 3 or np.max(np.abs(c @ vt[2])) > 1e-9 * (1.0 + size):
        return None
    return vt[2]


def path_view(path, pts: np.ndarray | None = None) -> PathView:
    """The view of :func:`draw_runs` for ``path`` (a PathGeometry); ``pts`` its drawn points
    (default :func:`path_polyline`). See the module docstring."""
    pts = path_polyline(path) if pts is None else _as3(pts)
    zero = np.zeros(3)
    if getattr(path, "dim", 3) == 2:
        return PathView(
            "xy", (ViewPanel("x–y", zero, _AXES[[0, 1]], "x (m)", "y (m)"),), _AXES[2].copy()
        )
    normal = _plane_normal(path, pts)
    if normal is None:
        views = (("x–y (top)", 0, 1), ("x–z (front)", 0, 2), ("y–z (side)", 1, 2))
        panels = tuple(
            ViewPanel(t, zero, _AXES[[i, j]], f"{_AXIS_NAMES[i]} (m)", f"{_AXIS_NAMES[j]} (m)")
            for t, i, j in views
        )
        return PathView("projections", panels, None, "grid")
    normal = normal / np.linalg.norm(normal)
    k = int(np.argmax(np.abs(normal)))
    if abs(normal[k]) >= 1.0 - 1e-12:
        # parallel to a coordinate plane: machine coordinates, as the projections
        i, j = [a for a in range(3) if a != k]
        u, v, n = _AXES[i], _AXES[j], _AXES[k]
        origin = zero
        level = float(np.mean(pts[:, k]))
        title = f"in the path's plane {_AXIS_NAMES[k]} = {level:.4g} m"
        labels = [f"{_AXIS_NAMES[a]} (m)" for a in (i, j, k)]
    else:
        # inclined: u = the coordinate axis lying most in the plane, projected on it; v = n × u
        # (u, v, n right-handed: a path counter-clockwise about n is drawn counter-clockwise).
        # Drawn coordinates u·p, v·p and the height above the plane, n·p − n·p₀.
        inplane = _AXES - np.outer(_AXES @ normal, normal)
        a = int(np.argmax(np.linalg.norm(inplane, axis=1) + 1e-12 * np.arange(3, 0, -1)))
        u = inplane[a] / np.linalg.norm(inplane[a])
        v = np.cross(normal, u)
        n = normal
        origin = float(pts[0] @ n) * n
        title = f"in the path's plane (normal n = {_fmt_vec(n)})"
        labels = [
            f"in-plane u (m), u = {_fmt_vec(u)}",
            f"in-plane v (m), v = {_fmt_vec(v)}",
            "out of plane n (m)",
        ]
    plan = ViewPanel(title, origin, np.stack([u, v]), labels[0], labels[1])
    extent = np.ptp(plan.project(pts), axis=0)
    if extent[0] >= extent[1]:
        elev = ViewPanel(
            "edge-on: the out-of-plane part", origin, np.stack([u, n]), labels[0], labels[2]
        )
        return PathView("plane", (plan, elev), normal, "below")
    elev = ViewPanel("edge-on: out of plane", origin, np.stack([n, v]), labels[2], labels[1])
    return PathView("plane", (plan, elev), normal, "beside")


def contour_error_vectors(path, positions) -> tuple[np.ndarray, np.ndarray]:
    """(foot, x − foot) for tool positions ``positions`` (n, d) m: the nearest path points
    and the contour-error vectors, both (n, 3) m. Rows with a non-finite position are NaN."""
    pos = _as3(positions)
    foot = np.full_like(pos, np.nan)
    ok = np.all(np.isfinite(pos), axis=1)
    if ok.any():
        foot[ok] = nearest_points(path, pos[ok])
    return foot, pos - foot


def magnified(path, positions, gain: float) -> tuple[np.ndarray, np.ndarray]:
    """(drawn, foot), (n, 3) m: the tool drawn at foot + gain·(x − foot)."""
    foot, err = contour_error_vectors(path, positions)
    return foot + gain * err, foot


def break_at_jumps(drawn: np.ndarray, foot: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """``drawn`` with a NaN row inserted wherever the foot point jumps (it moves more than 1.5
    times as far as the tool, e.g. from one leg of a corner to the other; moving along a curve
    it moves at most r/(r − ε) times as far): the drawn line is broken there instead of
    crossing the picture in a straight stroke."""
    if len(drawn) < 2:
        return drawn
    pos = _as3(positions)
    dfoot = np.linalg.norm(np.diff(foot, axis=0), axis=1)
    dpos = np.linalg.norm(np.diff(pos, axis=0), axis=1)
    jump = np.nonzero(dfoot > 1.5 * dpos + 1e-9)[0]
    if jump.size == 0:
        return drawn
    return np.insert(drawn, jump + 1, np.nan, axis=0)


def nice_gain(peak_m: float, size_m: float, fraction: float = DEVIATION_FRACTION) -> float:
    """The largest 1-2-5 number g with g·peak ≤ fraction·size (1 when there is no error)."""
    if not (peak_m > 0 and np.isfinite(peak_m)) or not size_m > 0:
        return 1.0
    g = fraction * size_m / peak_m
    e = math.floor(math.log10(g))
    for m in (5.0, 2.0, 1.0):
        if m * 10.0**e <= g * (1 + 1e-12):
            return m * 10.0**e
    return 10.0**e


def view_size(view: PathView, pts: np.ndarray) -> float:
    """The path's size in the drawing: its largest drawn extent over the panels (m)."""
    return max(float(np.ptp(p.project(pts), axis=0).max()) for p in view.panels) or 1e-3


def gain_scale_text(gain: float) -> str:
    """What one drawn mm of deviation is worth, for titles."""
    return f"1 mm drawn = {1e3 / gain:.3g} µm" if gain > 1 else f"×{gain:g}"


# ----------------------------------------------------------------------------------------
# drawing
# ----------------------------------------------------------------------------------------


def draw_path_panels(axes, view, pts, tools, gain, size, ax3d=None):
    """Path ``pts`` (black) and ``tools`` (label, drawn (n, 3) m, colour) on each of ``axes``
    (one per panel of ``view``); ``ax3d``: a 3-D axes for the overview. The limits leave room
    for a deviation of 1.3 × DEVIATION_FRACTION × ``size`` around the path (a run off that
    scale, an unstable one, is clipped)."""
    margin = 1.3 * DEVIATION_FRACTION * size
    for ax, panel in zip(axes, view.panels, strict=True):
        p2 = panel.project(pts)
        ax.plot(p2[:, 0], p2[:, 1], "k-", lw=1.3, zorder=3, gid="path")
        ax.plot(p2[:1, 0], p2[:1, 1], "ko", ms=4, zorder=4)  # start
        for label, drawn, color in tools:
            d2 = panel.project(drawn)
            ax.plot(d2[:, 0], d2[:, 1], "-", color=color, lw=1, gid=f"tool:{label}")
        lo, hi = p2.min(axis=0) - margin, p2.max(axis=0) + margin
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_aspect("equal", adjustable="box")
        ax.set_xlabel(panel.xlabel, fontsize=8)
        ax.set_ylabel(panel.ylabel, fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(True, alpha=0.25)
    if ax3d is not None:
        ax3d.plot(pts[:, 0], pts[:, 1], pts[:, 2], "k-", lw=1.2)
        for _, drawn, color in tools:
            ax3d.plot(drawn[:, 0], drawn[:, 1], drawn[:, 2], "-", color=color, lw=0.9)
        lo, hi = pts.min(axis=0) - margin, pts.max(axis=0) + margin
        ax3d.set_xlim(lo[0], hi[0])
        ax3d.set_ylim(lo[1], hi[1])
        ax3d.set_zlim(lo[2], hi[2])
        ax3d.set_box_aspect(hi - lo, zoom=0.85)
        ax3d.set_xlabel("x (m)", fontsize=7)
        ax3d.set_ylabel("y (m)", fontsize=7)
        ax3d.set_zlabel("z (m)", fontsize=7)
        ax3d.tick_params(labelsize=6)
        ax3d.set_title("3-D view, same magnification", fontsize=8)


def _metrics_text(label: str, m: dict | None) -> str:
    if not m:
        return label
    res = m.get("encoder_resolution_um")

    def um(key, spec):  # as the table prints it, with the unit
        text = format_um(m.get(key), res, spec)
        if text == "n/a":
            return text
        return text.replace(" (enc)", " µm (enc)") if text.endswith("(enc)") else f"{text} µm"

    text = (
        f"{label}: max ε {um('max_contour_error_um', '.1f')}, "
        f"RMS ε {um('rms_contour_error_um', '.2f')}"
    )
    if m.get("stable") is False or m.get("completed") is False:
        reason = m.get("incomplete_reason") or m.get("termination_reason")
        text += f" — did not complete ({reason})"
    return text


def _robust_text(r: dict) -> str:
    return (
        f"; ±{r['randomize'] * 100:.0f} %: mean RMS {r['mean_rms_contour_error_um']:.2f}, "
        f"CVaR10 {r['cvar10_rms_contour_error_um']:.2f} µm"
        + (f", {r['failure_rate']:.0%} failed" if r.get("failure_rate") else "")
    )


def _draw_robust_rms(ax, robust, colors):
    """RMS ε of every variation (dots), its mean (solid bar) and CVaR10 (dashed bar)."""
    values = []
    for i, r in enumerate(robust):
        c = colors[r["controller"]]
        per = r.get("rms_contour_error_um_per_episode")
        failed = np.asarray(r.get("failed_per_episode", []), dtype=bool)
        if per is not None:
            per = np.asarray(per, dtype=np.float64)
            ok = np.isfinite(per) & ~failed if failed.size == per.size else np.isfinite(per)
            xs = i + np.linspace(-0.22, 0.22, per.size) if per.size > 1 else np.full(1, i)
            ax.plot(xs[ok], per[ok], "o", color=c, ms=3.5, alpha=0.75, mec="none")
            values.extend(per[ok])
            if (~ok).any():
                ax.annotate(
                    f"{int((~ok).sum())} failed",
                    (i, 1.0),
                    xycoords=("data", "axes fraction"),
                    ha="center",
                    va="top",
                    fontsize=7,
                    color="red",
                )
        mean, cvar = r["mean_rms_contour_error_um"], r["cvar10_rms_contour_error_um"]
        ax.hlines(mean, i - 0.34, i + 0.34, colors=c, lw=2.2)
        ax.hlines(cvar, i - 0.34, i + 0.34, colors=c, lw=1.4, linestyles="--")
        values.extend([mean, cvar])
    v = np.asarray([x for x in values if np.isfinite(x) and x > 0])
    if v.size and v.max() / v.min() > 20:
        ax.set_yscale("log")

        def plain(y, _pos):  # 1, 2, 3, 5 × 10ᵏ in plain numbers
            mant = y / 10.0 ** math.floor(math.log10(y) + 1e-9) if y > 0 else 0.0
            return f"{y:g}" if min(abs(mant - m) for m in (1, 2, 3, 5)) < 1e-6 else ""

        fmt = matplotlib.ticker.FuncFormatter(plain)
        ax.yaxis.set_major_formatter(fmt)
        ax.yaxis.set_minor_formatter(fmt)
        ax.tick_params(axis="y", which="both", labelsize=8)
    ax.set_xticks(range(len(robust)), [r["controller"] for r in robust], fontsize=8)
    ax.set_xlim(-0.6, len(robust) - 0.4)
    ax.set_ylabel("RMS contour error ε (µm)")
    n = robust[0]["episodes"]
    ax.set_title(
        f"{n} plant variations ±{robust[0]['randomize'] * 100:.0f} %: RMS ε of each (dots),"
        " mean (—), CVaR10 = mean of the worst 10 % (– –)",
        fontsize=8,
    )
    ax.grid(True, axis="y", which="both", alpha=0.3)


def _draw_robust_time(ax, robust, colors):
    """ε(t) over the variations: mean (line) and min–max (band) at each instant."""
    drawn = False
    for r in robust:
        tr = r.get("traces")
        if not tr:
            continue
        t = np.asarray(tr["time_s"])
        e = np.asarray(tr["contour_error_m"], dtype=np.float64) * 1e6
        if e.size == 0:
            continue
        c = colors[r["controller"]]
        with np.errstate(all="ignore"):
            lo, hi, mean = np.nanmin(e, axis=1), np.nanmax(e, axis=1), np.nanmean(e, axis=1)
        ax.fill_between(t, lo, hi, color=c, alpha=0.22, lw=0)
        ax.plot(t, mean, color=c, lw=1)
        drawn = True
    if not drawn:
        ax.set_visible(False)
        return
    ax.set_xlabel("time (s)")
    ax.set_ylabel("ε over the variations (µm)")
    ax.set_title("contour error over the variations: mean (line), min–max (band)", fontsize=8)
    ax.grid(True, alpha=0.3)


def add_path_axes(fig, spec, view: PathView, pts: np.ndarray, size: float, header=True):
    """Axes for the path drawing in the gridspec cell ``spec`` of ``fig``: (one axes per panel
    of ``view``, a 3-D overview axes for projections or None, an empty header axes for the
    title text or None). A plan and its elevation get room in proportion to what they show
    (they are drawn at the same scale). ``header``: make the header axes for a plane or
    projections (a single panel takes its title on the axes)."""
    if view.kind == "projections":
        rows = [0.14, 1, 1] if header else [1, 1]
        sub = spec.subgridspec(len(rows), 2, height_ratios=rows)
        r = len(rows) - 2
        ax_head = None
        if header:
            ax_head = fig.add_subplot(sub[0, :])
            ax_head.axis("off")
        axes = [fig.add_subplot(sub[r, 0]), fig.add_subplot(sub[r + 1, 0])]
        axes.append(fig.add_subplot(sub[r + 1, 1]))
        for ax, panel in zip(axes, view.panels, strict=True):
            ax.set_title(panel.title, fontsize=8)
        return axes, fig.add_subplot(sub[r, 1], projection="3d"), ax_head
    if len(view.panels) == 1:
        return [fig.add_subplot(spec)], None, None
    pad = 2 * 1.3 * DEVIATION_FRACTION * size
    plan = np.ptp(view.panels[0].project(pts), axis=0) + pad
    ax_head = None
    if header:
        outer = spec.subgridspec(2, 1, height_ratios=[0.1, 1])
        ax_head = fig.add_subplot(outer[0])
        ax_head.axis("off")
        spec = outer[1]
    if view.layout == "below":
        sub = spec.subgridspec(2, 1, height_ratios=[plan[1], max(pad, 0.12 * plan[1])])
    else:
        sub = spec.subgridspec(1, 2, width_ratios=[plan[0], max(pad, 0.12 * plan[0])])
    axes = [fig.add_subplot(sub[0]), fig.add_subplot(sub[1])]
    for ax, panel in zip(axes, view.panels, strict=True):
        ax.set_title(panel.title, fontsize=8)
    return axes, None, ax_head


def draw_runs(
    records: dict[str, EpisodeRecord],
    path,
    title: str,
    metrics: dict[str, dict] | None = None,
    robust: list[dict] | None = None,
):
    """The figure of :func:`plot_runs`, not saved: returns ``(fig, info)``.

    ``info``: ``gain``; ``view`` (:class:`PathView`); ``foot`` and ``drawn``, dicts label →
    (n, 3) m (nearest path points, and foot + gain·(x − foot) as drawn); ``peak_m`` (largest
    contour error of the runs the env did not stop, m; the gain is chosen from it);
    ``path_axes``, the
    axes of the view panels. On each, the tool lines carry ``gid = "tool:<label>"`` and the
    path ``gid = "path"``; a tool line holds the projected ``drawn`` rows, with a NaN row
    wherever the foot point jumps (across a corner), so that the line breaks there.
    """
    pts = path_polyline(path)
    view = path_view(path, pts)
    size = view_size(view, pts)
    labels = list(records)
    colors = {lab: f"C{i % 10}" for i, lab in enumerate(labels)}
    for r in robust or []:
        colors.setdefault(r["controller"], f"C{len(colors) % 10}")

    foot, err = {}, {}
    for lab, rec in records.items():
        foot[lab], err[lab] = contour_error_vectors(path, rec.position)
    # the gain comes from the runs the env did not stop (a diverged run would flatten the rest)
    peaks = {
        lab: float(np.nanmax(np.linalg.norm(err[lab], axis=1)))
        for lab, rec in records.items()
        if rec.termination_reason is None and np.isfinite(err[lab]).any()
    }
    peak_label = max(peaks, key=peaks.get, default=None)
    peak = peaks[peak_label] if peak_label is not None else 0.0
    gain = nice_gain(peak, size)
    drawn = {lab: foot[lab] + gain * err[lab] for lab in labels}

    has_robust = bool(robust)
    fig = plt.figure(figsize=(15, 11.5 if has_robust else 8.5), layout="constrained")
    outer = fig.add_gridspec(
        3 if has_robust else 2,
        2,
        width_ratios=[1.0, 1.15],
        height_ratios=[1, 1, 0.95] if has_robust else [1, 1],
    )
    path_axes, ax3d, ax_head = add_path_axes(fig, outer[0:2, 0], view, pts, size)
    tools = [
        (lab, break_at_jumps(drawn[lab], foot[lab], records[lab].position), colors[lab])
        for lab in labels
    ]
    draw_path_panels(path_axes, view, pts, tools, gain, size, ax3d)
    head = f"path (black, ● start) and tool, contour error ×{gain:g} ({gain_scale_text(gain)})"
    if peak > 0:
        head += (
            f"\nlargest ε {peak * 1e6:.3g} µm ({peak_label}), drawn "
            f"{peak * gain * 1e3:.3g} mm from the path"
        )
    if ax_head is not None:
        ax_head.text(0.5, 0.5, head, fontsize=9, ha="center", va="center")
    else:
        path_axes[0].set_title(head, fontsize=9)

    ax_eps = fig.add_subplot(outer[0, 1])
    ax_te = fig.add_subplot(outer[1, 1], sharex=ax_eps)
    handles = [plt.Line2D([], [], color="k", lw=1.3, label="path")]
    robust_by = {r["controller"]: r for r in robust or []}
    for lab, rec in records.items():
        ax_eps.plot(rec.time, np.asarray(rec.contour_error) * 1e6, lw=1, color=colors[lab])
        te = np.linalg.norm(np.asarray(rec.tracking_error).reshape(len(rec.time), -1), axis=1)
        ax_te.plot(rec.time, te * 1e6, lw=1, color=colors[lab])
        text = _metrics_text(lab, (metrics or {}).get(lab))
        if lab in robust_by:
            text += _robust_text(robust_by[lab])
        handles.append(plt.Line2D([], [], color=colors[lab], lw=2, label=text))
    for lab, r in robust_by.items():
        if lab not in records:
            handles.append(
                plt.Line2D([], [], color=colors[lab], lw=2, label=lab + _robust_text(r)[1:])
            )
    ax_eps.set_ylabel("true contour error ε (µm)")
    ax_eps.set_title("contour error ε (distance to the nearest path point), nominal plant")
    ax_eps.grid(True, alpha=0.3)
    ax_eps.tick_params(labelbottom=True)
    ax_eps.set_xlabel("time (s)")
    ax_te.set_xlabel("time (s)")
    ax_te.set_ylabel("|x_d − x| (µm)")
    ax_te.set_title("tracking error |x_d − x| (includes the lag along the path)")
    ax_te.grid(True, alpha=0.3)
    if has_robust:
        _draw_robust_rms(fig.add_subplot(outer[2, 0]), robust, colors)
        _draw_robust_time(fig.add_subplot(outer[2, 1]), robust, colors)
    # one row when the entries are few and short, else one entry a line
    one_row = len(handles) <= 3 and all(len(h.get_label()) <= 60 for h in handles)
    fig.legend(
        handles=handles,
        loc="outside lower center",
        ncol=len(handles) if one_row else 1,
        fontsize=8,
        title="colours are the same in every panel",
        title_fontsize=8,
        frameon=False,
    )
    fig.suptitle(title)
    info = {
        "gain": gain,
        "view": view,
        "foot": foot,
        "drawn": drawn,
        "peak_m": peak,
        "path_axes": path_axes,
    }
    return fig, info


def plot_runs(
    records: dict[str, EpisodeRecord],
    path,
    title: str,
    out,
    metrics: dict[str, dict] | None = None,
    robust: list[dict] | None = None,
):
    """One figure, written to ``out`` (PNG): the path and each run's tool with the contour
    error magnified (module docstring), contour error and tracking error vs time, and with
    ``robust`` (rows of :func:`agents.compare.robustness`) the spread over plant variations.

    ``records`` maps a label (controller) to its episode on the nominal plant; ``path`` is
    the PathGeometry followed; ``metrics`` maps a label to its row of scores (legend text).
    Returns ``out``. Five-axis runs (records with an orientation error) get their own figure
    (:func:`contour_env.plotting_five_axis.plot_five_axis_runs`; no robustness panel).
    """
    if any(r.orientation_error is not None for r in records.values()):
        from .plotting_five_axis import plot_five_axis_runs

        if robust:
            raise ValueError("robust: no robustness panel for five-axis runs (--randomize)")
        return plot_five_axis_runs(records, path, title, out, metrics)
    fig, _ = draw_runs(records, path, title, metrics, robust)
    try:
        atomic_save_figure(fig, out, dpi=110)
    finally:
        plt.close(fig)
    return out


def plot_learning(result: dict, out, title: str | None = None):
    """Learning curve (max and RMS contour error per iteration, log scale) and the first and
    last trials' contour error vs time, from :func:`agents.repeated_batch.run_batch`."""
    rows = result["iterations"]
    it = [r["iteration"] for r in rows]
    mx = [np.nan if r["max_contour_error_um"] is None else r["max_contour_error_um"] for r in rows]
    rms = [np.nan if r["rms_contour_error_um"] is None else r["rms_contour_error_um"] for r in rows]
    fig, (ax_l, ax_t) = plt.subplots(1, 2, figsize=(12, 4.5))
    ax_l.semilogy(it, mx, "o-", ms=3, label="max ε")
    ax_l.semilogy(it, rms, "s-", ms=3, label="RMS ε")
    bad = [r["iteration"] for r in rows if r.get("error_growing")]
    if bad:
        ax_l.semilogy(bad, [rms[i - 1] for i in bad], "rx", label="error growing")
    ax_l.set_xlabel("iteration (trial)")
    ax_l.set_ylabel("contour error (µm)")
    ax_l.set_title("learning curve")
    ax_l.grid(True, which="both", alpha=0.3)
    ax_l.legend(fontsize=8)
    for i, trial in sorted(result.get("trials", {}).items()):
        rec = trial.episode(0)
        ax_t.plot(rec.time, rec.contour_error * 1e6, lw=1, label=f"trial {i}")
    ax_t.set_xlabel("time (s)")
    ax_t.set_ylabel("true contour error ε (µm)")
    ax_t.set_title("first and last trial")
    ax_t.grid(True, alpha=0.3)
    ax_t.legend(fontsize=8)
    fig.suptitle(
        title
        or f"{result['controller']} on {result['case']} ({result['plant']}), {len(rows)} iterations"
    )
    fig.tight_layout()
    atomic_save_figure(fig, out, dpi=110)
    plt.close(fig)
    return out
