"""The laws of pd, ccc, adaptive-ccc and jee-ccc written again in NumPy, on whole batches, from
the papers' equations (the controllers' docstrings cite them): an independent reference for
the one compiled definition (:func:`agents.compiled.laws.law`) that the controllers' ``act``
and the fused loops both run. ``patch(controller)`` puts the reference law on the instance (a
law on the instance is never compiled, so the run takes the Python env path with it)."""

from __future__ import annotations

import functools

import numpy as np

from agents.ccc import CORNER_TURN_RAD, contour_error_estimate

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


REFERENCE = {"pd": pd, "ccc": ccc, "adaptive-ccc": adaptive_ccc, "jee-ccc": jee_ccc}


def patch(controller):
    """``controller`` with the NumPy reference of its law on the instance (its class's
    ``COMPILED_LAW``); returns it."""
    law = REFERENCE[type(controller).COMPILED_LAW]
    controller.act = functools.partial(law, controller)
    return controller
