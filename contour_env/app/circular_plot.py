"""The circular test's polar plot, laid out as a ballbar report: per controller one polar panel
with the nominal circle and the radial deviation r − R (µm, about the nominal centre)
magnified on it, clockwise and counter-clockwise in two colours, the deviation scale in µm per
division in the panel's title and a small table of G, F_max, F_min (per direction) and H under
it (:mod:`contour_env.circular_test`).

Magnification. The radial axis of a panel is the deviation in µm, not the radius: the
concentric grid circles are divisions of a 1-2-2.5-5 step (µm/div), the thick dashed circle is
the nominal circle (deviation 0) and a point at angle θ is drawn at its deviation from it, so
a 10 µm deviation on a 50 mm circle is as visible as on a 500 mm one. Each panel has its own
scale (the range of its two traces and 0), chosen so that they span at most
:data:`MAX_DIVISIONS` divisions; the scale is printed in the panel's title. The centre of the
panel is empty (the radial axis starts half the span inside its innermost division), as on a
ballbar plot.
"""

from __future__ import annotations

import math

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..io import atomic_save_figure  # noqa: E402

__all__ = ["MAX_DIVISIONS", "deviation_scale", "plot_circular_test"]

# the traces and the nominal circle span at most this many divisions of a panel
MAX_DIVISIONS = 6
COLORS = {"cw": "tab:blue", "ccw": "tab:red"}
LABELS = {"cw": "clockwise (CW)", "ccw": "counter-clockwise (CCW)"}
PANELS_PER_ROW = 3


def deviation_scale(lo_um: float, hi_um: float) -> tuple[float, float, float]:
    """(µm per division, lower, upper limit in µm) of a panel that shows the deviations from
    ``lo_um`` to ``hi_um`` (µm) and 0 (the nominal circle): the smallest step of the
    1-2-2.5-5 series for which they span at most :data:`MAX_DIVISIONS` divisions, the limits
    whole divisions with one division to spare on each side."""
    lo, hi = min(0.0, float(lo_um)), max(0.0, float(hi_um))
    span = max(hi - lo, 1e-3)
    step = None
    for exp in range(-3, 7):
        for m in (1.0, 2.0, 2.5, 5.0):
            s = m * 10.0**exp
            if math.ceil(hi / s - 1e-9) - math.floor(lo / s + 1e-9) <= MAX_DIVISIONS:
                step = s
                break
        if step is not None:
            break
    step = step or 10.0 ** math.ceil(math.log10(span))
    return step, (math.floor(lo / step + 1e-9) - 1) * step, (math.ceil(hi / step - 1e-9) + 1) * step


def _closed(angle_deg, dev_um) -> tuple[np.ndarray, np.ndarray]:
    # the trace in angle order, closed (its first point repeated at the end)
    order = np.argsort(angle_deg)
    th = np.radians(np.asarray(angle_deg)[order])
    dv = np.asarray(dev_um)[order]
    return np.append(th, th[0] + 2 * np.pi), np.append(dv, dv[0])


def _fmt(value, unit: str = "") -> str:
    return f"{'n/a':>7s}" if value is None else f"{value:7.2f}{unit}"


def _table(row: dict) -> str:
    lines = [f"{'':4s} {'G':>7s} {'F_max':>7s} {'F_min':>7s}   µm"]
    for d in ("cw", "ccw"):
        r = row[d]
        lines.append(
            f"{d.upper():4s} {_fmt(r['circular_deviation_um'])} "
            f"{_fmt(r['radial_deviation_max_um'])} {_fmt(r['radial_deviation_min_um'])}"
        )
    lines.append(f"H  {_fmt(row['hysteresis_um'])} µm (CW vs CCW)")
    spikes = []
    for d in ("cw", "ccw"):
        rev = row[d].get("reversal_spikes_um") or []
        text = " ".join("n/a" if s["height_um"] is None else f"{s['height_um']:+.1f}" for s in rev)
        text = text or "n/a (did not complete)"
        spikes.append(f"{d.upper():4s} {text}")
    lines.append("spikes µm at x0° y90° x180° y270°:")
    lines.extend(spikes)
    return "\n".join(lines)


def plot_circular_test(result: dict, traces: dict, out) -> None:
    """Write the ballbar plot of ``result`` (:func:`contour_env.circular_test.run_circular_test`
    without its traces) and ``traces`` (its ``traces``: per controller and direction the
    capture arc's ``angle_deg`` (degrees) and ``radial_deviation_um`` (µm)) to ``out`` (PNG,
    written atomically)."""
    labels = list(result["results"])
    n = max(len(labels), 1)
    ncols = min(n, PANELS_PER_ROW)
    nrows = math.ceil(n / ncols)
    # the layout in inches: per row a polar panel above its table, the title on top, the
    # legend at the bottom
    top_in, bottom_in, table_in, polar_in, title_in = 0.8, 0.45, 1.6, 3.7, 0.75
    row_in = table_in + polar_in + title_in
    width_in, height_in = 4.9 * ncols, top_in + nrows * row_in + bottom_in
    fig = plt.figure(figsize=(width_in, height_in))
    try:
        r_m, f = result["radius_m"], result["feed_m_s"]
        fig.suptitle(
            f"ISO 230-4 circular test — plant {result['plant']}, R = {r_m * 1e3:g} mm, "
            f"F = {f:g} m/s ({f * 60:g} m/min), overshoot {result['overshoot_deg']:g}°, "
            "x–y plane\nradial deviation r − R about the nominal centre, magnified",
            fontsize=11,
            y=1.0 - 0.1 / height_in,
            va="top",
        )
        handles = {}
        for i, label in enumerate(labels):
            row = result["results"][label]
            run = traces.get(label, {})
            col, rr = i % ncols, i // ncols
            cell_w = 1.0 / ncols
            x0 = col * cell_w
            row_bottom_in = height_in - top_in - (rr + 1) * row_in
            ax = fig.add_axes(
                [
                    x0 + 0.5 * cell_w - 0.5 * polar_in / width_in,
                    (row_bottom_in + table_in) / height_in,
                    polar_in / width_in,
                    polar_in / height_in,
                ],
                projection="polar",
            )
            devs = [run[d]["radial_deviation_um"] for d in ("cw", "ccw") if d in run]
            lo = min((float(np.min(v)) for v in devs), default=-1.0)
            hi = max((float(np.max(v)) for v in devs), default=1.0)
            step, rlo, rhi = deviation_scale(lo, hi)
            ax.set_rlim(rlo, rhi)
            ax.set_rorigin(rlo - 0.5 * (rhi - rlo))
            ticks = np.arange(rlo, rhi + 0.5 * step, step)
            ax.set_rticks(ticks)
            # every other division labelled when there are many
            every = 1 if len(ticks) <= 6 else 2
            ax.set_yticklabels(
                [
                    ("0" if t == 0 else f"{t:+g}") if round(t / step) % every == 0 else ""
                    for t in np.round(ticks, 9)
                ],
                fontsize=7,
            )
            ax.set_rlabel_position(112.5)
            for text in ax.get_yticklabels():
                if text.get_text():
                    text.set_bbox(dict(facecolor="white", edgecolor="none", alpha=0.75, pad=0.5))
            ax.set_thetagrids(range(0, 360, 45), fontsize=8)
            ax.grid(True, linewidth=0.5, alpha=0.6)
            th = np.linspace(0, 2 * np.pi, 721)
            (nom,) = ax.plot(th, np.zeros_like(th), "k--", linewidth=1.3)
            handles["nominal circle (0 µm)"] = nom
            for d in ("cw", "ccw"):
                if d not in run:
                    continue
                t, v = _closed(run[d]["angle_deg"], run[d]["radial_deviation_um"])
                (h,) = ax.plot(t, v, color=COLORS[d], linewidth=1.1)
                handles[LABELS[d]] = h
            missing = [d for d in ("cw", "ccw") if not row[d]["completed"]]
            status = f" ({'/'.join(d.upper() for d in missing)} incomplete)" if missing else ""
            ax.set_title(f"{label}{status}\nscale {step:g} µm/div", fontsize=10, pad=12)
            if missing:
                reason = row[missing[0]].get("incomplete_reason") or "no data"
                ax.text(
                    0.5,
                    0.5,
                    f"{'/'.join(d.upper() for d in missing)} did not complete:\n{reason}",
                    transform=ax.transAxes,
                    ha="center",
                    va="center",
                    fontsize=8,
                    color="dimgray",
                    bbox=dict(facecolor="white", edgecolor="none", alpha=0.85),
                )
            fig.text(
                x0 + 0.5 * cell_w,
                (row_bottom_in + table_in - 0.3) / height_in,
                _table(row),
                ha="center",
                va="top",
                family="monospace",
                fontsize=8,
            )
        fig.legend(
            list(handles.values()),
            list(handles.keys()),
            loc="lower center",
            ncol=3,
            fontsize=9,
            frameon=False,
        )
        atomic_save_figure(fig, out, dpi=110)
    finally:
        plt.close(fig)
