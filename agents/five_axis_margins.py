"""Gain and phase margins of the five-axis joint loops (``contour-env margins --plant
five-axis --controller pid``): the five-axis counterpart of :mod:`agents.margins`, whose
requirement (≥ 6 dB / ≥ 30°), screening and reporting it shares.

Model (:mod:`contour_env.analysis.five_axis_linear`): at each pose the true (realistic) plant
linearised at rest — M(ξ) δξ̈ + B δξ̇ + K_g δξ = τ_a with the current-loop lag, sampled with a
zero-order hold, the one-period computation delay — in series with the controller's joint
law linearised at that pose (:meth:`joint_loop_gains`: through the nominal model,
u = M̂(ξ) (Kp E + Kd ΔE/T + Ki T ΣE) − ∂ĝ/∂ξ E, the backward-difference rate and the
rectangle-rule integral as implemented). Where the true and nominal inertias agree the loop of
joint j is the double integrator times the PID; the mismatch M⁻¹ M̂ (the table 20 % heavier,
then the ±20 % corners) scales and couples the joints.

Loops: ``joint x`` … ``joint C``, each broken at one joint's command with the other four
closed (loop-at-a-time, MIMO: the inertia couplings y–A, x–C, y–C, A–C stay in). Conditions:
every pose of :func:`default_poses` (the A/C travel grid, where M(ξ) varies, and points along
the two named paths) × the inertia corners (per joint 1 ± ``mass_variation``, every
combination, and 1). Each loop reports its worst gain and phase margin with the pose and corner
where it occurs; ``stable`` checks the closed-loop poles of every condition.
"""

from __future__ import annotations

import math

import numpy as np

from contour_env.analysis.five_axis_linear import (
    delay_line,
    discrete_joint_model,
    joint_plant,
)
from contour_env.analysis.linear_plant import controller_system
from contour_env.plants import FIVE_AXIS_PLANT_ALIASES

from .margins import (
    _GRID_POINTS,
    DEFAULT_MASS_VARIATION,
    _closed_loop_stable,
    _finite,
    _frequency_response,
    _omega_grid,
    _Refined,
    _screen,
    _worst_per_corner,
    _worst_per_loop,
    mass_corners,
)
from .registry import make_controller

JOINT_NAMES = ("x", "y", "z", "A", "C")
LOOP_NAMES = tuple(f"joint {j}" for j in JOINT_NAMES)
# the travel grid of the poses: M(ξ) depends on A and C only, C through the table's 5 mm
# eccentricity e₄ alone (M_xC ∝ sin C, M_yC ∝ cos C, M_AC ∝ cos C, M_AA ∋ e₄² sin² C: their
# extremes at C = 0° and 90°, mirrored at 180° and 270°)
GRID_A_DEG = (-120.0, -90.0, -60.0, -30.0, 0.0, 30.0)
GRID_C_DEG = (0.0, 90.0)
# points along each named path (fractions of the motion)
PATH_FRACTIONS = (0.0, 0.25, 0.5, 0.75, 1.0)


def default_poses(geometry=None) -> list[tuple[str, np.ndarray]]:
    """(label, ξ (5,)) pairs: the A × C travel grid (:data:`GRID_A_DEG` × :data:`GRID_C_DEG`,
    linear joints at 0), then :data:`PATH_FRACTIONS` of the motion along five-axis-line and
    five-axis-circle (their joint references)."""
    from contour_env.paths.five_axis import FIVE_AXIS_PATHS, five_axis_path

    poses = []
    for a in GRID_A_DEG:
        for c in GRID_C_DEG:
            q = np.array([0.0, 0.0, 0.0, math.radians(a), math.radians(c)])
            poses.append((f"A={a:g}° C={c:g}°", q))
    for name in FIVE_AXIS_PATHS:
        path = five_axis_path(name, geometry=geometry)
        s = path.reference.arc_length_m
        for f in PATH_FRACTIONS:
            k = int(np.searchsorted(s, f * s[-1]))
            k = min(k, len(s) - 1)
            poses.append((f"{name} s={f:g}", path.reference.joints[k].copy()))
    return poses


def controller_response(A0, A1, A2, T: float, omega: np.ndarray) -> np.ndarray:
    """K(e^{jωT}) (n_ω, 5, 5) of u = A0 E + A1 (E_k − E_{k−1}) / T + A2 T Σ_{j≤k} E_j
    (:func:`contour_env.analysis.linear_plant.controller_system`):
    K(z) = A0 + A1 (1 − z⁻¹) / T + A2 T / (1 − z⁻¹)."""
    zinv = np.exp(-1j * omega * T)[:, None, None]
    A0, A1, A2 = (np.asarray(a, dtype=np.float64)[None] for a in (A0, A1, A2))
    return A0 + A1 * (1 - zinv) / T + A2 * T / (1 - zinv)


def plant_response(P, omega: np.ndarray) -> np.ndarray:
    """P(e^{jωT}) (n_ω, outputs, inputs) of a discrete state-space system through the
    eigenvectors of its A (Σ_n C v_n (z − λ_n)⁻¹ w_nᵀ B: no solve per frequency); the solve
    of :func:`agents.margins._frequency_response` where A is close to defective."""
    lam, V = np.linalg.eig(P.A)
    if np.linalg.cond(V) > 1e8:
        return _frequency_response(P, omega)
    left = P.C @ V
    right = np.linalg.solve(V, P.B)
    z = np.exp(1j * omega * P.dt)
    return np.einsum("in,wn,nj->wij", left, 1.0 / (z[:, None] - lam[None, :]), right) + P.D


def loops_at_a_time(Gw: np.ndarray) -> np.ndarray:
    """L_j(ω) (5, n_ω) of every joint j, its loop open and the others closed: the
    :func:`agents.margins._loop_at_a_time` of each joint at once, by the Schur complement
    [(I + G)⁻¹]_jj = 1 / (1 + G_jj − G_jo (I + G_oo)⁻¹ G_oj) = 1 / (1 + L_j)."""
    n = Gw.shape[-1]
    inv = np.linalg.inv(np.eye(n) + Gw)
    return (1.0 / np.diagonal(inv, axis1=1, axis2=2) - 1.0).T


def five_axis_loop_margins(
    controller,
    plant: str = "five-axis",
    *,
    ideal: bool = False,
    structural_mode: bool = False,
    mass_variation: float = DEFAULT_MASS_VARIATION,
    poses: list[tuple[str, np.ndarray]] | None = None,
    screen_only: bool = False,
) -> dict:
    """Margins of every joint loop ``controller`` closes on the five-axis plant (module
    docstring). ``controller``: a five-axis name or variant (``pid``, ``pid:w=80``, ``pd``:
    the paper's gains, the line's) or a five-axis controller object; ``ismc`` and the
    feed-drive-only names are a ValueError, as is ``structural_mode`` (the five-axis plant
    has no two-mass mode). ``poses``: (label, ξ) pairs (default
    :func:`default_poses`). The report has the keys of :func:`agents.margins.loop_margins`
    (``directions`` empty) plus ``poses`` (labels) and ``machine``; loops ``joint x`` …
    ``joint C``; each worst case's ``…_at`` gives ``mass_scale`` (per joint) and ``pose``."""
    if not (isinstance(mass_variation, (int, float)) and 0 <= mass_variation <= 0.9):
        raise ValueError(f"mass_variation: a fraction in [0, 0.9], got {mass_variation!r}")
    if structural_mode:
        raise ValueError(
            f"structural_mode: the five-axis plant ({plant!r}) has no structural mode option; "
            "the two-mass mode is modelled for the feed-drive plants"
        )
    if plant not in FIVE_AXIS_PLANT_ALIASES:
        raise ValueError(
            f"plant: {plant!r} is not the five-axis plant ({', '.join(FIVE_AXIS_PLANT_ALIASES)})"
        )
    from contour_env.env.five_axis_setup import FiveAxisMachine

    machine = FiveAxisMachine(plant, ideal=ideal)
    label = controller if isinstance(controller, str) else getattr(controller, "spec", None)
    ctrl = (
        make_controller(controller, plant_family="five-axis")
        if isinstance(controller, str)
        else controller
    )
    label = label or ctrl.name
    ctrl.configure_for(machine)
    params = machine.plant.params
    T = params.servo_period_s
    poses = default_poses(machine.geometry) if poses is None else list(poses)
    if not poses:
        raise ValueError("poses: at least one (label, joints) pair")
    omega = _omega_grid(T, _GRID_POINTS)
    corners = mass_corners(5, mass_variation)
    gains = [ctrl.joint_loop_gains(q) for _, q in poses]
    laws = [controller_system(*g, T) for g in gains]
    law_responses = [controller_response(*g, T, omega) for g in gains]
    delay = delay_line(params)
    # the delay's response, z^-1 (or 1): kept out of the state-space solve below
    zinv = np.exp(-1j * omega * T) if params.computation_delay else np.ones_like(omega)
    screened, corner_stable = [], []
    for ci, scale in enumerate(corners):
        stable_here = True
        for (pose, q), K, Kw in zip(poses, laws, law_responses, strict=True):
            P = discrete_joint_model(params, q, scale)
            where = {"mass_scale": list(scale), "pose": pose}
            stable = _closed_loop_stable(K * P * delay)
            stable_here &= stable
            # G(e^{jωT}) = K(e^{jωT}) P(e^{jωT}) z⁻¹, the loop broken at the plant input
            Gw = Kw @ (plant_response(P, omega) * zinv[:, None, None])
            for name, L in zip(LOOP_NAMES, loops_at_a_time(Gw), strict=True):
                sc = _screen(L)
                if not stable:
                    sc.update(gm=-math.inf, pm=-math.inf)
                screened.append((name, ci, sc["gm"], sc["pm"], L, where, stable, sc))
        corner_stable.append(stable_here)
    figures = _Refined(screened, omega, screen_only)
    rows = _worst_per_loop(screened, figures)
    by_mass = _worst_per_corner(screened, corners, corner_stable, figures)
    min_gm = min(r["gain_margin_db"] for r in rows)
    min_pm = min(r["phase_margin_deg"] for r in rows)
    for r in rows:
        r["gain_margin_db"] = _finite(r["gain_margin_db"])
        r["phase_margin_deg"] = _finite(r["phase_margin_deg"])
    return {
        "plant": "five-axis",
        "machine": params.name,
        "controller": label,
        "ideal": bool(ideal),
        "structural_mode": False,
        "mass_variation": mass_variation,
        "directions": [],
        "poses": [p for p, _ in poses],
        "stable": all(corner_stable),
        "loops": rows,
        "min_gain_margin_db": _finite(min_gm),
        "min_phase_margin_deg": _finite(min_pm),
        "by_mass": by_mass,
    }


def closed_loop_poles(controller, q, mass_scale=None, *, ideal: bool = False, gain: float = 1.0):
    """The closed-loop poles (z-plane) of the linearised joint loops at pose q with the
    controller's feedback scaled by ``gain`` (an independent check of a margin: at a gain
    below 10^(GM/20) every pole lies inside the unit circle, above it one leaves)."""
    import control

    from contour_env.env.five_axis_setup import FiveAxisMachine

    machine = FiveAxisMachine("five-axis", ideal=ideal)
    ctrl = (
        make_controller(controller, plant_family="five-axis")
        if isinstance(controller, str)
        else controller
    )
    ctrl.configure_for(machine)
    params = machine.plant.params
    A0, A1, A2 = ctrl.joint_loop_gains(q)
    K = controller_system(gain * A0, gain * A1, gain * A2, params.servo_period_s)
    G = K * joint_plant(params, q, mass_scale)
    cl = control.feedback(G, np.eye(5), sign=-1)
    return np.linalg.eigvals(cl.A)
