"""The margin-derived slope bound of ``rfnn:margin=1`` / ``fnn:margin=1`` (issue 38):
``agents.rfnn.MARGIN_KAPPA`` per plant.

The learnt network is a static map y(e, ė) at each sample; its slope adds stiffness and
damping to the PD loop along its task-frame direction. With the rule weights' spread Δw
bounded, |∂y/∂e| ≤ κ P_min and |∂y/∂ė| ≤ κ P_min / (3 α) (``agents.rfnn.spread_limit``). For
each plant and each κ of ``KAPPAS`` this script builds the PD loops with that linearisation at
its four sign corners — P ± κ P_min and D ± κ P_min / (3 α) on every axis — and computes their
margins with ``agents.margins.loop_margins`` (realistic plant, ±20 % mass corners, every path
direction). κ is admissible when every corner meets the project's requirement (≥ 6 dB,
≥ 30°, ``agents.margins.meets_requirement``); the table takes the largest admissible κ of the
grid, which is kept below 1 so that the network can never cancel the PD's stiffness. Printed:
per plant and κ the worst gain / phase margin over the corners, the chosen κ, the table's
value, and the spread bounds Δw_max of the default 4-rule ``fnn`` and ``rfnn`` (in the plant's
command unit: N, m/s on jee-triaxial's velocity-command drives). Exit status 1 when the table
differs from what is derived here::

    python scripts/rfnn_margin_bound.py
"""

from __future__ import annotations

import sys

import gymnasium as gym
import numpy as np

import contour_env  # noqa: F401  (registers the env)
from agents import make_controller
from agents.margins import loop_margins, meets_requirement
from agents.rfnn import MARGIN_KAPPA
from contour_env import ENV_ID

KAPPAS = (0.25, 0.5, 0.75)
PLANTS = ("hsm2", "linear-motor", "friction-table", "jee-triaxial")
LINE = "G21 G90 G17\nG01 X2 F600\n"  # any path: only the bound controller's gains are read


def corner_specs(plant: str, kappa: float) -> list[str]:
    """The ``pd:p=…:d=…`` specs of the four sign corners of the network's linearisation at
    slope bound κ on ``plant`` (gains of the default ``rfnn``'s PD loops)."""
    env = gym.make(ENV_ID, plant=plant, path=LINE)
    c = make_controller("rfnn").bind(env)
    P, D = np.asarray(c.P, float), np.asarray(c.D, float)
    dP = kappa * float(np.min(P))
    dD = dP / (3.0 * c.alpha)
    specs = []
    for sp in (1.0, -1.0):
        for sd in (1.0, -1.0):
            p = "/".join(f"{v:.9g}" for v in P + sp * dP)
            d = "/".join(f"{v:.9g}" for v in np.maximum(D + sd * dD, 0.0))
            specs.append(f"pd:p={p}:d={d}")
    return specs


def corners_meet(plant: str, kappa: float) -> tuple[bool, float, float]:
    """(every corner meets the requirement, worst gain margin dB, worst phase margin °)."""
    ok, gm, pm = True, np.inf, np.inf
    for spec in corner_specs(plant, kappa):
        rep = loop_margins(spec, plant)
        ok = ok and meets_requirement(rep)
        g, p = rep["min_gain_margin_db"], rep["min_phase_margin_deg"]
        gm = min(gm, np.inf if g is None else g)
        pm = min(pm, np.inf if p is None else p)
    return ok, gm, pm


def derive(plant: str) -> tuple[float, list[tuple]]:
    """(the largest admissible κ of KAPPAS, or 0; the rows (κ, ok, gm, pm))."""
    rows = [(k, *corners_meet(plant, k)) for k in KAPPAS]
    ok = [k for k, good, _, _ in rows if good and k < 1.0]
    return (max(ok) if ok else 0.0), rows


def main() -> int:
    differs = False
    for plant in PLANTS:
        kappa, rows = derive(plant)
        env = gym.make(ENV_ID, plant=plant, path=LINE)
        spreads = []
        for name in ("fnn", "rfnn"):
            c = make_controller(f"{name}:margin=1").bind(env)
            spreads.append(f"{name} Δw_max {c.spread_max_N:.4g}")
        for k, good, gm, pm in rows:
            print(f"{plant:<15} κ {k:<5g} corners {'meet' if good else 'miss'} 6 dB / 30°: "
                  f"worst {gm:.2f} dB / {pm:.1f}°")  # fmt: skip
        table = MARGIN_KAPPA.get(plant)
        same = table == kappa
        differs |= not same
        print(f"{plant:<15} derived κ = {kappa:g}, MARGIN_KAPPA = {table}"
              f"{'' if same else '  (DIFFERS)'}; with the table: {', '.join(spreads)}")  # fmt: skip
    return 1 if differs else 0


if __name__ == "__main__":
    sys.exit(main())
