"""Controller names users script against, and their variants ``name:key=value:...``.

``make_controller("ccc:wp=3e4:wd=20")`` builds a CCC with W_p = 3·10⁴ 1/s² and W_d = 20 1/s:
the parameters after the name are the short names of the class's ``PARAMETERS`` table
(:mod:`agents.parameters`; ``contour-env controllers`` prints every table).
"""

from __future__ import annotations

import functools

from contour_env.env.core import core_of

from .adaptive_ccc import AdaptiveCCCController
from .ccc import CCCController
from .five_axis_controllers import FiveAxisPDController, FiveAxisPIDController, ISMCController
from .ilc import ILCContourController, ILCPDController
from .jee_ccc import JeeCCCController
from .parameters import describe_parameters, spec_kwargs, split_spec
from .pd import PDController
from .rfnn import FNNController, RFNNController
from .vilcfd import VILCFDController

CONTROLLERS = {
    "pd": PDController,
    "ccc": CCCController,
    "adaptive-ccc": AdaptiveCCCController,
    "jee-ccc": JeeCCCController,
    "ilc-pd": ILCPDController,
    "ilc-contour": ILCContourController,
    "vilcfd": VILCFDController,
    "rfnn": RFNNController,
    "fnn": FNNController,
}

# the five-axis plant's controllers, a family of their own: ``pd`` there is Chen 2022's joint
# PD with the paper's gains (``make_controller(name, plant_family="five-axis")``, or the
# feed-drive ``pd`` bound to a five-axis env); ``pid`` (the tuned joint PID baseline) and
# ``ismc`` exist only there (``make_controller("pid")`` builds it; binding it to a feed-drive
# env is a ValueError naming the plant it needs). Kept apart from CONTROLLERS, whose every
# entry runs on every feed-drive plant.
FIVE_AXIS_CONTROLLERS = {
    "pd": FiveAxisPDController,
    "ismc": ISMCController,
    "pid": FiveAxisPIDController,
}

# controllers that learn between trials of a repeated batch (``contour-env ilc``)
LEARNING_CONTROLLERS = ("ilc-pd", "ilc-contour", "vilcfd")
# controllers that learn within a trial and, with ``keep=1``, carry it to the next trial
KEEPING_CONTROLLERS = ("rfnn", "fnn")


def learns_between_trials(spec: str) -> bool:
    """Whether a repeated batch of ``spec`` improves from trial to trial: a learning controller
    (:data:`LEARNING_CONTROLLERS`), or an online learner that keeps its network across
    episodes (``rfnn:keep=1``, ``fnn:keep=1``)."""
    name, kwargs = parse_controller_spec(spec)
    return name in LEARNING_CONTROLLERS or (
        name in KEEPING_CONTROLLERS and bool(kwargs.get("keep", False))
    )


def controller_names() -> list[str]:
    return list(CONTROLLERS)


def spec_name(spec: str) -> str:
    """The controller name of a spec (``"ccc:wp=3e4"`` → ``"ccc"``); ``ValueError`` if the
    spec is malformed."""
    return split_spec(spec)[0]


def parse_controller_spec(spec: str) -> tuple[str, dict]:
    """``(name, constructor keywords)`` of a spec such as ``"ccc:wp=3e4:wd=20"``.

    ``ValueError`` for an unknown controller (the message lists the known ones), an unknown
    parameter (the message lists the controller's parameters with their descriptions) or a
    malformed one (``ccc:``, ``ccc:wp``, ``ccc:wp=abc``, ``ccc:wp=nan``)."""
    name, pairs = split_spec(spec)
    cls = _class_of(name)
    return name, spec_kwargs(spec, cls, pairs)


def all_controller_names() -> list[str]:
    """Every controller name: the feed-drive ones, then those only on the five-axis plant."""
    return [*CONTROLLERS, *(n for n in FIVE_AXIS_CONTROLLERS if n not in CONTROLLERS)]


def _class_of(name: str):
    cls = CONTROLLERS.get(name, FIVE_AXIS_CONTROLLERS.get(name))
    if cls is None:
        raise ValueError(
            f"controller: unknown controller {name!r}; known: {', '.join(all_controller_names())}"
        )
    return cls


def controller_parameters(name: str) -> dict:
    """The ``PARAMETERS`` table of a controller name: short name → :class:`Param`."""
    return dict(getattr(_class_of(name), "PARAMETERS", {}))


def format_controllers() -> str:
    """Every controller with its command-line parameters (``contour-env controllers``)."""
    lines = [
        "controller variants: NAME[:key=value[:key=value ...]], e.g. ccc:wp=3e4:wd=20; per-axis "
        "values as a/b(/c), e.g. pd:p=2e6/1e6",
    ]
    for name, cls in CONTROLLERS.items():
        learning = (
            "  (learning controller: contour-env ilc)" if name in LEARNING_CONTROLLERS else ""
        )
        if name in KEEPING_CONTROLLERS:
            learning = "  (learns online; with keep=1 across trials: contour-env ilc)"
        lines.append("")
        lines.append(f"{name}{learning}")
        lines.append(describe_parameters(name, getattr(cls, "PARAMETERS", {})))
    for name, cls in FIVE_AXIS_CONTROLLERS.items():
        lines.append("")
        lines.append(f"{name}  (five-axis plant: {cls.summary})")
        lines.append(describe_parameters(name, getattr(cls, "PARAMETERS", {})))
    return "\n".join(lines)


def plant_family_of(env) -> str | None:
    """The plant family of a contour_env env (single, wrapped or vectorised): ``"five-axis"``
    for the five-axis machine, None for the feed-drive plants."""
    return getattr(core_of(env)[1].setup, "family", None)


def make_controller(name: str, *, plant_family: str | None = None, env=None, **kwargs):
    """A controller by name or variant spec (unbound; call ``.bind(env)``).

    ``make_controller("ccc:wp=3e4:wd=20")`` and ``make_controller("ccc", W_p=3e4, W_d=20)``
    are the same controller; a keyword given both ways is a ``ValueError``.
    ``plant_family="five-axis"``: the five-axis class of the name
    (:data:`FIVE_AXIS_CONTROLLERS`: ``pd`` is then Chen 2022's joint PD); a name with none is
    a ``ValueError``. ``env``: take the family from that env (:func:`plant_family_of`).

    A feed-drive controller built without the family and bound to a five-axis env still works:
    :meth:`Controller.bind` builds the five-axis class of the same spec and forwards to it
    (``make_controller("pd").bind(five_axis_env)`` runs Chen 2022's joint PD)."""
    if env is not None:
        family = plant_family_of(env)
        if plant_family is not None and plant_family != family:
            raise ValueError(
                f"plant_family: {plant_family!r} given, but the env's plant family is {family!r}"
            )
        plant_family = family
    ctrl = _make(name, plant_family, kwargs)
    ctrl._spec = (name, dict(kwargs))
    # Controller.bind builds the five-axis class of this spec through it on a five-axis env
    ctrl._five_axis_factory = functools.partial(five_axis_counterpart, ctrl)
    return ctrl


def five_axis_counterpart(controller):
    """The five-axis controller (unbound) of the spec ``controller`` was built from by
    :func:`make_controller`; ``ValueError`` where the name has none or the spec is unknown."""
    name = controller.name
    if name not in FIVE_AXIS_CONTROLLERS:
        raise ValueError(
            f"controller {name!r}: not available on the five-axis plant; known there: "
            f"{', '.join(FIVE_AXIS_CONTROLLERS)}"
        )
    spec = getattr(controller, "_spec", None)
    if spec is None:
        raise ValueError(
            f"controller {name!r} ({type(controller).__name__}, built directly) is a feed-drive "
            "controller; for the five-axis plant build it with "
            f"agents.make_controller({name!r}, plant_family='five-axis')"
        )
    spec_text, kwargs = spec
    return make_controller(spec_text, plant_family="five-axis", **kwargs)


def _make(name: str, plant_family, kwargs):
    if plant_family == "five-axis":
        base, _ = split_spec(name)
        if base not in FIVE_AXIS_CONTROLLERS:
            raise ValueError(
                f"controller {base!r}: not available on the five-axis plant; known there: "
                f"{', '.join(FIVE_AXIS_CONTROLLERS)}"
            )
        cls = FIVE_AXIS_CONTROLLERS[base]
        spec_kw = spec_kwargs(name, cls, split_spec(name)[1])
        both = sorted(set(spec_kw) & set(kwargs))
        if both:
            raise ValueError(
                f"controller {name!r}: {', '.join(both)} given both in the spec and as a keyword"
            )
        return cls(**spec_kw, **kwargs)
    base, spec_kw = parse_controller_spec(name)
    both = sorted(set(spec_kw) & set(kwargs))
    if both:
        raise ValueError(
            f"controller {name!r}: {', '.join(both)} given both in the spec and as a keyword"
        )
    cls = _class_of(base)
    if not spec_kw:
        return cls(**kwargs)
    try:
        return cls(**spec_kw, **kwargs)
    except ValueError as exc:
        raise ValueError(f"controller {name!r}: {exc}") from None
