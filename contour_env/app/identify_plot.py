"""The plot of ``contour-env identify --plot``: per axis, on the held-out part of the trace,
the measured and the simulated position and velocity and the position residual.

Each simulation window (:mod:`contour_env.identify`) starts from the measured state; the
simulated curves are drawn window by window (a gap at each restart), the measured ones whole.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..io import atomic_save_figure  # noqa: E402

__all__ = ["plot_identification"]


def _broken(t, y, starts):
    """t, y with NaN between windows (a window starts at each value of ``starts``)."""
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    if len(t) == 0:
        return t, y
    H = len(t) // max(len(starts), 1)
    if H < 1 or H * len(starts) != len(t):
        return t, y
    tt = np.full((len(starts), H + 1), np.nan)
    yy = np.full((len(starts), H + 1), np.nan)
    tt[:, :H] = t.reshape(len(starts), H)
    yy[:, :H] = y.reshape(len(starts), H)
    return tt.ravel(), yy.ravel()


def plot_identification(ident, path) -> None:
    """Write the figure of an :class:`~contour_env.identify.Identification` to ``path``
    (format from the suffix), atomically."""
    fits = ident.axes
    fig, axes = plt.subplots(
        len(fits), 3, figsize=(15, 3.4 * len(fits)), squeeze=False, constrained_layout=True
    )
    for row, fit in zip(axes, fits, strict=True):
        d = fit.plot
        if not d:
            for ax in row:
                ax.text(0.5, 0.5, "no windows to show", ha="center", va="center")
                ax.set_axis_off()
            continue
        t = d["time_s"]
        starts = d["window_starts_s"]
        part = d.get("part", "held-out")
        err = fit.holdout_error if part == "held-out" else fit.fit_error
        mp = np.asarray(d["measured_position"]) * 1e3
        sp = np.asarray(d["simulated_position"]) * 1e3
        mv = np.asarray(d["measured_velocity"]) * 1e3
        sv = np.asarray(d["simulated_velocity"]) * 1e3
        ax = row[0]
        ax.plot(*_broken(t, mp, starts), lw=1.4, color="0.55", label="measured")
        ax.plot(*_broken(t, sp, starts), lw=0.9, color="tab:red", label="simulated")
        ax.set_ylabel(f"axis {fit.axis}: position, mm")
        pe = err.get("position")
        ax.set_title(f"position ({part}; normalised error {pe:.3g})" if pe is not None else "")
        ax.legend(loc="best", fontsize=8)
        ax = row[1]
        ax.plot(*_broken(t, mv, starts), lw=1.4, color="0.55", label="measured")
        ax.plot(*_broken(t, sv, starts), lw=0.9, color="tab:red", label="simulated")
        ax.set_ylabel("velocity, mm/s")
        ve = err.get("velocity")
        ax.set_title(f"velocity ({part}; normalised error {ve:.3g})" if ve is not None else "")
        ax = row[2]
        ax.plot(*_broken(t, (sp - mp) * 1e3, starts), lw=0.8, color="tab:blue")
        ax.axhline(0.0, color="0.3", lw=0.6)
        ax.set_ylabel("simulated − measured position, µm")
        ax.set_title(
            f"residual; delay {fit.delay_periods} period(s), m = {fit.values['mass']:.4g} kg"
        )
        for ax in row:
            ax.set_xlabel("time, s")
            ax.grid(True, lw=0.3)
    fig.suptitle(f"identification of {ident.trace.source}: simulated windows vs measured")
    try:
        atomic_save_figure(fig, path, dpi=110)
    finally:
        plt.close(fig)
