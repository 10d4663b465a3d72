"""Gain and phase margins of every loop a controller closes on the realistic plant.

Model (:mod:`contour_env.analysis.linear_plant`): each axis's linear dynamics (mass, viscous
friction, current-loop lag, two-mass mode with ``structural_mode``) sampled with a zero-order
hold, the one-period computation delay, and the controller's linear feedback law
(:meth:`agents.base.Controller.loop_gains`: backward-difference velocity from the encoder,
integrators as implemented). The loop transfer seen at the plant input is G(z) = K(z) P(z).

Loops (loop-at-a-time, the other loops closed, python-control for the algebra):

- ``axis x``, ``axis y`` (, ``axis z``): broken at one axis's command;
- ``tangential``, ``normal`` (, ``binormal``): broken at the command along one direction of
  the path frame F = [t n b] (G rotated to Fᵀ G F), which is where cross-coupling acts.

A controller that couples the axes depends on the path direction, so every loop is evaluated
for a set of path directions (2 axes: 0°, 15°, …, 90°; 3 axes: the axes, the face and space
diagonals), and for the true plant's masses scaled to the corners of ±``mass_variation``
(every combination of per-axis factors 1 ± v, and 1). Each loop reports its worst gain margin
and worst phase margin over those conditions, with the condition where it occurs.

Margins come from python-control's ``stability_margins`` on the frequency response over a
dense grid up to the Nyquist frequency (an integrator's response at ω = 0 is not evaluable).
The gain margin is the factor by which the loop gain can rise before instability (a loop whose
gain can also fall to instability reports that as ``gain_reduction_margin_db``); the crossover
is the gain crossover where the phase margin is measured, the phase crossover the frequency a
loop at its gain margin oscillates at.
"""

from __future__ import annotations

import itertools
import math
import warnings

import control
import numpy as np

# the project's requirement for every default gain set (issue "baselines"), on the realistic
# plant over the ±20 % mass corners: defined once, beside the Jee design chart that draws it
from contour_env.analysis.jee_design import MIN_GAIN_MARGIN_DB, MIN_PHASE_MARGIN_DEG
from contour_env.analysis.linear_plant import controller_system, discrete_plant
from contour_env.plants import FIVE_AXIS_PLANT_ALIASES, Plant
from contour_env.plants.catalog import PLANTS

from .registry import make_controller

#: With the two-mass mode (``structural_mode=True``): stable over the same corners with a
#: small but real margin, so an episode is bounded with no limit cycle.
MIN_GAIN_MARGIN_DB_STRUCTURAL = 2.0
MIN_PHASE_MARGIN_DEG_STRUCTURAL = 10.0


def requirement(structural_mode: bool) -> tuple[float, float]:
    """(min gain margin dB, min phase margin °) the project requires of a default gain set."""
    if structural_mode:
        return MIN_GAIN_MARGIN_DB_STRUCTURAL, MIN_PHASE_MARGIN_DEG_STRUCTURAL
    return MIN_GAIN_MARGIN_DB, MIN_PHASE_MARGIN_DEG


def meets_requirement(rep: dict) -> bool:
    """Whether a :func:`loop_margins` report meets :func:`requirement`."""
    gm_min, pm_min = requirement(rep["structural_mode"])
    gm, pm = rep["min_gain_margin_db"], rep["min_phase_margin_deg"]
    return bool(
        rep["stable"]
        and (gm is None or gm >= gm_min)  # None with stable: no phase crossover at all
        and (pm is None or pm >= pm_min)
    )


DEFAULT_MASS_VARIATION = 0.2
_GRID_POINTS = 400
_TASK_NAMES = ("tangential", "normal", "binormal")


def path_directions(n_axes: int) -> list[tuple[str, np.ndarray]]:
    """(label, frame) pairs: the path frames (columns t, n (, b)) the loops are checked on."""
    out = []
    if n_axes == 2:
        for deg in range(0, 91, 15):
            a = math.radians(deg)
            t = np.array([math.cos(a), math.sin(a)])
            out.append((f"{deg}°", np.column_stack([t, [-t[1], t[0]]])))
        return out
    tangents = [
        (1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0), (1, 0, 1), (0, 1, 1), (1, 1, 1),
    ]  # fmt: skip
    for t in tangents:
        t = np.asarray(t, dtype=np.float64)
        t /= np.linalg.norm(t)
        helper = np.eye(3)[int(np.argmin(np.abs(t)))]
        n = helper - (helper @ t) * t
        n /= np.linalg.norm(n)
        label = "t=(" + ",".join(f"{c:.2f}" for c in t) + ")"
        out.append((label, np.column_stack([t, n, np.cross(t, n)])))
    return out


def mass_corners(n_axes: int, variation: float) -> list[tuple[float, ...]]:
    """Per-axis mass factors: 1 on every axis, then every combination of 1 ± variation."""
    corners = [tuple([1.0] * n_axes)]
    if variation > 0:
        corners += list(itertools.product((1 - variation, 1 + variation), repeat=n_axes))
    return corners


def _frequency_response(G: control.StateSpace, omega: np.ndarray) -> np.ndarray:
    """G(e^{jωT}) for every ω, shape (n_ω, outputs, inputs)."""
    z = np.exp(1j * omega * G.dt)
    n = G.A.shape[0]
    if n == 0:
        return np.broadcast_to(G.D, (omega.size, *G.D.shape)).astype(complex)
    M = z[:, None, None] * np.eye(n) - G.A
    X = np.linalg.solve(M, np.broadcast_to(G.B, (omega.size, *G.B.shape)))
    return G.C @ X + G.D


def _loop_at_a_time(Gw: np.ndarray, Q: np.ndarray, channel: int) -> np.ndarray:
    """L_j(ω) = G̃_jj − G̃_jo (I + G̃_oo)⁻¹ G̃_oj with G̃ = Qᵀ G Q: channel j of the loop seen
    through the orthonormal directions Q, open, with the other channels closed."""
    Gq = Q.T @ Gw @ Q
    o = [i for i in range(Gq.shape[1]) if i != channel]
    j = channel
    if not o:
        return Gq[:, j, j]
    Goo = Gq[:, o][:, :, o]
    rhs = Gq[:, o, j][:, :, None]
    corr = Gq[:, j, o][:, None, :] @ np.linalg.solve(np.eye(len(o)) + Goo, rhs)
    return Gq[:, j, j] - corr[:, 0, 0]


def _closed_loop_stable(G: control.StateSpace) -> bool:
    cl = control.feedback(G, np.eye(G.ninputs), sign=-1)
    poles = np.linalg.eigvals(cl.A) if cl.A.size else np.array([])
    return bool(np.all(np.abs(poles) < 1.0 - 1e-9))


def _screen(L: np.ndarray) -> dict:
    """Grid estimate of a loop response's margins: the upper gain margin (dB) and the phase
    margin (°) with the grid index of the crossing each is read at, and the gain-reduction
    margin (dB) of a conditionally stable loop. Used to find the conditions and crossings
    that decide the reported figures, which :func:`siso_margins` then computes."""
    mag = np.abs(L)
    out = {"gm": math.inf, "i_gm": None, "pm": math.inf, "i_pm": None, "red": None}
    cross = np.nonzero(np.diff(np.sign(mag - 1.0)))[0]
    if cross.size:
        ph = np.abs((np.degrees(np.angle(L[cross])) + 360.0) % 360.0 - 180.0)
        out.update(pm=float(ph.min()), i_pm=int(cross[np.argmin(ph)]))
    neg = np.nonzero((np.diff(np.sign(L.imag)) != 0) & (L.real[:-1] < 0))[0]
    if neg.size:
        g = 1.0 / mag[neg]
        up, down = g > 1.0, g < 1.0
        if up.any():
            out.update(gm=float(20 * np.log10(g[up].min())), i_gm=int(neg[up][np.argmin(g[up])]))
        if down.any():
            out["red"] = float(20 * np.log10(g[down].max()))
    return out


def siso_margins(mag: np.ndarray, phase_deg: np.ndarray, omega: np.ndarray) -> dict:
    """Gain/phase margins of a SISO loop from its frequency response (python-control's
    ``stability_margins`` on the data)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        gm, pm, _, wpc, wgc, _ = control.stability_margins((mag, phase_deg, omega), returnall=True)
    gm, pm, wpc, wgc = (np.atleast_1d(np.asarray(a, dtype=float)) for a in (gm, pm, wpc, wgc))
    up = [(g, w) for g, w in zip(gm, wpc, strict=True) if np.isfinite(g) and g > 1.0]
    down = [(g, w) for g, w in zip(gm, wpc, strict=True) if np.isfinite(g) and 0 < g < 1.0]
    out = {"gain_margin_db": math.inf, "phase_crossover_hz": None, "gain_reduction_margin_db": None}
    if up:
        g, w = min(up)
        out.update(gain_margin_db=20 * math.log10(g), phase_crossover_hz=w / (2 * math.pi))
    if down:
        g, _ = max(down)
        out["gain_reduction_margin_db"] = 20 * math.log10(g)
    # the angular distance of each gain crossover from −1 (a crossover near the positive real
    # axis, which python-control reports as ±180°, is far from instability either way)
    finite_pm = [(abs(p), w) for p, w in zip(pm, wgc, strict=True) if np.isfinite(p)]
    if finite_pm:
        p, w = min(finite_pm)
        out.update(phase_margin_deg=float(p), crossover_hz=w / (2 * math.pi))
    else:
        out.update(phase_margin_deg=math.inf, crossover_hz=None)
    return out


def _omega_grid(T: float, points: int) -> np.ndarray:
    return np.logspace(-1.0, math.log10(math.pi / T * (1 - 1e-4)), points)


_WINDOW = 12  # grid points each side of a screened crossing refined by python-control


def _library_margins(L: np.ndarray, omega: np.ndarray, index: int | None = None) -> dict:
    """python-control's margins of ``L`` over the grid, or over a window of it around the
    screened crossing ``index`` (the same figure, refined, at a fraction of the cost)."""
    if index is not None:
        sl = slice(max(0, index - _WINDOW), index + _WINDOW + 2)
        m = siso_margins(np.abs(L[sl]), np.degrees(np.unwrap(np.angle(L[sl]))), omega[sl])
        if math.isfinite(m["gain_margin_db"]) or math.isfinite(m["phase_margin_deg"]):
            return m
    return siso_margins(np.abs(L), np.degrees(np.unwrap(np.angle(L))), omega)


def _plant_for(plant, ideal: bool, structural_mode: bool) -> Plant:
    if isinstance(plant, Plant):
        return plant
    if isinstance(plant, str) and plant in FIVE_AXIS_PLANT_ALIASES:
        raise ValueError(
            f"plant: the five-axis plant ({plant!r}) is analysed joint by joint by "
            "agents.five_axis_margins.five_axis_loop_margins (contour-env margins --plant "
            f"five-axis); this function is for the feed-drive plants: {', '.join(PLANTS)}"
        )
    return Plant(plant, ideal=ideal, structural_mode=structural_mode)


def loop_margins(
    controller,
    plant,
    *,
    ideal: bool = False,
    structural_mode: bool = False,
    mass_variation: float = DEFAULT_MASS_VARIATION,
    path_conditions: list[dict] | None = None,
    screen_only: bool = False,
) -> dict:
    """Margins of every loop ``controller`` closes on ``plant`` (see the module docstring).

    Parameters
    ----------
    controller : str or Controller
        A name or variant (``"ccc:wp=3e4"``, see :func:`agents.registry.make_controller`) or a
        controller object (configured here for the plant).
    plant : str, mapping, PlantParams or Plant
        The plant; its realistic true parameters are analysed (``ideal=True``: the textbook
        model), with the two-mass mode when ``structural_mode``. The five-axis plant is
        :func:`agents.five_axis_margins.five_axis_loop_margins`'s (a ValueError here).
    mass_variation : float in [0, 0.9]
        The ±fraction of the mass corners (default 0.2).
    path_conditions : list of dict, optional
        Extra frozen path points ``{"curvature": 1/m, "feedrate_m_s": m/s}`` for controllers
        whose law depends on them (adaptive CCC's coupling); straight lines always.
    screen_only : bool
        Report the margins read off the frequency grid (no refinement by python-control; the
        crossover frequencies are then None) — a fast first pass for gain searches
        (scripts/tune_controllers.py), which confirm their choice with the full computation.

    Returns a JSON-ready dict: ``plant``, ``controller``, ``loops`` (per loop its worst
    ``gain_margin_db``, ``phase_margin_deg``, ``crossover_hz``, ``phase_crossover_hz`` and
    where they occur), ``min_gain_margin_db``, ``min_phase_margin_deg``, ``stable`` (every
    closed loop stable over every condition) and ``by_mass`` (per mass corner: stable, and the
    gain and phase margin of its worst loop).
    """
    if not (isinstance(mass_variation, (int, float)) and 0 <= mass_variation <= 0.9):
        raise ValueError(f"mass_variation: a fraction in [0, 0.9], got {mass_variation!r}")
    plant_obj = _plant_for(plant, ideal, structural_mode)
    label = controller if isinstance(controller, str) else getattr(controller, "spec", None)
    ctrl = make_controller(controller) if isinstance(controller, str) else controller
    label = label or ctrl.name
    ctrl.configure_for(plant_obj)
    params = plant_obj.params
    n = params.n_axes
    conditions = [{"curvature": 0.0, "feedrate_m_s": 0.0}] + list(path_conditions or [])
    omega = _omega_grid(params.servo_period_s, _GRID_POINTS)
    # screen every (mass corner, direction, path condition, loop) on the grid, then refine
    # with python-control the few that decide a reported figure
    corners = mass_corners(n, mass_variation)
    screened, corner_stable = _screen_all(ctrl, params, corners, conditions, omega)
    figures = _Refined(screened, omega, screen_only)
    rows = _worst_per_loop(screened, figures)
    by_mass = _worst_per_corner(screened, corners, corner_stable, figures)
    min_gm = min(r["gain_margin_db"] for r in rows)
    min_pm = min(r["phase_margin_deg"] for r in rows)
    for r in rows:
        r["gain_margin_db"] = _finite(r["gain_margin_db"])
        r["phase_margin_deg"] = _finite(r["phase_margin_deg"])
    return {
        "plant": params.name,
        "controller": label,
        "ideal": bool(ideal),
        "structural_mode": bool(structural_mode),
        "mass_variation": mass_variation,
        "directions": [d for d, _ in path_directions(n)],
        "stable": all(corner_stable),
        "loops": rows,
        "min_gain_margin_db": _finite(min_gm),
        "min_phase_margin_deg": _finite(min_pm),
        "by_mass": by_mass,
    }


def _screen_all(ctrl, params, corners, conditions, omega) -> tuple[list[tuple], list[bool]]:
    """Every (mass corner, path direction, path condition, loop) screened on the grid: the
    entries ``(loop name, corner index, gm, pm, L, where, stable, screen)`` (gm and pm −∞
    for an unstable closed loop), and per corner whether every closed loop is stable."""
    n = params.n_axes
    T = params.servo_period_s
    axes = list(params.axis_names)
    screened = []
    corner_stable = []
    for ci, scale in enumerate(corners):
        P = discrete_plant(params.replace(mass_kg=params.mass_kg * np.asarray(scale)))
        stable_here = True
        for direction, frame in path_directions(n):
            for cond in conditions:
                gains = ctrl.loop_gains(frame, cond["curvature"], 0.0, cond["feedrate_m_s"])
                G = controller_system(*gains, T) * P
                where = {"mass_scale": list(scale), "direction": direction, **cond}
                stable = _closed_loop_stable(G)
                stable_here &= stable
                Gw = _frequency_response(G, omega)
                channels = [(f"axis {a}", np.eye(n), i) for i, a in enumerate(axes)]
                channels += [(_TASK_NAMES[i], frame, i) for i in range(n)]
                for name, Q, j in channels:
                    L = _loop_at_a_time(Gw, Q, j)
                    sc = _screen(L)
                    if not stable:
                        sc.update(gm=-math.inf, pm=-math.inf)
                    screened.append((name, ci, sc["gm"], sc["pm"], L, where, stable, sc))
        corner_stable.append(stable_here)
    return screened, corner_stable


class _Refined:
    """``figures(k, kind)``: the gain ("gm") or phase ("pm") margin of screened entry k,
    refined by python-control (unless ``screen_only``), each computed once."""

    def __init__(self, screened: list[tuple], omega: np.ndarray, screen_only: bool):
        self.screened = screened
        self.omega = omega
        self.screen_only = screen_only
        self.refined: dict[tuple, dict] = {}

    def __call__(self, k: int, kind: str) -> dict:
        if (k, kind) not in self.refined:
            _, _, gm, pm, L, _, stable, sc = self.screened[k]
            m = {"gain_margin_db": gm, "phase_margin_deg": pm, "phase_crossover_hz": None}
            m.update(crossover_hz=None, gain_reduction_margin_db=sc["red"])
            if stable and not self.screen_only and (gm if kind == "gm" else pm) < math.inf:
                lib = _library_margins(L, self.omega, sc["i_gm" if kind == "gm" else "i_pm"])
                keys = (
                    ("gain_margin_db", "phase_crossover_hz")
                    if kind == "gm"
                    else ("phase_margin_deg", "crossover_hz")
                )
                m.update({key: lib[key] for key in keys})
            self.refined[(k, kind)] = m
        return self.refined[(k, kind)]


def _worst_per_loop(screened: list[tuple], figures: _Refined) -> list[dict]:
    """Per loop its worst gain and phase margins over the conditions (report rows)."""
    loops: dict[str, dict] = {}
    names = list(dict.fromkeys(e[0] for e in screened))
    for name in names:
        mine = [k for k, e in enumerate(screened) if e[0] == name]
        for kind, col in (("gm", 2), ("pm", 3)):
            # the two lowest screened conditions (the grid's error could swap close ones)
            for k in sorted(mine, key=lambda k, c=col: screened[k][c])[:2]:
                _keep_worst(loops, name, figures(k, kind), screened[k][5], kind)
    return list(loops.values())


def _worst_per_corner(screened, corners, corner_stable, figures: _Refined) -> list[dict]:
    """Per mass corner: stable, and the gain and phase margin of its worst loop."""
    by_mass = []
    for ci, scale in enumerate(corners):
        mine = [k for k, e in enumerate(screened) if e[1] == ci]
        k_gm = min(mine, key=lambda k: screened[k][2])
        k_pm = min(mine, key=lambda k: screened[k][3])
        by_mass.append(
            {
                "mass_scale": list(scale),
                "stable": corner_stable[ci],
                "min_gain_margin_db": _finite(figures(k_gm, "gm")["gain_margin_db"]),
                "min_phase_margin_deg": _finite(figures(k_pm, "pm")["phase_margin_deg"]),
            }
        )
    return by_mass


def _finite(x):
    """JSON has no infinity: +inf (no phase crossover) → None; −inf (unstable) → None too,
    with ``stable: false`` beside it."""
    return float(x) if math.isfinite(x) else None


def _keep_worst(loops: dict, name: str, m: dict, where: dict, kind: str) -> None:
    row = loops.setdefault(
        name,
        {
            "loop": name,
            "gain_margin_db": math.inf,
            "phase_margin_deg": math.inf,
            "crossover_hz": None,
            "phase_crossover_hz": None,
            "gain_reduction_margin_db": None,
            "gain_margin_at": None,
            "phase_margin_at": None,
        },
    )
    value, freq, at = {
        "gm": ("gain_margin_db", "phase_crossover_hz", "gain_margin_at"),
        "pm": ("phase_margin_deg", "crossover_hz", "phase_margin_at"),
    }[kind]
    if row[at] is None or m[value] < row[value]:
        row.update({value: m[value], freq: m[freq], at: where})
    red = m.get("gain_reduction_margin_db")
    if red is not None and (
        row["gain_reduction_margin_db"] is None or red > row["gain_reduction_margin_db"]
    ):
        row["gain_reduction_margin_db"] = red


def format_margins(rep: dict) -> str:
    """A readable table of :func:`loop_margins`' report, with the verdict against the
    project's requirement (:func:`requirement`)."""

    def f(v, spec, width=8):
        return f"{'—':>{width}s}" if v is None else format(v, f"{width}{spec}")

    head = (
        f"plant {rep['plant']} ({'ideal' if rep['ideal'] else 'realistic'}"
        f"{', structural mode' if rep['structural_mode'] else ''}), controller "
        f"{rep['controller']}: ±{rep['mass_variation'] * 100:.0f} % mass corners × "
        + (
            f"{len(rep['poses'])} poses (joint loops)"
            if "poses" in rep
            else f"{len(rep['directions'])} path directions"
        )
    )
    lines = [
        head,
        f"{'loop':12s}{'GM dB':>8s}{'at Hz':>8s}{'PM °':>8s}{'at Hz':>8s}  worst case "
        + ("(inertia ×, pose)" if "poses" in rep else "(mass ×, path)"),
    ]
    for r in rep["loops"]:
        at = r["phase_margin_at"] or {}
        scale = "/".join(f"{s:g}" for s in at.get("mass_scale", []))
        lines.append(
            f"{r['loop']:12s}{f(r['gain_margin_db'], '.2f')}{f(r['phase_crossover_hz'], '.1f')}"
            f"{f(r['phase_margin_deg'], '.1f')}{f(r['crossover_hz'], '.1f')}  "
            f"{scale}, {at.get('pose', at.get('direction', ''))}"
        )
    gm_min, pm_min = requirement(rep["structural_mode"])
    if not rep["stable"]:
        bad = [b for b in rep["by_mass"] if not b["stable"]]
        scales = "; ".join("/".join(f"{s:g}" for s in b["mass_scale"]) for b in bad)
        verdict = f"UNSTABLE: a closed loop has a pole outside the unit circle (mass × {scales})"
    else:
        verdict = (
            f"min gain margin {f(rep['min_gain_margin_db'], '.2f', 0)} dB, min phase margin "
            f"{f(rep['min_phase_margin_deg'], '.1f', 0)}°: "
            + ("meets" if meets_requirement(rep) else "does NOT meet")
            + f" the requirement ≥ {gm_min:g} dB / ≥ {pm_min:g}°"
            + (" (structural mode)" if rep["structural_mode"] else "")
        )
    lines.append(verdict)
    return "\n".join(lines)
