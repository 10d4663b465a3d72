"""Jee & Lee (2007) design chart (Fig. 5), recommended gains (§3), report and plot of the
cross-coupling controller; the analysis they build on is :mod:`contour_env.analysis.jee_design`.

**Design chart (Fig. 5).** Over a (K_P, C_P) grid with C_I = 2.62 C_P and C_D = 0.02 C_P (the
paper's ratios), for each feedrate: stable (Jury on eq. 16, every axis, M ∈ {0, 1}) and
predicted steady-state contour error ≤ 25 µm and tracking error ≤ 250 µm on a circle of radius
R (default 50 mm). The prediction is the controller law's harmonic-balance steady state on the
design model (nominal m, b; with the one-period computation delay for the realistic model),
worst over the xy, yz and zx circles, which covers the mismatch of every pair of Table 1's axes
(a plane through all three, like jee-circle3d's, lies within 2 % of that worst). The paper's
matched-system analysis per axis would miss that mismatch: on the (1, 1, 1) plane it
under-predicts the contour error about 3×.

``admissible`` marks where gains may be picked. Realistic model: the project's loop-margin
requirement, gain margin ≥ 6 dB and phase margin ≥ 30° with the loop stable, estimated per axis
(SISO tangential loop ``K_P g z⁻¹`` and normal loop ``(K_P + G_C) g z⁻¹`` on the simulated
plant's true masses × {0.8, 1, 1.2}; the full MIMO check is ``agents.margins.loop_margins``,
which gives the same figures for jee-triaxial because its worst cases lie on the coordinate
directions). Ideal model (the paper's, which only asks for stability): Jury-stable with every
gain doubled, i.e. a 6 dB gain margin as for the axial default K_P = half its limit.

**Recommended gains (§3).** The paper: K_P the lowest that meets the tracking requirement, then
the C_P that maximises the contouring performance ("lower right portion of the design range,
near point C"), at the design feedrate (10 m/min, jee-circle3d's). When no admissible point
meets both requirements, the admissible point minimising the worst normalised error
``max(ε/25 µm, E/250 µm)`` is taken (ties within 0.5 % broken by the lower contour error) and
the missed requirement(s) named. The choice is refined on a fine grid around the coarse one.

All quantities SI (m, s); errors in the reports in µm.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..analysis.jee import DEFAULT_FEEDRATES_M_S, _check_circle, _circle_basis, format_cell
from ..analysis.jee_design import (
    CD_RATIO,
    CI_RATIO,
    CONTOUR_GOAL_M,
    M_VALUES,
    MASS_CORNERS,
    MIN_GAIN_MARGIN_DB,
    MIN_PHASE_MARGIN_DEG,
    TRACKING_GOAL_M,
    _cc_polys,
    _design_plant,
    _harmonic_balance,
    _orbit_errors,
    _true_models,
    cc_stable,
    cross_coupling_region,
    design_models,
    jury_stable_batch,
    simulate_cc_circle,
    siso_margins_grid,
    steady_state_cc_circle,
)

__all__ = [
    "DESIGN_FEEDRATE_M_S",
    "chart_to_json",
    "cross_coupling_report",
    "design",
    "design_chart",
    "format_cross_coupling_report",
    "loop_margins_of",
    "plot_design",
    "recommend_gains",
    "run_cross_coupling",
]

#: Design feedrate of the recommended gains: jee-circle3d's 10 m/min.
DESIGN_FEEDRATE_M_S = 10.0 / 60.0


# --------------------------------------------------------------------------- design chart


def _kp_upper(models, delay) -> float:
    """Upper end of the common stable K_P range (Ω1, every axis), with or without the delay."""
    hi = math.inf
    for mdl in models:
        lo_k, hi_k = 0.0, 2.0 * (1.0 + mdl.r) / max(mdl.H1 - mdl.H0, 1e-300)
        hi_k = min(hi_k, 1e6)
        if not jury_stable_batch(_cc_polys(mdl, hi_k, 0, 0, 0, 0.0, delay))[0]:
            for _ in range(80):
                mid = 0.5 * (lo_k + hi_k)
                if jury_stable_batch(_cc_polys(mdl, mid, 0, 0, 0, 0.0, delay))[0]:
                    lo_k = mid
                else:
                    hi_k = mid
        hi = min(hi, hi_k)
    return hi


def _cp_upper(models, delay, kp) -> float:
    """Largest stable C_P on the paper's ratio line at a small K_P (the chart's C_P span)."""
    cps = np.linspace(0.0, 200.0, 4001)
    ok = cc_stable(models, kp, cps, CI_RATIO * cps, CD_RATIO * cps, delay=delay)[0]
    idx = np.flatnonzero(ok)
    return float(cps[idx.max()]) if idx.size else 1.0


def design_chart(
    plant="jee-triaxial",
    *,
    realistic: bool = False,
    kp_values=None,
    cp_values=None,
    feedrates_m_s: Sequence[float] = DEFAULT_FEEDRATES_M_S,
    radius_m: float = 0.05,
    planes=("xy", "yz", "zx"),
    harmonics: int = 3,
    margins: bool | None = None,
    n_phase: int = 180,
    **plant_kw,
) -> dict:
    """Jee's Fig. 5: over a (K_P, C_P) grid with C_I = 2.62 C_P, C_D = 0.02 C_P, where the loop
    is stable and the predicted steady-state contour error ≤ 25 µm and tracking error ≤ 250 µm.

    The prediction is the controller law's harmonic-balance steady state on the design model
    (nominal m, b; the delay when ``realistic``) on a circle of ``radius_m`` at each feedrate,
    worst over ``planes`` (default the three coordinate planes: every pair of the mismatched
    axes; a plane through all three, e.g. normal (1, 1, 1), lies within 2 % of that worst for
    Table 1). ``admissible`` marks where a design may be picked: with ``margins`` (default:
    when realistic) the SISO loop-margin estimate (:func:`siso_margins_grid`, arrays
    ``gain_margin_db``, ``phase_margin_deg``) meets GM ≥ 6 dB, PM ≥ 30° and the loop is stable;
    without, the loop stays stable with every gain doubled.

    Returns a dict of numpy arrays (``kp_values`` (nk,), ``cp_values`` (nc,), ``stable``
    (nk, nc), per feedrate ``contour_um``, ``tracking_um``, ``meets`` (nk, nc)) and settings;
    :func:`chart_to_json` makes it JSON-ready.
    """
    base = _design_plant(plant, realistic, plant_kw)
    models, delay = design_models(base)
    if kp_values is None:
        kmax = _kp_upper(models, delay)
        kp_values = np.linspace(kmax / 45.0, kmax, 45)
    if cp_values is None:
        cmax = _cp_upper(models, delay, float(np.min(kp_values)))
        cp_values = np.linspace(0.0, 1.02 * cmax, 45)
    kpv = np.asarray(kp_values, dtype=np.float64)
    cpv = np.asarray(cp_values, dtype=np.float64)
    KP, CP = np.meshgrid(kpv, cpv, indexing="ij")
    CI, CD = CI_RATIO * CP, CD_RATIO * CP
    stable = cc_stable(models, KP, CP, CI, CD, delay=delay)[0].reshape(KP.shape)
    doubled = cc_stable(models, 2 * KP, 2 * CP, 2 * CI, 2 * CD, delay=delay)[0].reshape(KP.shape)
    F = _check_circle(radius_m, feedrates_m_s)
    per_f = []
    for f in F:
        w = float(f) / float(radius_m)
        worst_c = np.zeros(KP.size)
        worst_t = np.zeros(KP.size)
        for plane in planes:
            u, v = _circle_basis(plane, len(models))
            S, Ehat, _, _ = _harmonic_balance(
                models, KP, CP, CI, CD, radius_m, w, u, v, delay, harmonics
            )
            c, t = _orbit_errors(S, Ehat, radius_m, u, v, n_phase)
            worst_c = np.maximum(worst_c, c)
            worst_t = np.maximum(worst_t, t)
        c_um = np.where(stable.ravel(), worst_c * 1e6, np.nan).reshape(KP.shape)
        t_um = np.where(stable.ravel(), worst_t * 1e6, np.nan).reshape(KP.shape)
        meets = stable & (c_um <= CONTOUR_GOAL_M * 1e6) & (t_um <= TRACKING_GOAL_M * 1e6)
        per_f.append(
            {"feedrate_m_s": float(f), "contour_um": c_um, "tracking_um": t_um, "meets": meets}
        )
    out = {
        "plant": base.name,
        "model": "realistic" if realistic else "ideal",
        "delay": delay,
        "radius_m": float(radius_m),
        "planes": [p if isinstance(p, str) else [float(x) for x in p] for p in planes],
        "harmonics": int(harmonics),
        "ci_ratio": CI_RATIO,
        "cd_ratio": CD_RATIO,
        "contour_goal_um": CONTOUR_GOAL_M * 1e6,
        "tracking_goal_um": TRACKING_GOAL_M * 1e6,
        "kp_values": kpv,
        "cp_values": cpv,
        "stable": stable,
        "admissible": stable & doubled,
        "admissible_rule": "Jury-stable with every gain doubled (a 6 dB gain margin, as the "
        "axial default K_P = half its limit)",
        "feedrates": per_f,
    }
    if margins if margins is not None else realistic:
        m = siso_margins_grid(base, KP, CP)
        out["gain_margin_db"] = m["gain_margin_db"]
        out["phase_margin_deg"] = m["phase_margin_deg"]
        out["admissible"] = (
            m["stable"]
            & stable
            & (m["gain_margin_db"] >= MIN_GAIN_MARGIN_DB)
            & (m["phase_margin_deg"] >= MIN_PHASE_MARGIN_DEG)
        )
        out["admissible_rule"] = (
            f"GM ≥ {MIN_GAIN_MARGIN_DB:g} dB, PM ≥ {MIN_PHASE_MARGIN_DEG:g}° (per-axis SISO "
            f"tangential and normal loops, true masses × {list(MASS_CORNERS)})"
        )
    return out


def recommend_gains(
    chart: dict, design_feedrate_m_s: float = DESIGN_FEEDRATE_M_S, *, among: str = "admissible"
) -> dict:
    """The paper's rule (§3) on a :func:`design_chart` at the feedrate nearest
    ``design_feedrate_m_s``: among admissible points (``chart["admissible"]``: ideal model,
    stable with every gain doubled; realistic, the loop-margin requirement; ``among="stable"``:
    every Jury-stable point, the paper's own design range) that meet both requirements, the
    lowest K_P, then the C_P with the lowest predicted contour error. When none meets them, the
    admissible point with the lowest ``max(ε/25 µm, E/250 µm)`` (ties within 0.5 % to the
    lower ε); ``binding`` names the requirement(s) missed."""
    if among not in ("admissible", "stable"):
        raise ValueError(f"among: 'admissible' or 'stable', got {among!r}")
    fr = [f["feedrate_m_s"] for f in chart["feedrates"]]
    j = int(np.argmin(np.abs(np.asarray(fr) - design_feedrate_m_s)))
    f = chart["feedrates"][j]
    ok = np.asarray(chart[among], dtype=bool)
    rule_name = chart["admissible_rule"] if among == "admissible" else "Jury-stable"
    if not np.any(ok):
        raise ValueError(f"chart: no admissible point on the grid ({rule_name})")
    c, t = np.asarray(f["contour_um"]), np.asarray(f["tracking_um"])
    good = ok & np.asarray(f["meets"], dtype=bool)
    cg, tg = chart["contour_goal_um"], chart["tracking_goal_um"]
    if np.any(good):
        i = int(np.min(np.nonzero(np.any(good, axis=1))[0]))
        cand = np.flatnonzero(good[i])
        k = int(cand[np.argmin(c[i, cand])])
        rule = "paper §3: lowest K_P meeting both requirements, then the C_P of least contour error"
        binding = []
    else:
        v = np.where(ok, np.maximum(c / cg, t / tg), np.inf)
        best = float(np.min(v))
        near = np.argwhere(v <= best * 1.005)
        i, k = (int(x) for x in near[np.argmin([c[a, b] for a, b in near])])
        rule = (
            "no admissible point meets both requirements: least max(contour/goal, "
            "tracking/goal), ties (0.5 %) to the lower contour error"
        )
        binding = [
            name
            for name, val, goal in (("contour", c[i, k], cg), ("tracking", t[i, k], tg))
            if val > goal
        ]
    kp, cp = float(chart["kp_values"][i]), float(chart["cp_values"][k])
    out = {
        "K_P": kp,
        "C_P": cp,
        "C_I": CI_RATIO * cp,
        "C_D": CD_RATIO * cp,
        "model": chart["model"],
        "design_feedrate_m_s": float(f["feedrate_m_s"]),
        "predicted_contour_error_um": float(c[i, k]),
        "predicted_tracking_error_um": float(t[i, k]),
        "meets_goal": not binding,
        "binding": binding,
        "rule": rule,
    }
    out["admissible_rule"] = rule_name
    if "gain_margin_db" in chart:
        out["siso_gain_margin_db"] = _finite(chart["gain_margin_db"][i, k])
        out["siso_phase_margin_deg"] = _finite(chart["phase_margin_deg"][i, k])
    out["grid_index"] = [i, k]
    return out


def design(
    plant="jee-triaxial",
    *,
    realistic: bool = False,
    feedrates_m_s: Sequence[float] = DEFAULT_FEEDRATES_M_S,
    radius_m: float = 0.05,
    design_feedrate_m_s: float = DESIGN_FEEDRATE_M_S,
    refine: int = 21,
    among: str = "admissible",
    chart: dict | None = None,
    **chart_kw,
):
    """(chart, recommended): :func:`design_chart` (or the given ``chart`` made with the same
    arguments) and :func:`recommend_gains`, the latter refined on a ``refine`` × ``refine``
    grid spanning the neighbouring coarse grid points (the same rule at the design feedrate
    only)."""
    if chart is None:
        chart = design_chart(
            plant, realistic=realistic, feedrates_m_s=feedrates_m_s, radius_m=radius_m, **chart_kw
        )
    rec = recommend_gains(chart, design_feedrate_m_s, among=among)
    if refine and refine > 1:
        i, k = rec["grid_index"]
        kv, cv = chart["kp_values"], chart["cp_values"]
        sub = dict(chart_kw)
        sub.pop("kp_values", None)
        sub.pop("cp_values", None)
        fine = design_chart(
            plant,
            realistic=realistic,
            feedrates_m_s=[rec["design_feedrate_m_s"]],
            radius_m=radius_m,
            kp_values=np.linspace(kv[max(i - 1, 0)], kv[min(i + 1, kv.size - 1)], refine),
            cp_values=np.linspace(cv[max(k - 1, 0)], cv[min(k + 1, cv.size - 1)], refine),
            **sub,
        )
        coarse = rec
        rec = recommend_gains(fine, design_feedrate_m_s, among=among)
        rec["coarse_grid_choice"] = {"K_P": coarse["K_P"], "C_P": coarse["C_P"]}
        rec["grid_step"] = {
            "K_P": float(fine["kp_values"][1] - fine["kp_values"][0]),
            "C_P": float(fine["cp_values"][1] - fine["cp_values"][0]),
        }
    rec.pop("grid_index", None)
    return chart, rec


def _finite(x):
    x = float(x)
    return x if math.isfinite(x) else None


def _round(x, digits: int = 4):
    """A float to ``digits`` significant digits (None when not finite): keeps the JSON small."""
    x = _finite(x)
    return x if x is None or x == 0 else float(f"{x:.{digits}g}")


def chart_to_json(chart: dict) -> dict:
    """:func:`design_chart`'s dict with arrays as lists (floats to 4 significant digits,
    NaN → None)."""

    def conv(x):
        if isinstance(x, dict):
            return {k: conv(v) for k, v in x.items()}
        if isinstance(x, (list, tuple)):
            return [conv(v) for v in x]
        if isinstance(x, np.ndarray):
            if x.dtype == bool:
                return x.tolist()
            return [conv(v) for v in x.tolist()] if x.ndim else _round(x)
        if isinstance(x, (float, np.floating)):
            return _round(x)
        if isinstance(x, (np.integer, np.bool_)):
            return x.item()
        return x

    return conv(chart)


# --------------------------------------------------------------------------- report

M_RANGE_NOTE = (
    "ε = (I − t tᵀ) E: for matched axes and a frozen path point eq. (15) factors into "
    "Ω1 (tangent, M = 0) × Ω2(M = 1)^(n−1) (the normal directions), so M ∈ {0, 1}; Jee's M "
    "(eq. 13, trace A1x + B1y of the rank-one plane maps of eqs. 2–7) is the non-zero "
    "eigenvalue, exactly 1 for this projection. Mismatched axes: the matched analysis per "
    "axis, intersected (the paper's common range)."
)


def loop_margins_of(K_P: float, C_P: float, plant="jee-triaxial") -> dict:
    """``agents.margins.loop_margins`` of ``jee-ccc`` with these gains on ``plant``'s realistic
    model (±20 % masses, every path direction): the summary {stable, min_gain_margin_db,
    min_phase_margin_deg, meets_requirement}."""
    from agents.margins import loop_margins  # agents builds on contour_env, not the reverse
    from agents.registry import make_controller

    r = loop_margins(make_controller("jee-ccc", K_P=K_P, C_P=C_P), plant)
    gm, pm = r["min_gain_margin_db"], r["min_phase_margin_deg"]
    return {
        "stable": bool(r["stable"]),
        "min_gain_margin_db": gm,
        "min_phase_margin_deg": pm,
        "meets_requirement": bool(
            r["stable"]
            and gm is not None
            and pm is not None
            and gm >= MIN_GAIN_MARGIN_DB
            and pm >= MIN_PHASE_MARGIN_DEG
        ),
    }


def cross_coupling_report(
    plant="jee-triaxial",
    *,
    realistic: bool = False,
    kp: float | None = None,
    cp: float | None = None,
    feedrates_m_s: Sequence[float] = DEFAULT_FEEDRATES_M_S,
    radius_m: float = 0.05,
    plane="xy",
    design_feedrate_m_s: float = DESIGN_FEEDRATE_M_S,
    **plant_kw,
) -> dict:
    """The cross-coupling part of Jee's analysis for ``plant``, on the paper's ideal model and
    on the realistic one (one-period computation delay), JSON-ready. ``plant`` is a name or a
    mapping (``plant_kw`` go to :class:`~contour_env.plants.Plant`); a Plant instance is used
    as it is for both models.

    Keys: ``m_range`` ({values, note}); ``cross_coupling_region`` {ideal, realistic} → {fig4a
    (C_P, C_I; C_D = 0), fig4b (C_P, C_D; C_I = 0)} at K_P = ``kp`` or the model's recommended
    K_P (:func:`cross_coupling_region`); ``design_chart`` {ideal, realistic}
    (:func:`design_chart`, JSON form); ``recommended_gains`` {ideal, ideal_paper_rule,
    realistic} (:func:`design`; ``ideal_paper_rule`` picks among every Jury-stable point, the
    paper's own design range, the others among the admissible ones);
    ``cross_coupling_steady_state``: predicted (controller law, harmonic balance; paper eq. 21)
    vs simulated contour and tracking error per feedrate on a circle in ``plane`` at
    K_P = ``kp`` / C_P = ``cp`` (default the recommended gains) for the model ``realistic``
    selects, simulated on that plant (ideal or realistic)."""
    F = _check_circle(radius_m, feedrates_m_s)
    # one Plant per model (building one discretises its friction model: not free)
    plants = {
        name: _design_plant(plant, name == "realistic", plant_kw) for name in ("ideal", "realistic")
    }
    kind = plants["ideal"].nominal.input_kind
    if kind != "velocity-command":
        raise ValueError(
            "cross-coupling analysis: Jee's controller (jee-ccc) needs a velocity-command drive "
            f"(jee-triaxial); this plant takes a {kind} command"
        )
    common = {"feedrates_m_s": F, "radius_m": radius_m, "design_feedrate_m_s": design_feedrate_m_s}
    charts, recs, regions = {}, {}, {}
    for name, pl in plants.items():
        rl = name == "realistic"
        chart, rec = design(pl, realistic=rl, **common)
        charts[name], recs[name] = chart, rec
        if not rl:
            _, recs["ideal_paper_rule"] = design(
                pl, realistic=False, among="stable", chart=chart, **common
            )
        models, delay = design_models(pl)
        k = float(kp) if kp is not None else rec["K_P"]
        regions[name] = {
            "kp": k,
            "delay": delay,
            "fig4a": cross_coupling_region(models, k, second="ci", delay=delay),
            "fig4b": cross_coupling_region(models, k, second="cd", delay=delay),
        }
    model = "realistic" if realistic else "ideal"
    K = float(kp) if kp is not None else recs[model]["K_P"]
    C = float(cp) if cp is not None else recs[model]["C_P"]
    CI, CD = CI_RATIO * C, CD_RATIO * C
    models, delay = design_models(plants[model])
    true_models = _true_models(plants[model])
    sims = simulate_cc_circle(plants[model], K, C, CI, CD, radius_m, F, plane)
    rows = []
    for f, s in zip(F, sims, strict=True):
        p = steady_state_cc_circle(models, K, C, CI, CD, radius_m, float(f), plane, delay=delay)
        pt = steady_state_cc_circle(
            true_models, K, C, CI, CD, radius_m, float(f), plane, delay=delay
        )
        sc, st = s["contour_error_m"], s["tracking_error_m"]
        rows.append(
            {
                "feedrate_m_s": float(f),
                "feedrate_m_min": float(f) * 60.0,
                "predicted_contour_error_um": p["contour_error_m"] * 1e6,
                "predicted_tracking_error_um": p["tracking_error_m"] * 1e6,
                "predicted_true_linear_contour_error_um": pt["contour_error_m"] * 1e6,
                "predicted_true_linear_tracking_error_um": pt["tracking_error_m"] * 1e6,
                "eq21_contour_error_um": p["eq21_contour_error_m"] * 1e6,
                "eq21_tracking_error_um": p["eq21_tracking_error_m"] * 1e6,
                "simulated_contour_error_um": None if sc is None else sc * 1e6,
                "simulated_tracking_error_um": None if st is None else st * 1e6,
                "contour_ratio": None if not sc else p["contour_error_m"] / sc,
                "tracking_ratio": None if not st else p["tracking_error_m"] / st,
                "eq21_contour_ratio": None if not sc else p["eq21_contour_error_m"] / sc,
                "simulation_diverged": s["diverged"],
            }
        )
    return {
        "m_range": {"values": list(M_VALUES), "note": M_RANGE_NOTE},
        "cross_coupling_region": regions,
        "design_chart": {k: chart_to_json(v) for k, v in charts.items()},
        "recommended_gains": recs,
        "cross_coupling_steady_state": {
            "model": model,
            "K_P": K,
            "C_P": C,
            "C_I": CI,
            "C_D": CD,
            "radius_m": float(radius_m),
            "plane": plane if isinstance(plane, str) else [float(x) for x in plane],
            "rows": rows,
            "notes": (
                "predicted: the controller law ε = Π(k) E (harmonic balance, nominal model"
                + (" with the computation delay" if delay else "")
                + "); predicted_true_linear: the same on the simulated plant's linear part "
                "(its true, mismatched m and b); eq21: the paper's eq. (21) with d from eq. (32), "
                "matched axes, worst axis in the plane; simulated: the law on the "
                + ("realistic plant (mismatch, friction, delay)" if realistic else "ideal plant")
                + ", saturation lifted, max over the last revolution after settling"
            ),
        },
    }


def _fmt_iv(iv) -> str:
    if not iv:
        return "none"
    return ", ".join(
        "(" + ", ".join("…" if x is None else f"{x:.4g}" for x in pair) + ")" for pair in iv
    )


def _top(reg: dict):
    """The largest second-gain value with a stable C_P (None when none)."""
    vals = [s for s, iv in zip(reg["second_values"], reg["cp_intervals"], strict=True) if iv]
    return max(vals, default=None)


def format_cross_coupling_report(rep: dict) -> str:
    """A readable summary of :func:`cross_coupling_report`."""
    lines = ["", "Cross-coupling controller (eqs. 8, 16, 21; ε = (I − t tᵀ) E, M ∈ {0, 1})"]
    for name, reg in rep["cross_coupling_region"].items():
        a, b = reg["fig4a"], reg["fig4b"]
        ci_max = _top(a)
        cd_max = _top(b)
        lines.append(
            f"  {name:9s} K_P = {reg['kp']:.4g}: stable C_P (C_I = C_D = 0) "
            f"{_fmt_iv(a['cp_intervals'][0])}; C_I ≤ {ci_max:.4g} (C_D = 0, Fig. 4a); "
            f"C_D ≤ {cd_max:.4g} (C_I = 0, Fig. 4b)"
            if ci_max is not None and cd_max is not None
            else f"  {name:9s} K_P = {reg['kp']:.4g}: no stable cross-coupling gains"
        )
    lines.append(
        "  design chart (C_I = 2.62 C_P, C_D = 0.02 C_P; predicted worst of the xy, yz, zx "
        "circles), grid points meeting 25 µm / 250 µm:"
    )
    for name, ch in rep["design_chart"].items():
        cells = ", ".join(
            f"{f['feedrate_m_s'] * 60:.3g} m/min: {int(np.sum(np.asarray(f['meets'])))}"
            for f in ch["feedrates"]
        )
        lines.append(f"    {name:9s} {cells}")
    lines.append(
        "  recommended gains (design feedrate "
        f"{next(iter(rep['recommended_gains'].values()))['design_feedrate_m_s'] * 60:.3g} m/min):"
    )
    for name, r in rep["recommended_gains"].items():
        s = (
            f"    {name:16s} K_P = {r['K_P']:.4g}, C_P = {r['C_P']:.4g} (C_I = {r['C_I']:.4g}, "
            f"C_D = {r['C_D']:.4g}): predicted contour {r['predicted_contour_error_um']:.1f} µm, "
            f"tracking {r['predicted_tracking_error_um']:.0f} µm, "
            + ("meets the goal" if r["meets_goal"] else f"misses: {', '.join(r['binding'])}")
        )
        if r.get("siso_gain_margin_db") is not None:
            s += f"; GM {r['siso_gain_margin_db']:.2f} dB, PM {r['siso_phase_margin_deg']:.1f}°"
        lm = r.get("loop_margins")
        if lm:
            s += (
                f"; loop_margins: stable {lm['stable']}, GM {lm['min_gain_margin_db']:.2f} dB, "
                f"PM {lm['min_phase_margin_deg']:.1f}°"
                if lm["min_gain_margin_db"] is not None and lm["min_phase_margin_deg"] is not None
                else f"; loop_margins: stable {lm['stable']}"
            )
        lines.append(s)
    ss = rep["cross_coupling_steady_state"]
    lines += [
        f"  steady state with cross-coupling, {ss['model']} model, K_P = {ss['K_P']:.4g}, "
        f"C_P = {ss['C_P']:.4g}, R = {ss['radius_m'] * 1e3:g} mm, plane {ss['plane']}:",
        f"  {'F (m/min)':>10s} {'contour law':>12s} {'eq. 21':>9s} {'sim':>9s} {'ratio':>7s} "
        f"{'tracking law':>13s} {'sim':>9s} {'ratio':>7s}   (µm)",
    ]
    v = format_cell  # n/a where the simulation gives no figure
    for r in ss["rows"]:
        lines.append(
            f"  {r['feedrate_m_min']:10.4g} {r['predicted_contour_error_um']:12.3f} "
            f"{r['eq21_contour_error_um']:9.3f} {v(r['simulated_contour_error_um'], 9, 3)} "
            f"{v(r['contour_ratio'], 7, 4)} {r['predicted_tracking_error_um']:13.2f} "
            f"{v(r['simulated_tracking_error_um'], 9, 2)} {v(r['tracking_ratio'], 7, 4)}"
        )
    return "\n".join(lines)


# --------------------------------------------------------------------------- plot

_MODEL_COLOURS = {"ideal": "tab:blue", "realistic": "tab:orange"}
_FEED_COLOURS = ("tab:green", "tab:blue", "tab:purple", "tab:brown", "tab:olive")


def _fill_region(ax, reg: dict, colour: str, label: str) -> None:
    """Shade a :func:`cross_coupling_region` from its C_P intervals (x = C_P, y = the second
    gain); an open edge (None) runs to the grid's end."""
    sv = np.asarray(reg["second_values"], dtype=float)
    cpv = reg["cp_values"]
    pieces = max((len(iv) for iv in reg["cp_intervals"]), default=0)
    for q in range(pieces):
        lo = np.full(sv.size, np.nan)
        hi = np.full(sv.size, np.nan)
        for r, iv in enumerate(reg["cp_intervals"]):
            if len(iv) > q:
                lo[r] = cpv[0] if iv[q][0] is None else iv[q][0]
                hi[r] = cpv[-1] if iv[q][1] is None else iv[q][1]
        ax.fill_betweenx(
            sv, lo, hi, color=colour, alpha=0.35, lw=0, label=label if q == 0 else None
        )
        ax.plot(lo, sv, color=colour, lw=1.2)
        ax.plot(hi, sv, color=colour, lw=1.2)


def plot_design(rep: dict, out) -> None:
    """Jee's Figs. 4a, 4b and 5 from :func:`cross_coupling_report`'s dict (JSON form too), as one
    PNG written atomically: stable (C_P, C_I) and (C_P, C_D) regions of both models, and the
    design charts (x = C_P, y = K_P, so the paper's "lower right, near point C" is the lower
    right) with the regions meeting 25 µm / 250 µm per feedrate, the stability and admissible
    boundaries, iso-lines of the predicted contour error at the design feedrate and the
    recommended gains."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from contour_env.io import atomic_save_figure

    fig, axes = plt.subplots(2, 2, figsize=(13, 11.5))
    for ax, key, gain in ((axes[0, 0], "fig4a", "C_I"), (axes[0, 1], "fig4b", "C_D")):
        _plot_stable_regions(ax, rep["cross_coupling_region"], key, gain)
    for ax, name in ((axes[1, 0], "ideal"), (axes[1, 1], "realistic")):
        _plot_design_chart(ax, rep, name)
    fig.suptitle(
        "Jee & Lee 2007 cross-coupling design: stability regions (Fig. 4) and design chart (Fig. 5)"
    )
    fig.tight_layout()
    atomic_save_figure(fig, out, dpi=110)
    plt.close(fig)


_GAIN_UNITS = {"C_I": "1/s", "C_D": "s"}


def _plot_stable_regions(ax, regions: dict, key: str, gain: str) -> None:
    """Fig. 4a (``key`` "fig4a", ``gain`` "C_I") or 4b ("fig4b", "C_D"): the stable (C_P, gain)
    region of each model."""
    for name, reg in regions.items():
        _fill_region(ax, reg[key], _MODEL_COLOURS[name], f"{name} model, K_P = {reg['kp']:.3g}")
    fixed = next(iter(next(iter(regions.values()))[key]["fixed_gain"].items()))
    ax.axvline(0.0, color="0.5", lw=0.6)
    ax.set_xlabel("C_P (dimensionless, as K_P)")
    ax.set_ylabel(f"{gain} ({_GAIN_UNITS[gain]})")
    ax.set_title(
        f"Fig. {'4a' if key == 'fig4a' else '4b'}: stable (C_P, {gain}) with {fixed[0]} = "
        f"{fixed[1]:g}\ncommon to the x, y, z axes, M ∈ {{0, 1}} (Jury on eq. 16)"
    )
    ax.grid(True, alpha=0.3)
    ax.set_ylim(bottom=0.0)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=2, fontsize=9)


def _plot_design_chart(ax, rep: dict, name: str) -> None:
    """Fig. 5 of the ``name`` model ("ideal" or "realistic"): x = C_P, y = K_P."""
    ch = rep["design_chart"][name]
    kp = np.asarray(ch["kp_values"], dtype=float)
    cp = np.asarray(ch["cp_values"], dtype=float)
    rec = rep["recommended_gains"][name]
    handles = _plot_goal_regions(ax, ch, cp, kp)
    handles += _plot_boundaries(ax, ch, cp, kp)
    handles += _plot_contour_isolines(ax, ch, cp, kp, rec["design_feedrate_m_s"])
    handles += _plot_gain_points(ax, rec, rep["recommended_gains"].get(f"{name}_paper_rule"))
    ax.set_xlabel("C_P (dimensionless), with C_I = 2.62 C_P (1/s) and C_D = 0.02 C_P (s)")
    ax.set_ylabel("K_P (dimensionless; K·K_P is the position-loop gain, 1/s)")
    ax.set_title(
        f"Fig. 5, {name} model{' (computation delay)' if ch['delay'] else ''}: "
        f"R = {ch['radius_m'] * 1e3:g} mm, worst of {'/'.join(map(str, ch['planes']))}"
    )
    ax.grid(True, alpha=0.3)
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=2, fontsize=8)


def _plot_goal_regions(ax, ch: dict, cp, kp) -> list:
    """The grid points meeting 25 µm / 250 µm, one colour per feedrate; their legend entries."""
    from matplotlib.patches import Patch

    handles = []
    for q, f in enumerate(ch["feedrates"]):
        meets = np.asarray(f["meets"], dtype=float)
        col = _FEED_COLOURS[q % len(_FEED_COLOURS)]
        if meets.any():
            ax.contourf(cp, kp, meets, levels=[0.5, 1.5], colors=[col], alpha=0.3)
            ax.contour(cp, kp, meets, levels=[0.5], colors=[col], linewidths=1.2)
        handles.append(
            Patch(
                facecolor=col,
                alpha=0.3 if meets.any() else 0.08,
                edgecolor=col,
                label=f"{f['feedrate_m_s'] * 60:.3g} m/min: ε ≤ 25 µm, E ≤ 250 µm"
                + ("" if meets.any() else " (none)"),
            )
        )
    return handles


def _plot_boundaries(ax, ch: dict, cp, kp) -> list:
    """The stability (Jury) and admissible boundaries; their legend entries."""
    from matplotlib.lines import Line2D

    stable = np.asarray(ch["stable"], dtype=float)
    adm = np.asarray(ch["admissible"], dtype=float)
    ax.contour(cp, kp, stable, levels=[0.5], colors="k", linewidths=1.5)
    handles = [Line2D([], [], color="k", lw=1.5, label="stability boundary (Jury)")]
    ax.contour(cp, kp, adm, levels=[0.5], colors="k", linewidths=1.2, linestyles="--")
    handles.append(
        Line2D([], [], color="k", lw=1.2, ls="--", label="admissible: " + _short_rule(ch))
    )
    return handles


def _plot_contour_isolines(ax, ch: dict, cp, kp, fd: float) -> list:
    """Iso-lines of the predicted contour error at the feedrate of the grid nearest ``fd``
    (m/s); their legend entry, if any line is drawn."""
    from matplotlib.lines import Line2D

    fi = int(np.argmin([abs(f["feedrate_m_s"] - fd) for f in ch["feedrates"]]))
    cont = np.array(
        [[np.nan if x is None else x for x in row] for row in ch["feedrates"][fi]["contour_um"]],
        dtype=float,
    )
    levels = [
        lv for lv in (5, 10, 25, 50, 100, 200, 400, 800) if np.nanmin(cont) < lv < np.nanmax(cont)
    ]
    if not levels:
        return []
    cs = ax.contour(cp, kp, cont, levels=levels, colors="0.45", linewidths=0.7, linestyles=":")
    ax.clabel(cs, fontsize=7, fmt="%g µm")
    label = f"predicted ε at {fd * 60:.3g} m/min (µm)"
    return [Line2D([], [], color="0.45", lw=0.7, ls=":", label=label)]


def _plot_gain_points(ax, rec: dict, paper: dict | None) -> list:
    """The paper's rule (``paper``, stability only; absent: not drawn) and the recommended
    gains ``rec`` (point C); their legend entries."""
    from matplotlib.lines import Line2D

    handles = []
    if paper is not None:
        ax.plot(paper["C_P"], paper["K_P"], marker="o", ms=9, mfc="none", mec="red", ls="none")
        label = f"paper's rule, stability only: K_P = {paper['K_P']:.3g}, C_P = {paper['C_P']:.3g}"
        handles.append(
            Line2D([], [], marker="o", ms=8, mfc="none", mec="red", ls="none", label=label)
        )
    ax.plot(rec["C_P"], rec["K_P"], marker="*", ms=15, color="red", mec="k", ls="none")
    ax.annotate(
        "C",
        (rec["C_P"], rec["K_P"]),
        xytext=(6, 6),
        textcoords="offset points",
        fontsize=11,
        fontweight="bold",
        color="red",
    )
    label = f"recommended: K_P = {rec['K_P']:.3g}, C_P = {rec['C_P']:.3g}"
    handles.append(Line2D([], [], marker="*", ms=12, color="red", mec="k", ls="none", label=label))
    return handles


def _short_rule(ch: dict) -> str:
    return "GM ≥ 6 dB, PM ≥ 30°" if "gain_margin_db" in ch else "stable with all gains ×2"


def run_cross_coupling(
    plant="jee-triaxial",
    *,
    realistic: bool = False,
    cp: float | None = None,
    plot=None,
    verify_margins: bool = False,
    **report_kw,
) -> tuple[dict, str]:
    """What ``contour-env stability --cross-coupling`` adds: (report, text). The report is
    :func:`cross_coupling_report` (``report_kw``: kp, feedrates_m_s, radius_m, plane);
    ``verify_margins`` adds ``agents.margins.loop_margins`` of the realistic recommended gains
    (``recommended_gains.realistic.loop_margins``); ``plot`` writes :func:`plot_design` there."""
    rep = cross_coupling_report(plant, realistic=realistic, cp=cp, **report_kw)
    if verify_margins:
        r = rep["recommended_gains"]["realistic"]
        r["loop_margins"] = loop_margins_of(r["K_P"], r["C_P"], plant)
    text = format_cross_coupling_report(rep)
    if plot:
        plot_design(rep, plot)
        text += f"\nwrote {plot}"
    return rep, text
