"""rgb_array rendering: path, actual trajectory with the error magnified, error vs time."""

from __future__ import annotations

import numpy as np


def magnified_trajectory(
    path_points: np.ndarray, positions: np.ndarray, reference: np.ndarray, gain: float
) -> np.ndarray:
    """Reference + gain × (actual − reference): makes µm errors visible on a m-scale plot."""
    return reference + gain * (positions - reference)


def render_rgb(core, history) -> np.ndarray:
    """Render the episode so far as an (H, W, 3) uint8 image."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8, 4), dpi=80)
    ax_path = fig.add_subplot(1, 2, 1)
    ax_err = fig.add_subplot(1, 2, 2)
    ref = core.ref_pav[:, 0, :]
    # in-plane coordinates: the two directions the path spans most
    span = ref.max(axis=0) - ref.min(axis=0)
    i, j = np.argsort(span)[::-1][:2]
    i, j = sorted((int(i), int(j)))
    ax_path.plot(ref[:, i], ref[:, j], "k-", lw=1, label="path")
    if history:
        t = np.array([h[0] for h in history])
        pos = np.array([np.pad(h[1], (0, 3 - len(h[1]))) for h in history])
        eps = np.array([h[2] for h in history])
        k = np.minimum(np.round(t / core.T).astype(int), core.n_steps - 1)
        size = float(max(span[i], span[j], 1e-6))
        peak = float(np.nanmax(np.abs(eps))) if np.isfinite(eps).any() else 0.0
        gain = 0.05 * size / peak if peak > 0 else 1.0
        mag = magnified_trajectory(ref, pos, ref[k], gain)
        ax_path.plot(mag[:, i], mag[:, j], "r-", lw=1, label=f"actual, error ×{gain:.3g}")
        ax_err.plot(t, eps * 1e6, "r-", lw=1)
    ax_path.set_aspect("equal", adjustable="datalim")
    ax_path.set_xlabel(f"{'xyz'[i]} (m)")
    ax_path.set_ylabel(f"{'xyz'[j]} (m)")
    ax_path.legend(loc="upper right", fontsize=7)
    ax_path.set_title(core.setup.name, fontsize=9)
    ax_err.set_xlabel("time (s)")
    ax_err.set_ylabel("true contour error (µm)")
    ax_err.grid(True, alpha=0.3)
    fig.tight_layout()
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[:, :, :3].copy()
