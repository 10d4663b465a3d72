"""Controller names users script against."""

from __future__ import annotations

from .adaptive_ccc import AdaptiveCCCController
from .ccc import CCCController
from .ilc import ILCContourController, ILCPDController
from .jee_ccc import JeeCCCController
from .pd import PDController
from .vilcfd import VILCFDController

CONTROLLERS = {
    "pd": PDController,
    "ccc": CCCController,
    "adaptive-ccc": AdaptiveCCCController,
    "jee-ccc": JeeCCCController,
    "ilc-pd": ILCPDController,
    "ilc-contour": ILCContourController,
    "vilcfd": VILCFDController,
}

# controllers that learn between trials of a repeated batch (``contour-env ilc``)
LEARNING_CONTROLLERS = ("ilc-pd", "ilc-contour", "vilcfd")


def controller_names() -> list[str]:
    return list(CONTROLLERS)


def make_controller(name: str, **kwargs):
    """A controller by name (unbound; call ``.bind(env)``)."""
    if name not in CONTROLLERS:
        raise ValueError(
            f"controller: unknown controller {name!r}; known: {', '.join(CONTROLLERS)}"
        )
    return CONTROLLERS[name](**kwargs)
