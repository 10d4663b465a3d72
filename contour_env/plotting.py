"""Plots people would rather look at than read: trajectory with magnified error, error vs time."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .io import atomic_save_figure  # noqa: E402
from .metrics import EpisodeRecord  # noqa: E402


def plot_runs(
    records: dict[str, EpisodeRecord],
    path_points: np.ndarray,
    title: str,
    out,
    metrics: dict[str, dict] | None = None,
):
    """One figure: path and actual trajectories (error magnified), contour error vs time,
    tracking error vs time. ``records`` maps a label (controller) to its episode."""
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.5))
    ax_path, ax_eps, ax_te = axes
    span = path_points.max(axis=0) - path_points.min(axis=0)
    i, j = sorted(int(v) for v in np.argsort(span)[::-1][:2])
    ax_path.plot(path_points[:, i], path_points[:, j], "k-", lw=1.2, label="path")
    size = float(max(span[i], span[j], 1e-6))
    peak = max(
        (np.nanmax(r.contour_error) for r in records.values() if len(r.contour_error)), default=0.0
    )
    gain = 0.05 * size / peak if peak > 0 and np.isfinite(peak) else 1.0
    for label, r in records.items():
        mag = r.reference + gain * (r.position - r.reference)
        text = label
        if metrics and label in metrics:
            m = metrics[label]
            if m.get("rms_contour_error_um") is not None:
                text += (
                    f" (max {m['max_contour_error_um']:.1f} µm, "
                    f"RMS {m['rms_contour_error_um']:.1f} µm)"
                )
        ax_path.plot(mag[:, i], mag[:, j], lw=1, label=label)
        ax_eps.plot(r.time, r.contour_error * 1e6, lw=1, label=text)
        te = np.linalg.norm(r.tracking_error, axis=1)
        ax_te.plot(r.time, te * 1e6, lw=1, label=label)
    ax_path.set_aspect("equal", adjustable="datalim")
    ax_path.set_xlabel(f"{'xyz'[i]} (m)")
    ax_path.set_ylabel(f"{'xyz'[j]} (m)")
    ax_path.set_title(f"trajectory, error magnified ×{gain:.3g}")
    ax_path.legend(fontsize=7)
    ax_eps.set_xlabel("time (s)")
    ax_eps.set_ylabel("true contour error ε (µm)")
    ax_eps.set_title("contour error")
    ax_eps.legend(fontsize=7)
    ax_eps.grid(True, alpha=0.3)
    ax_te.set_xlabel("time (s)")
    ax_te.set_ylabel("|x_d − x| (µm)")
    ax_te.set_title("tracking error magnitude")
    ax_te.grid(True, alpha=0.3)
    fig.suptitle(title)
    fig.tight_layout()
    atomic_save_figure(fig, out, dpi=110)
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
