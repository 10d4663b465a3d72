"""The plot of five-axis runs (``contour-env run/compare --plot`` on the five-axis plant): the
tool-tip contour error and the tool's orientation error against time, on log scales (PD and
ISMC differ by one to two orders of magnitude), and the reference tool-tip path in the
workpiece frame. At µm against a path of centimetres a tool drawn on the path would sit on it;
the errors are read from the two time panels.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .io import atomic_save_figure  # noqa: E402
from .metrics import EpisodeRecord  # noqa: E402
from .paths.geometry import path_polyline  # noqa: E402
from .tool_errors import ARCSEC_PER_RAD  # noqa: E402

# floor of the log axes: errors below it (an exact start) are drawn at it
FLOOR_UM, FLOOR_ARCSEC = 1e-3, 1e-3


def _num(x: float) -> str:
    return f"{x:,.0f}" if abs(x) >= 1000 else f"{x:.3g}"


def _legend_label(name: str, m: dict | None) -> str:
    if not m:
        return name
    parts = [name]
    if m.get("rms_contour_error_um") is not None:
        parts.append(f"RMS ε {_num(m['rms_contour_error_um'])} µm")
    if m.get("rms_orientation_error_arcsec") is not None:
        parts.append(f"RMS θ {_num(m['rms_orientation_error_arcsec'])}″")
    if m.get("incomplete"):
        parts.append("incomplete")
    return ", ".join(parts)


def plot_five_axis_runs(
    records: dict[str, EpisodeRecord], path, title: str, out, metrics: dict | None = None
):
    """One PNG at ``out``: tool-tip contour error ε (µm) and orientation error θ (arc-seconds)
    vs time for each run of ``records`` (label → record with ``orientation_error``), and the
    reference tool-tip path ``path`` (PathGeometry, m) in 3-D. Returns ``out``."""
    metrics = metrics or {}
    fig = plt.figure(figsize=(13, 8))
    ax_e = fig.add_subplot(2, 2, 1)
    ax_o = fig.add_subplot(2, 2, 3, sharex=ax_e)
    ax_p = fig.add_subplot(1, 2, 2, projection="3d")
    for name, rec in records.items():
        t = rec.time
        line = ax_e.semilogy(
            t, np.maximum(rec.contour_error * 1e6, FLOOR_UM), lw=1.0,
            label=_legend_label(name, metrics.get(name)),
        )[0]  # fmt: skip
        if rec.orientation_error is not None:
            ax_o.semilogy(
                t, np.maximum(rec.orientation_error * ARCSEC_PER_RAD, FLOOR_ARCSEC),
                lw=1.0, color=line.get_color(),
            )  # fmt: skip
        if rec.termination_reason:
            ax_e.axvline(t[-1], color=line.get_color(), ls=":", lw=1.0)
    ax_e.set_ylabel("tool-tip contour error ε (µm)")
    ax_e.grid(True, which="both", alpha=0.3)
    ax_o.set_ylabel("orientation error θ (″)")
    ax_o.set_xlabel("time (s)")
    ax_o.grid(True, which="both", alpha=0.3)
    pts = path_polyline(path, 2000)
    ax_p.plot(pts[:, 0] * 1e3, pts[:, 1] * 1e3, pts[:, 2] * 1e3, "k-", lw=1.2)
    ax_p.scatter(*(pts[0] * 1e3), color="g", s=25, label="start")
    ax_p.set_xlabel("x_w (mm)")
    ax_p.set_ylabel("y_w (mm)")
    ax_p.set_zlabel("z_w (mm)")
    ax_p.set_title("reference tool-tip path (workpiece frame)")
    ax_p.legend(loc="upper left")
    fig.suptitle(title)
    handles, labels = ax_e.get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=max(1, len(labels)), frameon=False)
    fig.tight_layout(rect=(0, 0.06, 1, 0.96))
    try:
        atomic_save_figure(fig, out, dpi=110)
    finally:
        plt.close(fig)
    return out
