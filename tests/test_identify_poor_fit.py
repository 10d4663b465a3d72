"""Identification on a trace that ``contour-env excite`` did not make (issue 50, item 5): an
8 s open-loop force trace on hsm2 (two sines plus a PRBS square per axis, the force as
applied after the drive's one-period delay, the encoder's position with 0.1 µm noise). On this
seed the y axis' delay and current-loop lag cannot be told apart and its fit goes wrong (the
Coulomb friction dropped, viscous 22 % high, the held-out position missed by 1.4 % against
x's 0.01 %): the fit is reported as poor, with the reason and what to record instead, and the
friction it dropped is not reported as absent. The same trace's commanded force (seed 1) is
identified within 2 %: the check does not fire on a good fit."""

from __future__ import annotations

import numpy as np
import pytest

from contour_env.identify import POOR_POSITION_ERROR, identify, poor_fits
from contour_env.identify.trace import trace_from_arrays
from contour_env.plants import Plant


def open_loop_trace(seed: int, applied: bool):
    plant = Plant("hsm2")
    p = plant.params
    T = p.servo_period_s
    n = int(8.0 / T)
    t = np.arange(n) * T
    rng = np.random.default_rng(seed)
    u = np.zeros((n, 2))
    for j in range(2):
        f1, f2 = rng.uniform(0.3, 1.0), rng.uniform(2.0, 5.0)
        a = 0.08 * p.force_limit_N[j]
        prbs = np.repeat(rng.choice([-1.0, 1.0], size=n // 50 + 1), 50)[:n]
        u[:, j] = (a * np.sin(2 * np.pi * f1 * t) + 0.5 * a * np.sin(2 * np.pi * f2 * t + 1.0)
                   + 0.3 * a * prbs)  # fmt: skip
    st = plant.initial_state(np.zeros((1, 2)))
    pos = np.zeros((n, 2))
    force = np.zeros((n, 2))
    q = p.encoder_resolution_m
    for k in range(n):
        pos[k] = np.round(st.position[0] / q) * q
        st, ap = plant.step(st, u[k][None, :], t[k])
        force[k] = ap[0] if applied else u[k]
    pos = pos + rng.normal(0.0, 1e-7, pos.shape)
    return trace_from_arrays(t, force, pos, ("x", "y"), source="openloop.csv")


def test_a_poor_fit_is_reported_with_its_reason_and_friction_not_called_absent():
    ident = identify(open_loop_trace(0, applied=True))
    y = ident.axes[1]
    assert y.holdout_error["position"] > POOR_POSITION_ERROR  # 1.4 %
    assert set(ident.poor_fit) == {"y"}
    why = ident.poor_fit["y"]
    assert why.startswith("axis y: poor fit: the model misses the held-out position by ")
    assert "(x: 0.01%)" in why and "record the program contour-env excite plans" in why
    assert "\n" not in why and why in ident.warnings
    assert "axis y: friction set to 0 on a poor fit: not evidence that the axis has none" in (
        ident.warnings
    )
    assert not any("friction the trace cannot tell from none" in w for w in ident.warnings)
    report = ident.report()
    assert report["poor_fit"] == {"y": why} and "POOR FIT" in report["plant"]["notes"]


def test_a_good_open_loop_fit_is_not_flagged_and_is_within_10_percent():
    ident = identify(open_loop_trace(1, applied=False))
    assert ident.poor_fit == {} and poor_fits(ident.axes) == {}
    true = Plant("hsm2").params
    for j, f in enumerate(ident.axes):
        assert f.values["mass"] == pytest.approx(true.mass_kg[j], rel=0.1)
        assert f.values["viscous"] == pytest.approx(true.viscous_Ns_m[j], rel=0.1)
        assert f.values["coulomb"] == pytest.approx(true.coulomb_N[j], rel=0.1)
