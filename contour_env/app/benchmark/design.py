"""The ``design`` run of a suite: one controller's default gains on one named plant and the
margins of its loops (what the README's controller table shows; ``scripts/controller_table.py``
prints it).

For the plant and controller of the spec (``case`` is the plant's name: a design run has no
path): the default gains as the controller computes them for that plant, and the worst
gain/phase margin of its loops on the realistic plant over the ±20 % mass corners
(:func:`agents.margins.loop_margins`), and with the two-mass mode where the plant has one.
"""

from __future__ import annotations

from functools import cache

import numpy as np

# the controllers whose default gains and margins the table gives, in table order
CONTROLLERS = ("pd", "ccc", "adaptive-ccc", "jee-ccc")


def _num(v) -> str:
    arr = np.atleast_1d(np.asarray(v, dtype=float))
    return " / ".join(f"{x:.4g}" for x in arr)


def gains_text(name: str, c) -> str:
    """The default gains of the configured controller ``c`` (named ``name``), in words."""
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


def _configured(name: str, plant_name: str):
    from agents import make_controller
    from contour_env.plants import Plant

    return make_controller(name).configure_for(Plant(plant_name))


@cache
def applies(plant_name: str, name: str) -> bool:
    """Whether controller ``name`` configures for the named plant (jee-ccc needs a
    velocity-command drive)."""
    try:
        _configured(name, plant_name)
    except ValueError:
        return False
    return True


def _report(rep: dict) -> dict:
    """The figures of a :func:`agents.margins.loop_margins` report the table needs."""
    from agents.margins import meets_requirement

    return {
        "stable": bool(rep["stable"]),
        "min_gain_margin_db": rep["min_gain_margin_db"],
        "min_phase_margin_deg": rep["min_phase_margin_deg"],
        "meets_requirement": meets_requirement(rep),
    }


def design(plant_name: str, name: str, mass_variation: float = 0.2) -> dict:
    """The metrics of a design run: ``gains`` (text), ``margins`` (realistic plant, over the
    ±``mass_variation`` mass corners) and ``structural_mode_margins`` (the same with the
    two-mass mode; None where the plant has none), each ``{stable, min_gain_margin_db,
    min_phase_margin_deg, meets_requirement}``."""
    from agents.margins import loop_margins
    from contour_env.plants.catalog import nominal_params

    c = _configured(name, plant_name)
    has_mode = bool(nominal_params(plant_name)[1].structural_mode_hz)
    kw = {"mass_variation": mass_variation}
    return {
        "gains": gains_text(name, c),
        "margins": _report(loop_margins(name, plant_name, **kw)),
        "structural_mode_margins": (
            _report(loop_margins(name, plant_name, structural_mode=True, **kw))
            if has_mode
            else None
        ),
    }


def margins_text(rep: dict | None) -> str:
    """A margins cell: ``GM dB / PM°``, bold with a note below the requirement."""
    if rep is None:
        return "(no mode)"
    if not rep["stable"]:
        return "unstable"
    gm, pm = rep["min_gain_margin_db"], rep["min_phase_margin_deg"]
    text = f"{'∞' if gm is None else f'{gm:.1f}'} dB / {'∞' if pm is None else f'{pm:.0f}'}°"
    return text if rep["meets_requirement"] else f"**{text}** (below the requirement)"
