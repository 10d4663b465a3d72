"""The per-step laws of pd, ccc, adaptive-ccc, jee-ccc and rfnn / fnn as numba functions.

Each law reads what the Python ``act`` reads (the servo signals of env ``b`` at reference index
``kk``: measured position/velocity from the env's ``ax`` rows, the reference position,
velocity, acceleration, frame, curvature, torsion and feedrate from the reference tables) and
keeps the controller's state in row ``b`` of a float64 array ``st`` (flags as 0/1). Gains come
in a float64 vector ``fp`` (layouts: :mod:`agents.compiled.forms`).

Each law is defined here once: the controllers' Python ``act`` runs it through
:func:`act_rows`, the fused loops (:mod:`.runner`, :mod:`.residual_runner`) inline it. The
NumPy reference of the test suite (tests/agents/numpy_laws.py, from the papers' equations) is
written in the same summation order (sums of 2–3 terms left to right; ``einsum("bij,bj->bi")``
over 3 terms as (p0 + p2) + p1, numpy's two-lane pairing; the rfnn's sums over rules from
j = 0), so every path is bit-identical to it.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit

from contour_env.env.borrow import register_record
from contour_env.env.kernel import AX_MEAS, AX_VEL

KIND_PD, KIND_CCC, KIND_ADAPTIVE_CCC, KIND_JEE_CCC, KIND_RFNN = 1, 2, 3, 4, 5
# a law as the compiled loops receive it: its kind, gains fp, state st (one row per env) and
# the controller's force limit per axis (N)
CompiledLaw = register_record(namedtuple("CompiledLaw", "kind fp st flim"))
# the scratch :func:`law` needs: ≥ 4 A + 2 A² floats (3 axes), and the adaptive regressor
WORK_SIZE = 4 * 3 + 2 * 9 + 6

# --- CCC: fp = [P (A), D (A), W_p, W_i, W_d, mass (A), limit, cos(CORNER_TURN_RAD)];
# st = [prev (2), J (A), started, tangent (A), corner (A), bisector (A), holding]
# --- adaptive-ccc: fp = [k, alpha, coupling, kv_rho (A each), any_kv, ncol, friction,
# normalize, velocity_match, any_gamma, mean_squares (ncol), Gamma (ncol·A)]; st = θ̂ (ncol·A)
# --- jee-ccc: fp = [K_P (A), C_P, C_I, C_D]; st = [sum (A), prev (A), started]
# --- rfnn / fnn: fp = [P (A), D (A), alpha, 1/scale_e, 1/scale_s, input_limit, theta_limit,
# w_max, k_w, k_theta, learn, recurrent, R, learn_theta, centres (2 R), 1/σ² (2 R), lr_w,
# lr_theta / w_max², instant, EQ23_INSTANT_CAP, half the spread bound (N; inf: none)];
# st = [w (A R), θ (A 2 R), memory O(k−1) (A 2 R), then scratch: 2 (u − m) O(k−1) / σ² (2 R),
# ψ (R), y (A); then the largest per-sample eq. 23 value so far (NaN: none yet)]


@njit(cache=True, inline="always")
def _pd(A, b, kk, T, ax, ref_pav, fp, u):
    for i in range(A):
        e = ref_pav[kk, 0, i] - ax[AX_MEAS, b, i]
        de = ref_pav[kk, 1, i] - ax[AX_VEL, b, i]
        u[i] = fp[i] * e + fp[A + i] * de


@njit(cache=True, inline="always")
def _clip(x, lo, hi):
    # np.clip: NaN passes through
    if x < lo:
        return lo
    if x > hi:
        return hi
    return x


@njit(cache=True, inline="always")
def _ccc(A, b, kk, T, ax, ref_pav, frame, scal, fp, st, u, E):
    _pd(A, b, kk, T, ax, ref_pav, fp, u)
    W_p = fp[2 * A]
    W_i = fp[2 * A + 1]
    W_d = fp[2 * A + 2]
    om = 2 * A + 3  # mass
    limit = fp[3 * A + 3]
    cos_thr = fp[3 * A + 4]
    s_prev = 0
    s_J = 2
    s_started = 2 + A
    s_tan = 3 + A
    s_corner = 3 + 2 * A
    s_bis = 3 + 3 * A
    s_hold = 3 + 4 * A
    for i in range(A):
        E[i] = ref_pav[kk, 0, i] - ax[AX_MEAS, b, i]
    # contour_error_estimate
    sn = frame[kk, 0, 1] * E[0]
    ee = E[0] * E[0]
    for i in range(1, A):
        sn += frame[kk, i, 1] * E[i]
        ee += E[i] * E[i]
    eps_n = -(sn + 0.5 * scal[kk, 2] * ee)
    eps_b = 0.0
    if A == 3:
        sb = frame[kk, 0, 2] * E[0]
        for i in range(1, A):
            sb += frame[kk, i, 2] * E[i]
        eps_b = -sb
    started = st[b, s_started] != 0.0
    # the corner hold (CCCController.act)
    ct = st[b, s_tan] * frame[kk, 0, 0]
    for i in range(1, A):
        ct += st[b, s_tan + i] * frame[kk, i, 0]
    jump = started and (ct < cos_thr) and (ct > -0.9)
    if jump:
        for i in range(A):
            st[b, s_corner + i] = ref_pav[kk, 0, i]
            st[b, s_bis + i] = st[b, s_tan + i] + frame[kk, i, 0]
        st[b, s_hold] = 1.0
    pp = st[b, s_bis] * (ax[AX_MEAS, b, 0] - st[b, s_corner])
    for i in range(1, A):
        pp += st[b, s_bis + i] * (ax[AX_MEAS, b, i] - st[b, s_corner + i])
    if pp >= 0.0:
        st[b, s_hold] = 0.0
    for i in range(A):
        st[b, s_tan + i] = frame[kk, i, 0]
    if st[b, s_hold] != 0.0:
        for i in range(A):
            st[b, s_J + i] = 0.0
        eps_n = 0.0
        eps_b = 0.0
    # the integral's components on the current normal (and binormal)
    cn = st[b, s_J] * frame[kk, 0, 1]
    for i in range(1, A):
        cn += st[b, s_J + i] * frame[kk, i, 1]
    cn = _clip(cn + eps_n * T, -limit, limit)
    cb = 0.0
    if A == 3:
        cb = st[b, s_J] * frame[kk, 0, 2]
        for i in range(1, A):
            cb += st[b, s_J + i] * frame[kk, i, 2]
        cb = _clip(cb + eps_b * T, -limit, limit)
    for i in range(A):
        st[b, s_J + i] = 0.0
    n_dir = 2 if A == 3 else 1
    for slot in range(n_dir):
        col = 1 + slot
        eps = eps_n if slot == 0 else eps_b
        integ = cn if slot == 0 else cb
        de = (eps - st[b, s_prev + slot]) / T if started else 0.0
        c = W_p * eps + W_i * integ + W_d * de
        for i in range(A):
            d = frame[kk, i, col]
            u[i] = u[i] - fp[om + i] * c * d
            st[b, s_J + i] += integ * d
        st[b, s_prev + slot] = eps
    st[b, s_started] = 1.0


@njit(cache=True, inline="always")
def _sum3(p0, p1, p2, A):
    # numpy's einsum("bij,bj->bi") over A terms: two lanes, (p0 + p2) + p1 for three
    if A == 3:
        return (p0 + p2) + p1
    return p0 + p1


@njit(cache=True, inline="always")
def _sign(x):
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    if x == 0.0:
        return 0.0
    return x  # NaN


@njit(cache=True, inline="always")
def _adaptive(A, b, kk, T, ax, ref_pav, frame, scal, fp, st, u, E, W):
    # W: work space, at least 3 A + 2 A² + 3 A
    o_k, o_alpha, o_c, o_kv = 0, A, 2 * A, 3 * A
    any_kv = fp[4 * A] != 0.0
    ncol = int(fp[4 * A + 1])
    friction = fp[4 * A + 2] != 0.0
    normalize = fp[4 * A + 3] != 0.0
    vmatch = fp[4 * A + 4] != 0.0
    any_gamma = fp[4 * A + 5] != 0.0
    o_ms = 4 * A + 6
    o_G = o_ms + ncol
    Ed = W[0:A]
    FR = W[A : A + A * A]  # FRFt, row-major (i, l)
    C = W[A + A * A : A + 2 * A * A]
    phi = W[A + 2 * A * A : A + 2 * A * A + 3 * A]  # (ncol, A)
    kap = scal[kk, 2]
    tau = scal[kk, 3]
    v = scal[kk, 0]
    half_T = 0.5 * T
    for i in range(A):
        E[i] = ref_pav[kk, 0, i] - ax[AX_MEAS, b, i]
        rv = ref_pav[kk, 1, i]
        if vmatch:
            rv = rv - half_T * ref_pav[kk, 2, i]
        Ed[i] = rv - ax[AX_VEL, b, i]
    # F R Fᵀ: einsum("bij,bjk,blk->bil"), j outer, k inner, ((F_ij R_jk) F_lk) from 0; the
    # zero entries of R add ±0 to a sum that starts at +0 and are left out
    for i in range(A):
        for col in range(A):
            acc = 0.0
            acc += (frame[kk, i, 0] * kap) * frame[kk, col, 1]
            acc += (frame[kk, i, 1] * -kap) * frame[kk, col, 0]
            if A == 3:
                acc += (frame[kk, i, 1] * tau) * frame[kk, col, 2]
                acc += (frame[kk, i, 2] * -tau) * frame[kk, col, 1]
            FR[i * A + col] = acc
    sk = _sign(kap)
    for i in range(A):
        cv = fp[o_c + i] * v
        for col in range(A):
            cc = cv * FR[i * A + col]
            if any_kv:
                jj = 0.0
                if i == 0 and col == 1:
                    jj = 1.0
                elif i == 1 and col == 0:
                    jj = -1.0
                cc = cc + sk * (fp[o_kv + i] * jj)
            C[i * A + col] = cc
    for i in range(A):
        phi[i] = ref_pav[kk, 2, i]
        phi[A + i] = ref_pav[kk, 1, i]
        if friction:
            phi[2 * A + i] = _sign(ref_pav[kk, 1, i])
    for i in range(A):
        p2 = 0.0
        q2 = 0.0
        if A == 3:
            p2 = FR[i * A + 2] * E[2]
            q2 = C[i * A + 2] * E[2]
        fre = _sum3(FR[i * A] * E[0], FR[i * A + 1] * E[1], p2, A)
        ce = _sum3(C[i * A] * E[0], C[i * A + 1] * E[1], q2, A)
        pe = Ed[i] + fp[o_alpha + i] * E[i]
        Fr = pe + v * fre
        ff = 0.0
        for j in range(ncol):
            ff += phi[j * A + i] * st[b, j * A + i]
        u[i] = fp[o_k + i] * pe + ce + E[i] + ff
        if any_gamma:
            step = T * Fr
            if normalize:
                psi2 = 0.0
                for j in range(ncol):
                    ph = phi[j * A + i]
                    psi2 += ph * ph / fp[o_ms + j]
                x = psi2 / ncol
                if not x > 1.0 and x == x:
                    x = 1.0
                step = step / x
            for j in range(ncol):
                th = st[b, j * A + i] + fp[o_G + j * A + i] * phi[j * A + i] * step
                if th < 0.0:
                    th = 0.0
                st[b, j * A + i] = th


@njit(cache=True, inline="always")
def _jee(A, b, kk, T, ax, ref_pav, frame, fp, st, u, E):
    C_P = fp[A]
    C_I = fp[A + 1]
    C_D = fp[A + 2]
    for i in range(A):
        E[i] = ref_pav[kk, 0, i] - ax[AX_MEAS, b, i]
    s = frame[kk, 0, 0] * E[0]
    for i in range(1, A):
        s += frame[kk, i, 0] * E[i]
    started = st[b, 2 * A] != 0.0
    for i in range(A):
        eps = E[i] - s * frame[kk, i, 0]
        st[b, i] += eps * T
        d_eps = (eps - st[b, A + i]) / T if started else 0.0
        st[b, A + i] = eps
        u[i] = fp[i] * E[i] + C_P * eps + C_I * st[b, i] + C_D * d_eps
    st[b, 2 * A] = 1.0


@njit(cache=True, inline="always")
def _rfnn_learn(R, e, y, fp, o, o_x, r, q_w, q_th, s_t, s_psi, s_pk):
    # one direction's update (eqs. 14–19) with the options of issue 38: the per-sample eq. 23
    # value (recorded in r[s_pk], its largest so far), its cap on the θ step (instant=1) and
    # the rule weights' spread bound (margin=1 / kappa=κ). Sums run left to right, j = 0 first
    # (the θ gradient's squared norm: rule by rule, input 0 then input 1), as the NumPy
    # reference writes them.
    k_w = fp[o + 6]
    k_th = fp[o + 7]
    learn_theta = fp[o + 11] != 0.0  # learn and recurrent and k_θ > 0
    lr_w = fp[o_x]
    v_coef = fp[o_x + 1]  # lr_theta / w_max²
    instant = fp[o_x + 2] != 0.0
    cap = fp[o_x + 3]
    half = fp[o_x + 4]  # half the spread bound (N); inf: none
    w_max = fp[o + 5]
    ss = 0.0
    for j in range(R):
        psi = r[s_psi + j]
        ss = psi * psi if j == 0 else ss + psi * psi
    value = lr_w * ss
    if learn_theta:
        th_lim = fp[o + 4]
        ge = k_th * e
        gg = 0.0
        # the θ gradient (in place of its factor 2 (u − m) O(k−1) / σ², formed in the forward
        # pass) and its squared norm, rule by rule (input 0, input 1); without the per-sample
        # cap θ steps in the same pass
        for j in range(R):
            a = r[s_psi + j] * (r[q_w + j] - y)
            g0 = -a * r[s_t + j]
            g1 = -a * r[s_t + R + j]
            gg = g0 * g0 if j == 0 else gg + g0 * g0
            gg = gg + g1 * g1
            if instant:
                r[s_t + j] = g0
                r[s_t + R + j] = g1
            else:
                r[q_th + j] = _clip(r[q_th + j] - ge * g0, -th_lim, th_lim)
                r[q_th + R + j] = _clip(r[q_th + R + j] - ge * g1, -th_lim, th_lim)
        v_theta = v_coef * gg
        if instant:
            scaled = False
            scale = 1.0
            if value + v_theta > cap:  # scale this sample's θ step down to the cap
                room = cap - value
                if room < 0.0:
                    room = 0.0
                scale = room / v_theta
                v_theta = v_theta * scale
                scaled = True
            for j in range(2 * R):
                step = ge * r[s_t + j]
                if scaled:
                    step = step * scale
                r[q_th + j] = _clip(r[q_th + j] - step, -th_lim, th_lim)
        value = value + v_theta
    if not value <= r[s_pk]:  # also the first sample (NaN)
        r[s_pk] = value
    gw = k_w * e
    if half < math.inf:
        # the spread bound: every weight within ±half of the output at these inputs with the
        # new weights
        y_new = 0.0
        for j in range(R):
            wn = r[q_w + j] - gw * r[s_psi + j]
            r[q_w + j] = wn
            wy = wn * r[s_psi + j]
            y_new = wy if j == 0 else y_new + wy
        for j in range(R):
            wn = _clip(r[q_w + j], y_new - half, y_new + half)
            r[q_w + j] = _clip(wn, -w_max, w_max)
    else:
        for j in range(R):
            r[q_w + j] = _clip(r[q_w + j] - gw * r[s_psi + j], -w_max, w_max)


@njit(cache=True, inline="always")
def _rfnn_n(A, R, b, kk, ax, ref_pav, frame, fp, st, u):
    # Chen & Lee 2020 eqs. 5–7 (forward) and 14–19 (update, :func:`_rfnn_learn`), the law
    # agents.rfnn.RFNNController documents (exp: libm's, as math.exp), for A axes and R
    # rules; called with literal A and R where it can be, so that the compiler unrolls the
    # loops over the rules and directions
    r = st[b]
    o = 2 * A
    alpha = fp[o]
    inv_scale_e = fp[o + 1]
    inv_scale_s = fp[o + 2]
    lim = fp[o + 3]
    learn = fp[o + 8] != 0.0
    recurrent = fp[o + 9] != 0.0
    o_m = o + 12
    o_is2 = o_m + 2 * R
    s_th = A * R
    s_mem = 3 * A * R
    s_t = 5 * A * R  # scratch: 2 (u − m) O(k−1) / σ² (2 R), ψ (R), y (A); then eq. 23's peak
    s_psi = s_t + 2 * R
    s_y = s_psi + R
    for p in range(A):
        se = frame[kk, 0, p] * (ref_pav[kk, 0, 0] - ax[AX_MEAS, b, 0])
        sd = frame[kk, 0, p] * (ref_pav[kk, 1, 0] - ax[AX_VEL, b, 0])
        for i in range(1, A):
            se = se + frame[kk, i, p] * (ref_pav[kk, 0, i] - ax[AX_MEAS, b, i])
            sd = sd + frame[kk, i, p] * (ref_pav[kk, 1, i] - ax[AX_VEL, b, i])
        e = -se
        s = -sd + alpha * e
        x0 = _clip(e * inv_scale_e, -lim, lim)
        x1 = _clip(s * inv_scale_s, -lim, lim)
        q_w = p * R
        q_th = s_th + 2 * p * R  # θ, memory of input 0 (e) and input 1 (s) of rule j
        q_mem = s_mem + 2 * p * R
        S = 0.0
        for j in range(R):
            m0 = r[q_mem + j]
            m1 = r[q_mem + R + j]
            is0 = fp[o_is2 + j]
            is1 = fp[o_is2 + R + j]
            d0 = (x0 + m0 * r[q_th + j]) - fp[o_m + j]
            d1 = (x1 + m1 * r[q_th + R + j]) - fp[o_m + R + j]
            o0 = math.exp(-(d0 * d0 * is0))
            o1 = math.exp(-(d1 * d1 * is1))
            # the θ gradient's factor needs O(k−1): taken before the memory is overwritten
            r[s_t + j] = 2.0 * d0 * m0 * is0
            r[s_t + R + j] = 2.0 * d1 * m1 * is1
            if recurrent:
                r[q_mem + j] = o0
                r[q_mem + R + j] = o1
            o3 = o0 * o1
            r[s_psi + j] = o3
            S = o3 if j == 0 else S + o3
        inv_S = 1.0 / S
        y = 0.0
        for j in range(R):
            psi = r[s_psi + j] * inv_S
            r[s_psi + j] = psi
            wy = r[q_w + j] * psi
            y = wy if j == 0 else y + wy
        if learn:
            _rfnn_learn(R, e, y, fp, o, o_is2 + 2 * R, r, q_w, q_th, s_t, s_psi, s_y + A)
        r[s_y + p] = y
    for i in range(A):
        c = frame[kk, i, 0] * r[s_y]
        for p in range(1, A):
            c = c + frame[kk, i, p] * r[s_y + p]
        u[i] = u[i] + c


@njit(cache=True, inline="always")
def _rfnn(A, b, kk, T, ax, ref_pav, frame, fp, st, u):
    _pd(A, b, kk, T, ax, ref_pav, fp, u)
    R = int(fp[2 * A + 10])
    # literal sizes for the usual configurations (the compiler unrolls their loops), else the
    # loops over run-time sizes
    if A == 3 and R == 4:
        _rfnn_n(3, 4, b, kk, ax, ref_pav, frame, fp, st, u)
    elif A == 2 and R == 4:
        _rfnn_n(2, 4, b, kk, ax, ref_pav, frame, fp, st, u)
    elif A == 3 and R == 9:
        _rfnn_n(3, 9, b, kk, ax, ref_pav, frame, fp, st, u)
    elif A == 2 and R == 9:
        _rfnn_n(2, 9, b, kk, ax, ref_pav, frame, fp, st, u)
    else:
        _rfnn_n(A, R, b, kk, ax, ref_pav, frame, fp, st, u)


@njit(cache=True, inline="always")
def law(kind, A, b, kk, T, ax, ref_pav, frame, scal, fp, st, u, work):
    """The command u (A,) of env b (plant units) from its signals at reference index kk;
    advances the controller state st[b]. ``work``: scratch, ≥ 4 A + 2 A² floats."""
    E = work[0:A]
    if kind == KIND_PD:
        _pd(A, b, kk, T, ax, ref_pav, fp, u)
    elif kind == KIND_CCC:
        _ccc(A, b, kk, T, ax, ref_pav, frame, scal, fp, st, u, E)
    elif kind == KIND_ADAPTIVE_CCC:
        _adaptive(A, b, kk, T, ax, ref_pav, frame, scal, fp, st, u, E, work[A:])
    elif kind == KIND_RFNN:
        _rfnn(A, b, kk, T, ax, ref_pav, frame, fp, st, u)
    else:
        _jee(A, b, kk, T, ax, ref_pav, frame, fp, st, u, E)


@njit(cache=True)
def act_rows(kind, T, ax, ref_pav, frame, scal, fp, st, u):
    """The Python ``act`` of every controller with a compiled law runs here: :func:`law` for
    each row b of a batch of servo signals (u (B, A) out, plant units), the signals of row b at
    table index b: ``ax`` rows AX_MEAS and AX_VEL (measured position m and velocity m/s, each
    (B, A)), ``ref_pav`` (B, 3, 3) [position, velocity, acceleration], ``frame`` (B, 3, 3)
    columns [t n b], ``scal`` (B, 4) [feedrate m/s, -, curvature 1/m, torsion 1/m]. T: the servo
    period (s); ``st`` rows 0..B−1 advanced. The fused loops (:mod:`.runner`,
    :mod:`.residual_runner`) call the same :func:`law` on the env's own tables, so a law is
    defined once (:func:`agents.compiled.forms.run_law` packs a controller for this)."""
    B, A = u.shape
    row = np.zeros(A)
    work = np.zeros(WORK_SIZE)
    for b in range(B):
        law(kind, A, b, b, T, ax, ref_pav, frame, scal, fp, st, row, work)
        for i in range(A):
            u[b, i] = row[i]
