"""The laws of pd, ccc, adaptive-ccc, jee-ccc and rfnn / fnn written again in NumPy, on whole
batches, from the papers' equations (the controllers' docstrings cite them): an independent
reference for the one compiled definition (:func:`agents.compiled.laws.law`) that the
controllers' ``act`` and the fused loops both run. ``patch(controller)`` puts the reference law
on the instance (a law on the instance is never compiled, so the run takes the Python env path
with it)."""

from __future__ import annotations

import functools
import math

import numpy as np

from agents.ccc import CORNER_TURN_RAD, contour_error_estimate
from agents.rfnn import EQ23_INSTANT_CAP, THETA_LIMIT

PD_SIGNALS = ("measured_position", "measured_velocity", "reference_position", "reference_velocity")


def pd(c, signals):
    e = signals["reference_position"] - signals["measured_position"]
    de = signals["reference_velocity"] - signals["measured_velocity"]
    return c.P * e + c.D * de


def _corner_hold(c, signals):
    t = signals["frame"][:, :, 0]
    B = t.shape[0]
    prev_t, corner, holding = c._tangent[:B], c._corner[:B], c._holding[:B]
    bisector = c._bisector[:B]
    cos_turn = np.sum(prev_t * t, axis=1)
    jump = c._started[:B] & (cos_turn < np.cos(CORNER_TURN_RAD)) & (cos_turn > -0.9)
    corner[jump] = signals["reference_position"][jump]
    bisector[jump] = (prev_t + t)[jump]
    holding |= jump
    past = np.sum(bisector * (signals["measured_position"] - corner), axis=1) >= 0.0
    holding &= ~past
    prev_t[:] = t
    return holding


def ccc(c, signals):
    u = pd(c, signals)
    eps_n, eps_b = contour_error_estimate(signals)
    T = c.servo_period_s
    B = eps_n.shape[0]
    F = signals["frame"]
    prev, started, J = c._prev[:B], c._started[:B], c._integral[:B]
    hold = _corner_hold(c, signals)
    if hold.any():
        J[hold] = 0.0
        eps_n = np.where(hold, 0.0, eps_n)
        eps_b = None if eps_b is None else np.where(hold, 0.0, eps_b)
    directions = [(F[:, :, 1], eps_n, 0)]
    if eps_b is not None:
        directions.append((F[:, :, 2], eps_b, 1))
    comps = [np.sum(J * d, axis=1) + eps * T for d, eps, _ in directions]
    limit = float(np.min(c.force_limit / c.mass)) / max(c.W_i, 1e-300)
    comps = [np.clip(x, -limit, limit) for x in comps]
    J[:] = 0.0
    for (d, eps, slot), integ in zip(directions, comps, strict=True):
        de = np.where(started, (eps - prev[:, slot]) / T, 0.0)
        k = c.W_p * eps + c.W_i * integ + c.W_d * de
        u = u - c.mass * k[:, None] * d
        prev[:, slot] = eps
        J += integ[:, None] * d
    started[:] = True
    return u


def jee_ccc(c, signals):
    E = signals["reference_position"] - signals["measured_position"]
    t = signals["frame"][:, :, 0]
    eps = E - np.sum(t * E, axis=1, keepdims=True) * t
    B = E.shape[0]
    T = c.servo_period_s
    c._sum[:B] += eps * T
    started = c._started[:B, None]
    d_eps = np.where(started, (eps - c._prev[:B]) / T, 0.0)
    c._prev[:B] = eps
    c._started[:B] = True
    return c.K_P * E + c.C_P * eps + c.C_I * c._sum[:B] + c.C_D * d_eps


def adaptive_ccc(c, signals):
    n = c.n_axes
    E = signals["reference_position"] - signals["measured_position"]
    ref_vel = signals["reference_velocity"]
    if c.velocity_match:
        ref_vel = ref_vel - 0.5 * c.servo_period_s * signals["reference_acceleration"]
    Ed = ref_vel - signals["measured_velocity"]
    v = signals["feedrate"]
    C, FRFt = c._coupling_matrix(signals["frame"], signals["curvature"], signals["torsion"], v)
    B = E.shape[0]
    Fr = Ed + c.alpha * E + v[:, None] * np.einsum("bij,bj->bi", FRFt, E)
    th = c.theta_hat[:B].reshape(B, c.n_columns, n)
    acc, vel = signals["reference_acceleration"], signals["reference_velocity"]
    phi = np.stack([acc, vel] + ([np.sign(vel)] if c.friction else []), axis=1)
    feedforward = np.einsum("bja,bja->ba", phi, th)
    u = c.k * (Ed + c.alpha * E) + np.einsum("bij,bj->bi", C, E) + E + feedforward
    if np.any(c.Gamma):
        step = c.servo_period_s * Fr
        if c.normalize:
            ms = np.asarray(c.mean_squares)[None, :, None]
            psi2 = np.sum(phi**2 / ms, axis=1)
            step = step / np.maximum(1.0, psi2 / c.n_columns)
        th += c.Gamma.reshape(c.n_columns, n) * phi * step[:, None, :]
        np.maximum(th, 0.0, out=th)
    return u


def _seq_sum(terms):
    """Σ over the last axis, left to right from j = 0 (the compiled law's order)."""
    total = terms[..., 0]
    for j in range(1, terms.shape[-1]):
        total = total + terms[..., j]
    return total


def rfnn(c, signals):
    """Chen & Lee 2020 eqs. 5–7 and 14–19 with the options of issue 38 (the per-sample eq. 23
    cap, the spread bound), from the network's pieces of :class:`agents.rfnn.RFNNController`
    (``network``, ``theta_gradient``, ``network_inputs``); sums left to right."""
    u = pd(c, signals)
    B = u.shape[0]
    e, _ = c.task_errors(signals)
    x = c.network_inputs(signals)
    w, theta, memory = c.w[:B], c.theta[:B], c.memory[:B]
    y, psi, O2, d = c.network(x, memory, theta, w)
    if c.online_update:
        # eq. 23 at this sample, per direction: lr_w ‖∂y/∂w‖² + lr_theta ‖∂y/∂θ‖² / w_max²
        value = c.lr_w * _seq_sum(psi * psi)
        if c.recurrent and c.k_theta > 0.0:
            g = c.theta_gradient(psi, w, y, d, memory)
            step = (c.k_theta * e)[..., None, None] * g
            gg = np.swapaxes(g * g, -1, -2)  # rule by rule: (rule j, input 0), (j, input 1)
            v_theta = c.lr_theta / (c.w_max * c.w_max) * _seq_sum(gg.reshape(*gg.shape[:-2], -1))
            if c.eq23_instant:
                over = value + v_theta > EQ23_INSTANT_CAP
                if np.any(over):  # scale this sample's θ step down to the cap
                    room = np.maximum(EQ23_INSTANT_CAP - value, 0.0)
                    scale = np.where(over, room / np.where(over, v_theta, 1.0), 1.0)
                    step = step * scale[..., None, None]
                    v_theta = v_theta * scale
            theta[:] = np.clip(theta - step, -THETA_LIMIT, THETA_LIMIT)
            value = value + v_theta
        peak = float(np.max(value))
        if not peak <= c.eq23_peak:  # also the first sample (NaN)
            c.eq23_peak = peak
        w_new = w - (c.k_w * e)[..., None] * psi
        if c.spread_max_N < math.inf:
            # every weight within ±Δw_max/2 of the output at these inputs with the new weights
            half = 0.5 * c.spread_max_N
            y_new = _seq_sum(w_new * psi)[..., None]
            w_new = np.clip(w_new, y_new - half, y_new + half)
        w[:] = np.clip(w_new, -c.w_max, c.w_max)
    if c.recurrent:
        memory[:] = O2
    # the task-frame force y on the axes: F y
    F = signals["frame"]
    corr = F[:, :, 0] * y[:, 0:1]
    for p in range(1, c.n_axes):
        corr = corr + F[:, :, p] * y[:, p : p + 1]
    return u + corr


REFERENCE = {
    "pd": pd,
    "ccc": ccc,
    "adaptive-ccc": adaptive_ccc,
    "jee-ccc": jee_ccc,
    "rfnn": rfnn,
}


def patch(controller):
    """``controller`` with the NumPy reference of its law on the instance (its class's
    ``COMPILED_LAW``); returns it."""
    law = REFERENCE[type(controller).COMPILED_LAW]
    controller.act = functools.partial(law, controller)
    return controller
