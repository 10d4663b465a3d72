"""The benchmark's circular-test section: the ISO 230-4 circular ("ballbar") test of every named
2- and 3-axis plant under the feed-drive controllers, clockwise and counter-clockwise.

- what runs: :func:`section_runs` (plant, controller) pairs: every named plant with 2 or 3 axes
  (:func:`plants`; not the five-axis machine) × :data:`CONTROLLERS` where the controller
  configures for the plant (:func:`.design.applies`, as the controller table decides), on the
  circle of :func:`circle_settings`; the suite wraps each pair in a ``circular`` run spec
  (:func:`.suite.circular`);
- one run: :func:`run`, the test itself
  (:func:`contour_env.app.circular_test_run.circular_test`, i.e.
  :func:`contour_env.circular_test.run_circular_test`; no metric is computed here);
- the report: :func:`tables` (per plant a table of G, F_max, F_min, H and the largest reversal
  spike per controller and direction, and a reading generated from its numbers) and
  :func:`write_figures` (per plant the ballbar plot of :mod:`contour_env.app.circular_plot`,
  ``circular_PLANT.png``).

This module imports nothing else of the benchmark package but :mod:`.design` (the suite, the
runs and the report import it).
"""

from __future__ import annotations

from pathlib import Path

from contour_env.circular_test import DEFAULT_FEED_M_S, DEFAULT_OVERSHOOT_DEG, DEFAULT_RADIUS_M

# the record kind of a circular-test run (``case``: the plant's name)
KIND = "circular"
# the feed-drive controllers tested, in table order; each where it configures for the plant
# (jee-ccc needs a velocity-command drive: jee-triaxial only)
CONTROLLERS = ("pd", "ccc", "adaptive-ccc", "jee-ccc")
# the circle: `contour-env circular-test`'s defaults on every plant — R = 50 mm at
# F = 0.2 m/s (12 m/min), 180° feed-in and feed-out overshoot arcs. One circle for all plants,
# so the rows compare across plants and any row is reproduced by `contour-env circular-test
# --plant P --controllers C` without options; 0.2 m/s is within what every named 2/3-axis
# plant holds on it (contour_env.circular_test.max_circle_feed_m_s at R = 50 mm: hsm2
# 0.45 m/s, the lowest; jee-triaxial 0.87, friction-table 1.26, linear-motor 1.46).
RADIUS_M = DEFAULT_RADIUS_M
FEED_M_S = DEFAULT_FEED_M_S
OVERSHOOT_DEG = DEFAULT_OVERSHOOT_DEG
# the headline figure of a record (its ``figure`` and ``ratio_to_pd``): G of the worse direction
HEADLINE = "max_circular_deviation_um"
DIRECTIONS = ("cw", "ccw")
HEADER = [
    "plant",
    "controller",
    "direction",
    "G µm",
    "F_max µm",
    "F_min µm",
    "H µm",
    "largest reversal spike µm",
]
NOTE = (
    "Each controller runs the circle clockwise (CW) and counter-clockwise (CCW) on the "
    "realistic plant (seed 0); figures on the 360° capture arc of the true tool position. "
    "G: circular deviation, the radial range about the least-squares centre; F_max, F_min: "
    "the largest and smallest r − R about the nominal centre; H: hysteresis, the largest "
    "radial gap between CW and CCW at one angle (one per controller, on its CW row); largest "
    "reversal spike: of the four axis reversals' spikes the one of largest magnitude (signed, "
    "> 0 outward), with its axis and angle."
)


def circle_settings(radius_m=None, feed_m_s=None, overshoot_deg=None) -> dict:
    """The settings of a run: ``radius_m`` (m), ``feed_m_s`` (m/s), ``overshoot_deg``
    (degrees); None: the section's (:data:`RADIUS_M`, :data:`FEED_M_S`,
    :data:`OVERSHOOT_DEG`)."""
    return {
        "radius_m": float(RADIUS_M if radius_m is None else radius_m),
        "feed_m_s": float(FEED_M_S if feed_m_s is None else feed_m_s),
        "overshoot_deg": float(OVERSHOOT_DEG if overshoot_deg is None else overshoot_deg),
    }


def variant_name(settings: dict) -> str:
    """The record's ``variant``: the circle, e.g. ``R50mm F0.2m/s``."""
    return f"R{settings['radius_m'] * 1e3:g}mm F{settings['feed_m_s']:g}m/s"


def plants() -> list[str]:
    """The named plants with 2 or 3 axes, in the catalogue's order."""
    from contour_env.plants.catalog import nominal_params, plant_names

    return [p for p in plant_names() if nominal_params(p)[0].n_axes in (2, 3)]


def section_runs(plant_names=None) -> list[tuple[str, str]]:
    """(plant, controller) of the section: every plant of ``plant_names`` (default
    :func:`plants`) × every one of :data:`CONTROLLERS` that configures for it."""
    from .design import applies

    names = plants() if plant_names is None else list(plant_names)
    return [(p, c) for p in names for c in CONTROLLERS if applies(p, c)]


# --- one run ------------------------------------------------------------------------------


def run(plant: str, controller: str, settings: dict, seed: int = 0) -> dict:
    """The circular test of ``controller`` on ``plant``, CW and CCW:
    ``{"plant", "metrics", "trace"}`` — ``metrics`` the test's row for the controller (``cw``,
    ``ccw``: :func:`contour_env.circular_test.circle_metrics` and ``completed``;
    ``hysteresis_um``), the circle's settings, ``completed`` (both directions) and
    :data:`HEADLINE`; ``trace`` per direction the capture arc's ``angle_deg`` and
    ``radial_deviation_um`` (lists, for the polar plot)."""
    from ..circular_test_run import circular_test

    s = circle_settings(
        settings.get("radius_m"), settings.get("feed_m_s"), settings.get("overshoot_deg")
    )
    result = circular_test(
        plant,
        [controller],
        s["radius_m"],
        s["feed_m_s"],
        overshoot_deg=s["overshoot_deg"],
        seed=int(seed),
    )
    traces = result.pop("traces").get(controller, {})
    row = result["results"][controller]
    gs = [row[d]["circular_deviation_um"] for d in DIRECTIONS]
    metrics = {
        **s,
        "spike_window_deg": result["spike_window_deg"],
        "ideal": result["ideal"],
        "completed": all(row[d]["completed"] for d in DIRECTIONS),
        HEADLINE: None if None in gs else max(gs),
        "hysteresis_um": row["hysteresis_um"],
        "cw": row["cw"],
        "ccw": row["ccw"],
    }
    trace = {
        d: {k: [float(v) for v in tr[k]] for k in ("angle_deg", "radial_deviation_um")}
        for d, tr in traces.items()
    }
    return {"plant": result["plant"], "metrics": metrics, "trace": trace}


# --- the report ---------------------------------------------------------------------------


def _fmt(v, digits: int = 3) -> str:
    if v is None:
        return "—"
    from agents.compare import significant

    return significant(float(v), digits)


def _order(controller: str) -> tuple:
    name = controller.split(":")[0]
    return (CONTROLLERS.index(name) if name in CONTROLLERS else len(CONTROLLERS), controller)


def _groups(records: list[dict]) -> dict:
    """(plant, variant, seed) → the section's records of it, plants in the catalogue's order,
    controllers in :data:`CONTROLLERS`' order."""
    from contour_env.plants.catalog import plant_names

    names = plant_names()
    groups: dict = {}
    for r in records:
        if r["kind"] == KIND and not r.get("error"):
            groups.setdefault((r["case"], r["variant"], r["seed"]), []).append(r)

    def key(k):
        return (names.index(k[0]) if k[0] in names else len(names), k[0], k[1], k[2])

    return {
        k: sorted(groups[k], key=lambda r: _order(r["controller"])) for k in sorted(groups, key=key)
    }


def _figure_names(keys) -> dict:
    """(plant, variant, seed) → figure file: ``circular_PLANT.png``, with the circle and seed
    when one plant has several."""
    keys = list(keys)
    out = {}
    for k in keys:
        plant, variant, seed = k
        if sum(1 for j in keys if j[0] == plant) == 1:
            out[k] = f"circular_{plant}.png"
        else:
            slug = "".join(ch if ch.isalnum() or ch in ".-" else "_" for ch in variant)
            out[k] = f"circular_{plant}_{slug}_seed{seed}.png"
    return out


def largest_spike(row: dict) -> dict | None:
    """The reversal spike of ``row`` (one direction's figures) of largest |height|, or None."""
    spikes = [s for s in row.get("reversal_spikes_um") or [] if s["height_um"] is not None]
    return max(spikes, key=lambda s: abs(s["height_um"]), default=None)


def _spike_text(s: dict | None) -> str:
    if s is None:
        return "—"
    sign = "+" if s["height_um"] > 0 else ""
    return f"{sign}{_fmt(s['height_um'])} ({s['axis']} {s['angle_deg']:g}°)"


def table_rows(rows: list[dict]) -> list[list[str]]:
    """The table's text cells: per record (one controller) a CW and a CCW row — plant,
    controller, direction, G, F_max, F_min (µm), H (µm, per controller: on its CW row),
    the largest reversal spike (µm, signed, with its axis and angle)."""
    body = []
    for r in rows:
        m = r["metrics"]
        for d in DIRECTIONS:
            x = m[d]
            spike = _spike_text(largest_spike(x)) if x["completed"] else "did not complete"
            body.append(
                [
                    r["plant"] or r["case"],
                    r["controller"],
                    d.upper(),
                    _fmt(x["circular_deviation_um"]),
                    _fmt(x["radial_deviation_max_um"]),
                    _fmt(x["radial_deviation_min_um"]),
                    _fmt(m["hysteresis_um"]) if d == "cw" else "",
                    spike,
                ]
            )
    return body


def read(plant: str, rows: list[dict]) -> str:
    """One sentence on a plant's table, from its numbers: the controller of smallest G (its
    worse direction) and its ratio to PD's (or to the next best when it is PD), the largest G,
    the smallest hysteresis H; a sentence more per run that did not complete."""
    g = {r["controller"]: r["metrics"].get(HEADLINE) for r in rows}
    ok = [c for c in g if g[c] is not None]
    parts = []
    if ok:
        best = min(ok, key=lambda c: g[c])
        worst = max(ok, key=lambda c: g[c])
        text = (
            f"On {plant}, {best} has the smallest circular deviation G "
            f"({_fmt(g[best])} µm in its worse direction"
        )
        ref = "pd" if best != "pd" and g.get("pd") else None
        if ref is None and len(ok) > 1:
            ref = min((c for c in ok if c != best), key=lambda c: g[c])
        if ref is not None and g[ref]:
            text += f", {_fmt(g[best] / g[ref])}× {ref}'s {_fmt(g[ref])} µm"
        text += ")"
        if worst not in (best, ref):
            text += f" and {worst} the largest ({_fmt(g[worst])} µm)"
        h = {r["controller"]: r["metrics"].get("hysteresis_um") for r in rows}
        h = {c: v for c, v in h.items() if v is not None}
        if len(h) > 1:
            lo, hi = min(h, key=h.get), max(h, key=h.get)
            text += (
                f"; the hysteresis H runs from {_fmt(h[lo])} µm ({lo}) to {_fmt(h[hi])} µm ({hi})"
            )
        parts.append(text + ".")
    for r in rows:
        for d in DIRECTIONS:
            x = r["metrics"][d]
            if not x["completed"]:
                parts.append(
                    f"{r['controller']} did not complete the {d.upper()} circle "
                    f"({x.get('incomplete_reason')})."
                )
    return " ".join(parts)


def tables(records: list[dict]) -> list[dict]:
    """Per plant (and circle, seed): {title, case, sources, header, rows, reading, figure}; the
    first table carries the section's :data:`NOTE` (what the columns are)."""
    groups = _groups(records)
    names = _figure_names(groups)
    out = []
    for key, rows in groups.items():
        plant, _variant, seed = key
        m = rows[0]["metrics"]
        f = m["feed_m_s"]
        out.append(
            {
                "title": f"{plant}: R = {m['radius_m'] * 1e3:g} mm, F = {f:g} m/s "
                f"({f * 60:g} m/min), overshoot {m['overshoot_deg']:g}° (seed {seed})",
                "case": plant,
                "sources": [],
                "note": NOTE if not out else None,
                "header": list(HEADER),
                "rows": table_rows(rows),
                "reading": read(plant, rows),
                "figure": names[key],
            }
        )
    return out


def write_figures(records: list[dict], results: list[dict], out) -> list[Path]:
    """Per plant the ballbar plot (:func:`contour_env.app.circular_plot.plot_circular_test`:
    one polar panel per controller, CW and CCW) into ``out``, written atomically."""
    items: dict = {}
    for r, res in zip(records, results, strict=True):
        if r["kind"] == KIND and not r.get("error"):
            items.setdefault((r["case"], r["variant"], r["seed"]), {})[r["controller"]] = (
                r,
                res.get("trace") or {},
            )
    if not items:
        return []
    import numpy as np

    from ..circular_plot import plot_circular_test

    groups = _groups(records)
    names = _figure_names(groups)
    written = []
    for key, rows in groups.items():
        m = rows[0]["metrics"]
        result = {
            "plant": rows[0]["plant"] or key[0],
            "radius_m": m["radius_m"],
            "feed_m_s": m["feed_m_s"],
            "overshoot_deg": m["overshoot_deg"],
            "results": {},
        }
        traces = {}
        for r in rows:
            rm = r["metrics"]
            c = r["controller"]
            result["results"][c] = {d: rm[d] for d in (*DIRECTIONS, "hysteresis_um")}
            trace = items[key][c][1]
            traces[c] = {
                d: {k: np.asarray(v, float) for k, v in tr.items()} for d, tr in trace.items()
            }
        path = Path(out) / names[key]
        plot_circular_test(result, traces, path)
        written.append(path)
    return written
