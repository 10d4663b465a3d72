"""Print the README's table of default gains and their loop margins (generated, not typed).

For every named plant and every controller that applies to it: the default gains as the
controller computes them for that plant, and the worst gain/phase margin of its loops on the
realistic plant over the ±20 % mass corners (agents.margins), and with the two-mass mode
where the plant has one.

Usage: ``python scripts/controller_table.py`` (markdown on stdout; about a minute).
"""

from __future__ import annotations

import sys

import numpy as np

from agents import make_controller
from agents.margins import loop_margins, meets_requirement
from contour_env.plants import Plant
from contour_env.plants.catalog import nominal_params, plant_names

CONTROLLERS = ("pd", "ccc", "adaptive-ccc", "jee-ccc")


def _num(v) -> str:
    arr = np.atleast_1d(np.asarray(v, dtype=float))
    return " / ".join(f"{x:.4g}" for x in arr)


def gains_text(name: str, c) -> str:
    velocity_command = c.nominal.input_kind == "velocity-command"
    pu, du = ("1", "s") if velocity_command else ("N/m", "N s/m")
    if name == "pd":
        return (
            f"ω = {c.omega:g} rad/s, ζ = {c.damping:g} (P = {_num(c.P)} {pu}, D = {_num(c.D)} {du})"
        )
    if name == "ccc":
        return (
            f"PD's ω = {c.omega:g} rad/s; W_p = {c.W_p:g} 1/s², W_i = {c.W_i:g} 1/s³, "
            f"W_d = {c.W_d:g} 1/s"
        )
    if name == "adaptive-ccc":
        same = np.allclose(c.coupling, c.k)
        return (
            f"PD's P and D (k = {_num(c.k)} {du}, α = {_num(c.alpha)} 1/s); coupling c "
            f"{'= k' if same else '= ' + _num(c.coupling)}; Γ from τ_a = {c.tau_a_s:g} s"
        )
    if name == "jee-ccc":
        return f"K_P = {_num(c.K_P)}, C_P = {c.C_P:g}, C_I = {c.C_I:g} 1/s, C_D = {c.C_D:g} s"
    return ""


def _margins(rep: dict) -> str:
    if not rep["stable"]:
        return "unstable"
    gm, pm = rep["min_gain_margin_db"], rep["min_phase_margin_deg"]
    text = f"{'∞' if gm is None else f'{gm:.1f}'} dB / {'∞' if pm is None else f'{pm:.0f}'}°"
    return text if meets_requirement(rep) else f"**{text}** (below the requirement)"


def rows() -> list[str]:
    out = [
        "| plant | controller | default gains | margins, realistic ±20 % "
        "| margins, structural mode |",
        "|---|---|---|---|---|",
    ]
    for plant_name in plant_names():
        plant = Plant(plant_name)
        has_mode = bool(nominal_params(plant_name)[1].structural_mode_hz)
        for name in CONTROLLERS:
            try:
                c = make_controller(name).configure_for(plant)
            except ValueError:
                continue  # not applicable (jee-ccc needs a velocity-command drive)
            real = _margins(loop_margins(name, plant_name))
            modal = (
                _margins(loop_margins(name, plant_name, structural_mode=True))
                if has_mode
                else "(no mode)"
            )
            out.append(f"| `{plant_name}` | `{name}` | {gains_text(name, c)} | {real} | {modal} |")
    return out


def main() -> int:
    print("\n".join(rows()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
