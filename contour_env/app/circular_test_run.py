"""The circular test (ISO 230-4) with controllers named as ``contour-env compare`` names them:
the controllers are built here (the application imports ``agents``), the test itself is
:func:`contour_env.circular_test.run_circular_test`."""

from __future__ import annotations

from ..circular_test import (
    DEFAULT_FEED_M_S,
    DEFAULT_OVERSHOOT_DEG,
    DEFAULT_RADIUS_M,
    run_circular_test,
)

__all__ = ["check_controller_names", "circular_test", "controller_factories", "format_report"]


def check_controller_names(names, model=None) -> dict[str, str]:
    """The problems with the controller names (``pd``, ``ccc:wp=3e4``, ``residual`` …) and
    ``model`` (the residual agent's DIR): {"controllers": text, "model": text}, each key only
    when that one is bad, texts without a parameter name; {} when both are good."""
    from agents.compare import RESIDUAL, check_controllers

    errors = {}
    try:
        check_controllers(list(names))
    except ValueError as exc:
        text = str(exc)
        errors["controllers"] = (
            text[len("controllers: ") :] if text.startswith("controllers: ") else text
        )
    if model is not None and RESIDUAL not in [n.strip() for n in names]:
        errors["model"] = "DIR is the agent of the 'residual' controller; add residual"
    return errors


def controller_factories(names, model=None) -> dict:
    """label → ``factory(env)``: each name bound to the env it is given, as
    ``contour-env compare`` binds it (:func:`agents.compare.bound_controller`; ``residual``:
    the agent in ``model`` DIR or the shipped one for the plant). Each label is the name as
    typed."""
    from agents.compare import bound_controller, check_controllers

    specs = check_controllers(list(names)) if names else []  # each name parsed once, here
    return {
        spec.label: (lambda env, spec=spec: bound_controller(spec, env, model)) for spec in specs
    }


def circular_test(
    plant,
    controllers,
    radius_m: float = DEFAULT_RADIUS_M,
    feed_m_s: float = DEFAULT_FEED_M_S,
    *,
    overshoot_deg: float = DEFAULT_OVERSHOOT_DEG,
    model=None,
    **kwargs,
) -> dict:
    """:func:`contour_env.circular_test.run_circular_test` for controller names (a list, or
    one comma-separated string): ``plant`` (name or mapping), ``radius_m`` (m), ``feed_m_s``
    (m/s), ``overshoot_deg`` (degrees), ``model`` (the residual agent's DIR); the other keywords
    are passed on. ValueError naming every bad controller before anything runs."""
    if isinstance(controllers, str):
        controllers = [c.strip() for c in controllers.split(",") if c.strip()]
    names = list(controllers)
    errors = check_controller_names(names, model)
    if errors:
        raise ValueError("; ".join(f"{key}: {text}" for key, text in errors.items()))
    return run_circular_test(
        plant,
        controller_factories(names, model),
        radius_m,
        feed_m_s,
        overshoot_deg=overshoot_deg,
        **kwargs,
    )


def _num(value, fmt: str = ".2f") -> str:
    return "n/a" if value is None else format(value, fmt)


def format_report(result: dict) -> str:
    """The report as a text table: per controller and direction G, F_max, F_min and the
    reversal spikes (µm), and H (µm) per controller."""
    lines = [
        f"ISO 230-4 circular test: plant {result['plant']}, radius {result['radius_m']:g} m, "
        f"feed {result['feed_m_s']:g} m/s ({result['feed_m_s'] * 60:g} m/min), overshoot "
        f"{result['overshoot_deg']:g}° at each end, plane xy",
        f"{'controller':22s} {'dir':4s} {'G µm':>9s} {'F_max µm':>9s} {'F_min µm':>9s} "
        f"{'H µm':>9s}  reversal spikes µm (x 0°, y 90°, x 180°, y 270°)",
    ]
    for label, row in result["results"].items():
        for d in ("cw", "ccw"):
            r = row[d]
            if not r["completed"]:
                spikes = f"did not complete: {r.get('incomplete_reason')}"
            else:
                spikes = ", ".join(_num(s["height_um"]) for s in r["reversal_spikes_um"])
            hyst = _num(row["hysteresis_um"]) if d == "cw" else ""
            lines.append(
                f"{label[:22]:22s} {d:4s} {_num(r['circular_deviation_um']):>9s} "
                f"{_num(r['radial_deviation_max_um']):>9s} "
                f"{_num(r['radial_deviation_min_um']):>9s} {hyst:>9s}  {spikes}"
            )
    return "\n".join(lines)
