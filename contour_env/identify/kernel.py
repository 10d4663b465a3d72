"""The identification's window simulation loop, compiled: every servo period of a window batch
through the package's plant step (:func:`contour_env.plants.kernel.plant_step_batch`), the
periodic forces against the drive formed per period (disturbance in time, precomputed; ripple
in position, from the state), positions and velocities recorded. One call replaces a Python
loop of one plant-step call per period (issue 51: the fits spent most of their time in it)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..plants.kernel import plant_step_batch


@njit(cache=True)
def simulate_steps(
    z, stuck, pending, U, T, n_sub, mat_T, mat_h, cont, nl, pidx, applied, dist, ripple, xs, vs
):
    """Advance the batch ``z`` (B, 2, 3) over the H periods of ``U`` (H, B, 2), in place;
    ``dist`` (H, B, 2): the disturbance force per period (N; shape (0, 0, 0): none);
    ``ripple`` (B, 3): r_s, r_c (N) and k (rad/m) per env (shape (0, 3): none). The extra force
    on each mass is −(disturbance + r_s sin k x̄ + r_c cos k x̄), x̄ the position at the period's
    middle by the start velocity. Writes xs, vs (H, B, 2): position (m) and velocity (m/s) at
    the end of each period."""
    H = U.shape[0]
    B = z.shape[0]
    w_extra = np.zeros((B, 2))
    has_dist = dist.shape[0] > 0
    has_ripple = ripple.shape[0] > 0
    for j in range(H):
        if has_dist or has_ripple:
            for b in range(B):
                for a in range(2):
                    w = 0.0
                    if has_dist:
                        w = -dist[j, b, a]
                    if has_ripple:
                        ang = ripple[b, 2] * (z[b, a, 0] + 0.5 * T * z[b, a, 1])
                        w = w - (ripple[b, 0] * math.sin(ang) + ripple[b, 1] * math.cos(ang))
                    w_extra[b, a] = w
        plant_step_batch(
            z,
            stuck,
            pending,
            U[j],
            0.0,
            T,
            n_sub,
            False,
            mat_T,
            mat_h,
            cont,
            nl,
            pidx,
            applied,
            w_extra,
        )
        for b in range(B):
            for a in range(2):
                xs[j, b, a] = z[b, a, 0]
                vs[j, b, a] = z[b, a, 1]


@njit(cache=True)
def start_velocity_response(phi, gx, gv):
    """The linear part's response to a unit start velocity: e(j+1) = φ e(j) from e(0) = (0, 1,
    0), per parameter set s of ``phi`` (S, 3, 3); writes its position gx[s, j] (m per m/s) and
    velocity gv[s, j] after j + 1 periods, for the H columns of gx, gv (S, H)."""
    S, H = gx.shape
    for s in range(S):
        e0, e1, e2 = 0.0, 1.0, 0.0
        for j in range(H):
            n0 = phi[s, 0, 0] * e0 + phi[s, 0, 1] * e1 + phi[s, 0, 2] * e2
            n1 = phi[s, 1, 0] * e0 + phi[s, 1, 1] * e1 + phi[s, 1, 2] * e2
            n2 = phi[s, 2, 0] * e0 + phi[s, 2, 1] * e1 + phi[s, 2, 2] * e2
            e0, e1, e2 = n0, n1, n2
            gx[s, j] = e0
            gv[s, j] = e1
