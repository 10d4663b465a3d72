"""The fit's plants packed for the package's compiled axis step: parameter vectors as
:class:`~contour_env.plants.params.PlantParams`, their discretisation in one batch."""

from __future__ import annotations

import functools

import numpy as np

from ..plants.discretize import continuous_model
from ..plants.kernel import (
    NL_FC,
    NL_FMAX,
    NL_FS,
    NL_MASS,
    NL_VS,
    n_sub_levels,
    sub_level_lengths,
)
from ..plants.model import PackedPlant, pack_params
from ..plants.params import PlantParams


def _params_of(theta: np.ndarray, T: float, limit: float) -> PlantParams:
    m, b, fc, dfs, vs, tau = (float(x) for x in theta[:6])
    return PlantParams(
        name="fit",
        axis_names=("a", "b"),
        mass_kg=m,
        viscous_Ns_m=b,
        coulomb_N=fc,
        static_N=fc + dfs,
        stribeck_velocity_m_s=vs,
        ripple_amplitude_N=0.0,
        ripple_period_m=1.0,
        disturbance_amplitude_N=0.0,
        disturbance_frequency_hz=0.0,
        force_limit_N=limit,
        encoder_resolution_m=0.0,
        servo_period_s=T,
        current_loop_time_constant_s=tau,
        computation_delay=False,
    )


def _expm(M: np.ndarray) -> np.ndarray:
    """Matrix exponential of a stack (..., n, n): scaling and squaring of the Taylor series to
    the 18th power (terms beyond below 1e-25 of the first at norm 1/2). Plain numpy products:
    scipy.linalg.expm goes through threaded LAPACK calls that take milliseconds each on a
    machine whose cores are busy, and the fit discretises thousands of small matrices."""
    # one scaling per matrix (norms differ by orders of magnitude across hold times)
    norm = np.max(np.sum(np.abs(M), axis=-1), axis=-1)
    s = np.where(norm > 0.5, np.ceil(np.log2(np.maximum(norm, 1e-300) / 0.5)), 0).astype(int)
    X = M / (2.0**s)[..., None, None]
    eye = np.broadcast_to(np.eye(M.shape[-1]), M.shape)
    E = eye.copy()
    for k in range(18, 0, -1):
        E = eye + (X @ E) / k
    for level in range(int(s.max()) if s.size else 0):
        sq = s > level
        E = np.where(sq[..., None, None], E @ E, E)
    return E


def _discretize(A: np.ndarray, Bu: np.ndarray, Bw: np.ndarray, h):
    """:func:`contour_env.plants.discretize.discretize` (the same augmented matrix and the
    same extraction) with :func:`_expm`; ``h`` a number or an array of hold times along the
    first axis of ``A`` (broadcast); ``tests/test_identify.py`` holds them equal."""
    ns = A.shape[-1]
    h = np.asarray(h, dtype=np.float64)
    hb = h.reshape(h.shape + (1,) * (A.ndim - h.ndim)) if h.ndim else h
    lead = np.broadcast_shapes(A.shape[:-2], hb.shape[:-2] if h.ndim else ())
    M = np.zeros((*lead, ns + 3, ns + 3))
    M[..., :ns, :ns] = A
    M[..., :ns, ns] = Bu
    M[..., :ns, ns + 1] = Bw
    M[..., ns + 1, ns + 2] = 1.0
    E = _expm(M * hb)
    Phi = E[..., :ns, :ns]
    Gu = E[..., :ns, ns]
    G1 = E[..., :ns, ns + 1]
    Gb = E[..., :ns, ns + 2] / hb[..., 0]
    Ga = G1 - Gb
    return Phi, Gu, Ga, Gb


@functools.lru_cache(maxsize=8)
def _template_nl(T: float, n_sub: int) -> np.ndarray:
    """The nonlinear-parameter rows (1, 2, NL_SIZE) of a fit's plant as the package packs them
    (no ripple, no disturbance, exact encoder); the fitted entries are overwritten."""
    th = np.array([1.0, 1.0, 1.0, 1.0, 1.0, T])
    nl = pack_params([_params_of(th, T, 1.0).replace(friction_substeps=n_sub)]).nl
    nl.setflags(write=False)
    return nl


def _pack(plist: list) -> PackedPlant:
    """:func:`contour_env.plants.model.pack_params` of distinct parameter sets that differ only
    in mass, viscous, friction, current-loop lag and force limit (one env per set): the
    template's packed arrays (the first set, packed by the package) with those entries and the
    discretised matrices of every set filled in (:func:`_discretize`, one batched call)."""
    S = len(plist)
    T = plist[0].servo_period_s
    n_sub = plist[0].friction_substeps
    tpl_nl = _template_nl(T, n_sub)
    L = n_sub_levels(n_sub)
    models = [continuous_model(p) for p in plist]
    A = np.stack([m[0] for m in models])  # (S, axes, ns, ns)
    Bu = np.stack([m[1] for m in models])
    Bw = np.stack([m[2] for m in models])
    hs = np.array([T, *sub_level_lengths(T, n_sub)])
    Phi, Gu, Ga, Gb = _discretize(A[None], Bu[None], Bw[None], hs)  # (levels, S, axes, ...)
    mats = np.concatenate([Phi, Gu[..., None], Ga[..., None], Gb[..., None]], axis=-1)
    mat_T = np.ascontiguousarray(mats[0])
    mat_h = np.ascontiguousarray(np.swapaxes(mats[1:], 0, 1).reshape(S * L, *mat_T.shape[1:]))
    cont = np.ascontiguousarray(
        np.concatenate([A[:, :, 1, :], Bu[:, :, 1:2], Bw[:, :, 1:2]], axis=2)
    )
    nl = np.repeat(tpl_nl, S, axis=0)
    for q, p in enumerate(plist):
        nl[q, :, NL_FC] = p.coulomb_N
        nl[q, :, NL_FS] = p.static_N
        nl[q, :, NL_VS] = p.stribeck_velocity_m_s
        nl[q, :, NL_FMAX] = p.force_limit_N
        nl[q, :, NL_MASS] = p.mass_kg
    return PackedPlant(mat_T, mat_h, cont, nl, np.arange(S, dtype=np.int64))
