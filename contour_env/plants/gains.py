"""Controller gains a plant carries: ``controller_gains`` in a plant file or mapping.

The named plants' default gains live with their controllers (``agents/pd.py:
DEFAULT_BANDWIDTH_RAD_S``, ``agents/ccc.py: DEFAULT_GAINS``), tuned by
``scripts/tune_controllers.py``. A plant of your own (the file ``contour-env identify``
writes) has none until ``contour-env tune`` searches them under the same margin constraints
and writes them into the file::

    "controller_gains": {"pd": {"bandwidth_rad_s": 80.0},
                         "ccc": {"W_p": 3000.0, "W_i": 300000.0, "W_d": 0.0}}

The controllers read them as their defaults on that plant (an explicit ``pd:w=…`` or
``ccc:wp=…`` still wins). Units: ω in rad/s; W_p 1/s², W_i 1/s³, W_d 1/s per unit nominal
axis mass (agents.ccc).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

__all__ = ["TUNABLE_GAINS", "check_controller_gains", "tuned_gain"]

# controller → (gain, smallest allowed value is > 0 (True) or >= 0 (False))
TUNABLE_GAINS = {
    "pd": {"bandwidth_rad_s": True},
    "ccc": {"W_p": False, "W_i": False, "W_d": False},
}


def check_controller_gains(gains) -> dict:
    """``gains`` as a plain ``{controller: {gain: float}}``; ValueError with one line naming
    the controller or gain and the allowed ones otherwise."""
    if gains is None:
        return {}
    if not isinstance(gains, Mapping):
        raise ValueError(
            "controller_gains: a mapping of controller → {gain: value} such as "
            f'{{"pd": {{"bandwidth_rad_s": 80}}}}, got {type(gains).__name__}'
        )
    out: dict = {}
    for ctrl, values in gains.items():
        if ctrl not in TUNABLE_GAINS:
            raise ValueError(
                f"controller_gains: unknown controller {ctrl!r}; allowed: "
                f"{', '.join(TUNABLE_GAINS)}"
            )
        allowed = TUNABLE_GAINS[ctrl]
        if not isinstance(values, Mapping):
            raise ValueError(
                f"controller_gains.{ctrl}: a mapping of gain → value ({', '.join(allowed)}), "
                f"got {type(values).__name__}"
            )
        out[ctrl] = {}
        for key, value in values.items():
            if key not in allowed:
                raise ValueError(
                    f"controller_gains.{ctrl}: unknown gain {key!r}; allowed: {', '.join(allowed)}"
                )
            positive = allowed[key]
            ok = isinstance(value, (int, float)) and not isinstance(value, bool)
            ok = ok and math.isfinite(value) and (value > 0 if positive else value >= 0)
            if not ok:
                raise ValueError(
                    f"controller_gains.{ctrl}.{key}: must be a finite number "
                    f"{'> 0' if positive else '>= 0'}, got {value!r}"
                )
            out[ctrl][key] = float(value)
    return out


def tuned_gain(params, controller: str, key: str):
    """The gain ``key`` of ``controller`` that the plant parameters ``params`` carry, or None."""
    gains = getattr(params, "controller_gains", None) or {}
    return gains.get(controller, {}).get(key)
