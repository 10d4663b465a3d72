"""Compiled step of the five-axis env: plant → encoder → kinematics → task-space errors →
guards → reward → observation, per env of a batch (the five-axis counterpart of
:mod:`contour_env.env.kernel`; the plant is :func:`five_axis_step_batch`).

Each env is stepped by the same arithmetic whatever the batch, so the vector env equals the
single envs bit for bit. Layouts (SI): joints (B, 5) in (m, m, m, rad, rad); the reference
tables (n, 5) / (n, 3) per servo sample; ``cfg`` float64 with the F_* slots, ``icfg`` int64
with the N_* slots.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit

from ..plants.five_axis.plant import five_axis_step_batch
from .borrow import register_record
from .layout import (
    STATUS_CONTOUR_LIMIT,
    STATUS_NONFINITE,
    STATUS_OK,
    STATUS_TRACKING_LIMIT,
    StepOutputs,
)
from .reward import five_axis_reward, guard_reward

# cfg slots
(
    F_T,
    F_ERR_SCALE,
    F_VERR_SCALE,
    F_FEED_SCALE,
    F_LEVER,
    F_EPS_SCALE,
    F_W_CONTOUR,
    F_W_LAG,
    F_W_EFFORT,
    F_ABORT_CONTOUR,
    F_ABORT_TRACK,
    F_GUARD_PENALTY,
    F_OBS_CLIP,
    F_D4,
    F_TIP_OFFSET,
) = range(15)
F_SIZE = 15
# icfg slots: reference samples, RK4 substeps, computation delay (0/1), search half-window
N_STEPS, N_SUB, N_DELAY, N_WINDOW = range(4)
N_SIZE = 4

# observation layout (see FiveAxisCore's docstring)
OBS_DIM = 22

# The arrays of the entry points, by record; each field is the FiveAxisCore attribute of that
# name (FiveAxisCore.records builds them by field name), so the list is written here only.
# The reference tables: joints ξ_d (n, 5), joint rates (n, 5), tool tip (n, 3) m, tool
# vector (n, 3), feedrate (n,) m/s
FiveAxisPath = register_record(
    namedtuple("FiveAxisPath", ("ref_q", "ref_qd", "ref_tip", "ref_tool", "ref_feed"))
)
# Per env (B, ...): joints, rates, applied torque, delayed command, measured joints, their
# previous value and backward-difference rate, the force applied last period, reference
# index, nearest reference sample, contour and orientation errors (m, rad), tool tip and
# vector, guard status, previous action
FiveAxisEnvState = register_record(
    namedtuple(
        "FiveAxisEnvState",
        (
            "q", "qd", "tau", "u_pending", "meas", "mprev", "mvel", "applied", "k", "near",
            "eps", "orient", "tip", "tool", "status", "action",
        ),
    )
)  # fmt: skip
# Encoder resolution (5,) m/rad, drive limits (5,) N/N·m, the torques holding gravity at the
# start pose (5,), and the packed parameter sets (PackedFiveAxis: ip, jp, pidx)
FiveAxisPlantArrays = register_record(
    namedtuple("FiveAxisPlantArrays", ("resolution", "force_limit", "q0_hold", "ip", "jp", "pidx"))
)
# what a step writes for Python (observation (B, OBS_DIM) float32, reward, done flags): the
# feed-drive kernel's StepOutputs
ENTRY_RECORDS = (FiveAxisPath, FiveAxisEnvState, FiveAxisPlantArrays, StepOutputs)
# where each record's arrays end in the entry points' flat list
PATH_END, STATE_END, PLANT_END, OUT_END = (
    int(e) for e in np.cumsum([len(r._fields) for r in ENTRY_RECORDS])
)


@njit(cache=True, inline="always")
def records_of(arrays):
    """The records of an entry point's flat arrays (:data:`ENTRY_RECORDS`, in order)."""
    return (
        FiveAxisPath(*arrays[0:PATH_END]),
        FiveAxisEnvState(*arrays[PATH_END:STATE_END]),
        FiveAxisPlantArrays(*arrays[STATE_END:PLANT_END]),
        StepOutputs(*arrays[PLANT_END:OUT_END]),
    )


@njit(cache=True, inline="always")
def quantize(x, r):
    """Encoder reading of x with resolution r (0: exact), as FiveAxisPlant.measure."""
    return np.rint(x / r) * r if r > 0.0 else x


@njit(cache=True)
def _hermite(samples, j, u, out):
    """The Catmull–Rom cubic through samples j, j + 1 (tangents from the neighbours) at
    u ∈ [0, 1] (rows of ``samples``, 3 columns)."""
    n = samples.shape[0]
    jm, jp, jpp = max(j - 1, 0), min(j + 1, n - 1), min(j + 2, n - 1)
    h00 = (1.0 + 2.0 * u) * (1.0 - u) * (1.0 - u)
    h10 = u * (1.0 - u) * (1.0 - u)
    h01 = u * u * (3.0 - 2.0 * u)
    h11 = u * u * (u - 1.0)
    for i in range(3):
        m0 = 0.5 * (samples[jp, i] - samples[jm, i])
        m1 = 0.5 * (samples[jpp, i] - samples[j, i])
        out[i] = h00 * samples[j, i] + h10 * m0 + h01 * samples[jp, i] + h11 * m1


@njit(cache=True)
def _refine(tip, ref_tip, j, f, d2_chord):
    """(fraction, squared distance) of the point nearest to ``tip`` on the Catmull–Rom cubic
    through the reference samples j, j + 1 (tangents from the neighbours), by Newton's method
    from the chord's foot f: the chord alone would overstate the distance by its sagitta
    (h² / 8r: 0.2 µm on the r = 0.1 m circle at 0.4 m/s), the cubic's error is O(h⁴)."""
    n = ref_tip.shape[0]
    jm, jp, jpp = max(j - 1, 0), j + 1, min(j + 2, n - 1)
    c0 = np.empty(3)
    c1 = np.empty(3)
    c2 = np.empty(3)
    c3 = np.empty(3)
    for i in range(3):
        p0, p1 = ref_tip[j, i], ref_tip[jp, i]
        m0 = 0.5 * (p1 - ref_tip[jm, i])
        m1 = 0.5 * (ref_tip[jpp, i] - p0)
        # P(u) = c0 + c1 u + c2 u² + c3 u³ (Hermite form of p0, m0, p1, m1)
        c0[i] = p0
        c1[i] = m0
        c2[i] = -3.0 * p0 - 2.0 * m0 + 3.0 * p1 - m1
        c3[i] = 2.0 * p0 + m0 - 2.0 * p1 + m1
    u = f
    for _ in range(4):
        g = 0.0
        dg = 0.0
        for i in range(3):
            r = c0[i] + u * (c1[i] + u * (c2[i] + u * c3[i])) - tip[i]
            d1 = c1[i] + u * (2.0 * c2[i] + 3.0 * u * c3[i])
            d2 = 2.0 * c2[i] + 6.0 * u * c3[i]
            g += r * d1
            dg += d1 * d1 + r * d2
        if dg <= 0.0:
            break
        u = min(max(u - g / dg, 0.0), 1.0)
    d2 = 0.0
    for i in range(3):
        r = c0[i] + u * (c1[i] + u * (c2[i] + u * c3[i])) - tip[i]
        d2 += r * r
    if d2 <= d2_chord:
        return u, d2
    return f, d2_chord


@njit(cache=True, inline="always")
def forward_into(q, d4, tip_offset, tip, tool):
    """Eq. 1 (kinematics.forward, the same arithmetic) of one joint vector q (5,)."""
    sa, ca = math.sin(q[3]), math.cos(q[3])
    sc, cc = math.sin(q[4]), math.cos(q[4])
    zt = q[2] + tip_offset
    wy = ca * q[1] + sa * zt
    wz = -sa * q[1] + ca * zt
    tip[0] = cc * q[0] + sc * wy
    tip[1] = -sc * q[0] + cc * wy
    tip[2] = wz - d4
    tool[0] = sa * sc
    tool[1] = sa * cc
    tool[2] = ca


@njit(cache=True)
def _two_ranges(lo1, hi1, lo2, hi2):
    """The integers of [lo1, hi1] ∪ [lo2, hi2], each once, in order (O(both lengths))."""
    out = np.empty(max(hi1 - lo1 + 1, 0) + max(hi2 - lo2 + 1, 0), dtype=np.int64)
    m = 0
    if lo2 < lo1:
        lo1, hi1, lo2, hi2 = lo2, hi2, lo1, hi1
    for j in range(lo1, hi1 + 1):
        out[m] = j
        m += 1
    for j in range(max(lo2, hi1 + 1), hi2 + 1):
        out[m] = j
        m += 1
    return out[:m]


@njit(cache=True)
def nearest_on_reference(tip, tool, ref_tip, ref_tool, j0, k, window):
    """(distance (m), angle (rad), segment j) of a tip (3,) and tool vector (3,) against the
    reference tip path: the nearest segment of the polyline through the reference tips over
    the segments j0 − window … j0 + window (O(window)), refined on the cubic through its
    samples (:func:`_refine`); the reference tool at the foot point is the same cubic through
    the tool samples (:func:`_hermite`). Zero-length segments (the reference at rest) are
    points."""
    n = ref_tip.shape[0]
    best = np.inf
    best_j = max(min(j0, n - 2), 0)
    best_f = 0.0
    # two windows: about the last nearest segment (the tool's own progress) and behind the
    # reference index k (where a lagging tool is), so a path that folds back on itself
    # (a cusp of the tip path) cannot hold the search on the wrong branch
    lo1, hi1 = max(j0 - window, 0), min(j0 + window, n - 2)
    lo2, hi2 = max(k - 4 * window, 0), min(k + window, n - 2)
    for j in _two_ranges(lo1, hi1, lo2, hi2):
        dx = ref_tip[j + 1, 0] - ref_tip[j, 0]
        dy = ref_tip[j + 1, 1] - ref_tip[j, 1]
        dz = ref_tip[j + 1, 2] - ref_tip[j, 2]
        rx = tip[0] - ref_tip[j, 0]
        ry = tip[1] - ref_tip[j, 1]
        rz = tip[2] - ref_tip[j, 2]
        dd = dx * dx + dy * dy + dz * dz
        f = 0.0
        if dd > 0.0:
            f = (rx * dx + ry * dy + rz * dz) / dd
            f = min(max(f, 0.0), 1.0)
        ex, ey, ez = rx - f * dx, ry - f * dy, rz - f * dz
        d2 = ex * ex + ey * ey + ez * ez
        if d2 < best:
            best, best_j, best_f = d2, j, f
    if n < 2:  # a one-sample reference: the point itself
        best_j = 0
        best_f = 0.0
        rx, ry, rz = tip[0] - ref_tip[0, 0], tip[1] - ref_tip[0, 1], tip[2] - ref_tip[0, 2]
        best = rx * rx + ry * ry + rz * rz
    else:
        best_f, best = _refine(tip, ref_tip, best_j, best_f, best)
    # the reference tool at the same parameter of the same cubic through its samples
    o = np.empty(3)
    _hermite(ref_tool, best_j, best_f, o)
    ox, oy, oz = o[0], o[1], o[2]
    # angle = atan2(|a × b|, a · b): accurate for small angles (arc-seconds)
    cx = tool[1] * oz - tool[2] * oy
    cy = tool[2] * ox - tool[0] * oz
    cz = tool[0] * oy - tool[1] * ox
    angle = math.atan2(
        math.sqrt(cx * cx + cy * cy + cz * cz), tool[0] * ox + tool[1] * oy + tool[2] * oz
    )
    return math.sqrt(best), angle, best_j


@njit(cache=True)
def observe_one(b, cfg, k, n_steps, path, state, out):
    """Observation of env b from its measured joints (the layout of FiveAxisCore), into
    ``out.obs``."""
    kk = min(k, n_steps - 1)
    clip = cfg[F_OBS_CLIP]
    inv_e = 1.0 / cfg[F_ERR_SCALE]
    inv_v = 1.0 / cfg[F_VERR_SCALE]
    meas, mvel, prev_a = state.meas, state.mvel, state.action
    ref_q, ref_qd, ref_tip, ref_tool = path.ref_q, path.ref_qd, path.ref_tip, path.ref_tool
    tip = np.empty(3)
    tool = np.empty(3)
    forward_into(meas[b], cfg[F_D4], cfg[F_TIP_OFFSET], tip, tool)
    vals = np.empty(22)
    for j in range(5):
        vals[j] = (ref_q[kk, j] - meas[b, j]) * inv_e
        vals[5 + j] = (ref_qd[kk, j] - mvel[b, j]) * inv_v
        vals[17 + j] = prev_a[b, j]
    for i in range(3):
        vals[10 + i] = (ref_tip[kk, i] - tip[i]) * inv_e
        vals[13 + i] = (ref_tool[kk, i] - tool[i]) * cfg[F_LEVER] * inv_e
    vals[16] = path.ref_feed[kk] / cfg[F_FEED_SCALE]
    obs = out.obs
    for i in range(22):
        v = vals[i]
        if not math.isfinite(v):
            v = clip if v > 0 else -clip
            if v != v:
                v = 0.0
        obs[b, i] = np.float32(min(max(v, -clip), clip))


@njit(cache=True)
def reset_envs(envs, cfg, icfg, *arrays):
    """Put the envs ``envs`` at rest on the reference start, drives holding gravity.
    ``arrays``: the records' arrays, flat, in their declared order (:func:`records_of`)."""
    path, state, plant, out = records_of(arrays)
    _reset_records(envs, cfg, icfg, path, state, plant, out)


@njit(cache=True)
def _reset_records(envs, cfg, icfg, path, state, plant, out):
    n_steps = icfg[N_STEPS]
    ref_q, q0_hold, res = path.ref_q, plant.q0_hold, plant.resolution
    q, qd, meas = state.q, state.qd, state.meas
    for b in envs:
        for j in range(5):
            q[b, j] = ref_q[0, j]
            qd[b, j] = 0.0
            state.tau[b, j] = q0_hold[j]
            state.u_pending[b, j] = q0_hold[j]
            meas[b, j] = quantize(q[b, j], res[j])
            state.mprev[b, j] = meas[b, j]
            state.mvel[b, j] = 0.0
            state.applied[b, j] = q0_hold[j]
            state.action[b, j] = 0.0
        state.k[b] = 0
        tip, tool = state.tip[b], state.tool[b]
        forward_into(q[b], cfg[F_D4], cfg[F_TIP_OFFSET], tip, tool)
        d, a, jn = nearest_on_reference(
            tip, tool, path.ref_tip, path.ref_tool, 0, 0, icfg[N_WINDOW]
        )
        state.eps[b], state.orient[b], state.near[b] = d, a, jn
        state.status[b] = STATUS_OK
        out.reward[b] = 0.0
        out.terminated[b] = False
        out.truncated[b] = False
        observe_one(b, cfg, 0, n_steps, path, state, out)


@njit(cache=True)
def env_step(cfg, icfg, action, active, *arrays):
    """Step every active env once with ``action`` (B, 5) in [-1, 1]. Returns (first env with
    a non-finite action or −1, terminated count, ended count); an env with a bad action is
    not stepped. ``arrays``: the records' arrays, flat, in their declared order (a tuple of
    records from Python costs numba's dispatcher several µs a call; flat arrays do not)."""
    path, state, plant, out = records_of(arrays)
    return _step_records(cfg, icfg, path, state, plant, action, active, out)


@njit(cache=True)
def _step_records(cfg, icfg, path, state, plant, action, active, out):
    n_steps = icfg[N_STEPS]
    T = cfg[F_T]
    lever = cfg[F_LEVER]
    inv_scale = 1.0 / cfg[F_EPS_SCALE]
    q, qd, k, meas, mprev = state.q, state.qd, state.k, state.meas, state.mprev
    ref_tip = path.ref_tip
    limit, res = plant.force_limit, plant.resolution
    reward, terminated, truncated = out.reward, out.terminated, out.truncated
    command = np.empty((1, 5))
    app = np.empty((1, 5))
    bad = -1
    n_term = 0
    n_end = 0
    for b in range(q.shape[0]):
        if not active[b]:
            continue
        finite = True
        for j in range(5):
            if not math.isfinite(action[b, j]):
                finite = False
        if not finite:
            if bad < 0:
                bad = b
            continue
        effort = 0.0
        for j in range(5):
            a = min(max(action[b, j], -1.0), 1.0)
            state.action[b, j] = a
            effort += a * a
            command[0, j] = a * limit[j]
        five_axis_step_batch(
            q[b : b + 1], qd[b : b + 1], state.tau[b : b + 1], state.u_pending[b : b + 1],
            command, k[b] * T, T, icfg[N_SUB], icfg[N_DELAY] != 0, plant.ip, plant.jp,
            plant.pidx[b : b + 1], app,
        )  # fmt: skip
        k[b] += 1
        kk = min(k[b], n_steps - 1)
        ok = True
        for j in range(5):
            state.applied[b, j] = app[0, j]
            mprev[b, j] = meas[b, j]
            meas[b, j] = quantize(q[b, j], res[j])
            state.mvel[b, j] = (meas[b, j] - mprev[b, j]) / T
            if not (math.isfinite(q[b, j]) and math.isfinite(qd[b, j])):
                ok = False
        st = STATUS_OK
        track = 0.0
        if ok:
            tip, tool = state.tip[b], state.tool[b]
            forward_into(q[b], cfg[F_D4], cfg[F_TIP_OFFSET], tip, tool)
            d, ang, jn = nearest_on_reference(
                tip, tool, ref_tip, path.ref_tool, state.near[b], kk, icfg[N_WINDOW]
            )
            state.eps[b], state.orient[b], state.near[b] = d, ang, jn
            for i in range(3):
                e = ref_tip[kk, i] - tip[i]
                track += e * e
            track = math.sqrt(track)
            if d + lever * ang > cfg[F_ABORT_CONTOUR]:
                st = STATUS_CONTOUR_LIMIT
            elif track > cfg[F_ABORT_TRACK]:
                st = STATUS_TRACKING_LIMIT
        else:
            state.eps[b] = np.nan
            state.orient[b] = np.nan
            st = STATUS_NONFINITE
        state.status[b] = st
        if st != STATUS_OK:
            terminated[b] = True
            truncated[b] = False
            reward[b] = guard_reward(cfg[F_GUARD_PENALTY], n_steps - k[b])
            n_term += 1
            n_end += 1
        else:
            terminated[b] = False
            truncated[b] = k[b] >= n_steps - 1
            if truncated[b]:
                n_end += 1
            reward[b] = five_axis_reward(
                cfg[F_W_CONTOUR], cfg[F_W_LAG], cfg[F_W_EFFORT], inv_scale,
                state.eps[b], lever, state.orient[b], track, effort,
            )  # fmt: skip
        if ok:
            observe_one(b, cfg, k[b], n_steps, path, state, out)
        else:
            for i in range(OBS_DIM):
                out.obs[b, i] = 0.0
    return bad, n_term, n_end
