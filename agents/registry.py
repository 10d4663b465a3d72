"""Controller names users script against, and their variants ``name:key=value:...``.

``make_controller("ccc:wp=3e4:wd=20")`` builds a CCC with W_p = 3·10⁴ 1/s² and W_d = 20 1/s:
the parameters after the name are the short names of the class's ``PARAMETERS`` table
(:mod:`agents.parameters`; ``contour-env controllers`` prints every table). The string is
read once, by :func:`parse_spec`, into a :class:`~agents.parameters.ControllerSpec` that every
function here and in :mod:`agents.compare` takes instead of the string.
"""

from __future__ import annotations

import copy

from contour_env.env.core import core_of

from .adaptive_ccc import AdaptiveCCCController
from .ccc import CCCController
from .five_axis_controllers import FiveAxisPDController, FiveAxisPIDController, ISMCController
from .ilc import ILCContourController, ILCPDController
from .jee_ccc import JeeCCCController
from .parameters import ControllerSpec, describe_parameters, spec_kwargs, split_spec
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
# PD with the paper's gains (``make_controller(name, plant_family="five-axis")`` or
# ``make_controller(name, env=five_axis_env)``; the feed-drive ``pd`` bound to a five-axis
# env is a ValueError naming that fix); ``pid`` (the tuned joint PID baseline) and
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


def learns_between_trials(spec: str | ControllerSpec) -> bool:
    """Whether a repeated batch of ``spec`` improves from trial to trial: a learning controller
    (:data:`LEARNING_CONTROLLERS`), or an online learner that keeps its network across
    episodes (``rfnn:keep=1``, ``fnn:keep=1``). ``spec``: a string or its
    :class:`ControllerSpec` (:func:`parse_spec`)."""
    spec = parse_spec(spec)
    return spec.name in LEARNING_CONTROLLERS or (
        spec.name in KEEPING_CONTROLLERS and bool(spec.keywords.get("keep", False))
    )


def controller_names() -> list[str]:
    return list(CONTROLLERS)


def spec_name(spec: str | ControllerSpec) -> str:
    """The controller name of a spec (``"ccc:wp=3e4"`` → ``"ccc"``); ``ValueError`` if the
    spec is malformed or names no controller (:func:`parse_spec`)."""
    return parse_spec(spec).name


def parse_controller_spec(spec: str | ControllerSpec) -> tuple[str, dict]:
    """``(name, constructor keywords)`` of a spec such as ``"ccc:wp=3e4:wd=20"``
    (:func:`parse_spec`'s record as a pair).

    ``ValueError`` for an unknown controller (the message lists the known ones), an unknown
    parameter (the message lists the controller's parameters with their descriptions) or a
    malformed one (``ccc:``, ``ccc:wp``, ``ccc:wp=abc``, ``ccc:wp=nan``)."""
    spec = parse_spec(spec)
    return spec.name, dict(spec.keywords)


def parse_spec(
    spec: str | ControllerSpec,
    plant_family: str | None = None,
    *,
    agent_names: tuple[str, ...] = (),
    parameter: str = "controller",
) -> ControllerSpec:
    """The one reader of a controller spec ``name[:key=value ...]`` (:mod:`agents.parameters`):
    the :class:`ControllerSpec` every other function takes (``"ccc:wp=3e4"`` → name ``"ccc"``,
    keywords ``{"W_p": 30000.0}``, label ``"ccc:wp=3e4"``).

    ``plant_family``: None resolves the name among the feed-drive controllers, then the
    five-axis-only ones (``pid``, ``ismc``); ``"five-axis"`` among
    :data:`FIVE_AXIS_CONTROLLERS` (``pd`` is then Chen 2022's joint PD). A record is returned
    unchanged when ``plant_family`` is None or its own; for another family it is resolved
    again from its ``key=value`` pairs (the string is not read again). ``agent_names``: names
    that are not controllers of this registry (``compare``'s ``residual``, a trained agent),
    accepted without parameters (``keywords`` empty). ``parameter``: the name that starts an
    unknown-controller error (``controllers`` for :func:`agents.compare.check_controllers`).

    ``ValueError`` for a malformed spec, an unknown controller (the message lists the known
    ones), a name the five-axis plant does not have, or an unknown or bad parameter (the
    message lists the controller's parameters with their descriptions and units)."""
    if isinstance(spec, ControllerSpec):
        if plant_family is None or plant_family == spec.family:
            return spec
        name, pairs, label = spec.name, spec.parameters, spec.label
    else:
        name, pairs = split_spec(spec)
        label = spec
    if name in agent_names and name not in CONTROLLERS and name not in FIVE_AXIS_CONTROLLERS:
        if pairs:
            raise ValueError(
                f"controller {label!r}: {name} takes no parameters (its agent comes from "
                "--model DIR / model=)"
            )
        return ControllerSpec(name, {}, label, None, ())
    if plant_family == "five-axis":
        if name not in FIVE_AXIS_CONTROLLERS:
            raise ValueError(
                f"controller {name!r}: not available on the five-axis plant; known there: "
                f"{', '.join(FIVE_AXIS_CONTROLLERS)}"
            )
    elif name not in CONTROLLERS and name not in FIVE_AXIS_CONTROLLERS:
        known = [*all_controller_names(), *agent_names]
        raise ValueError(f"{parameter}: unknown controller {name!r}; known: {', '.join(known)}")
    family = "five-axis" if plant_family == "five-axis" else None
    keywords = spec_kwargs(label, _class_for(name, family), list(pairs))
    return ControllerSpec(name, keywords, label, family, tuple(pairs))


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


def _class_for(name: str, family: str | None):
    """The class of ``name`` for the plant family a :class:`ControllerSpec` was resolved for."""
    if family == "five-axis":
        return FIVE_AXIS_CONTROLLERS[name]
    return _class_of(name)


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


def make_controller(
    name: str | ControllerSpec, *, plant_family: str | None = None, env=None, **kwargs
):
    """A controller by name or variant spec (unbound; call ``.bind(env)``).

    ``make_controller("ccc:wp=3e4:wd=20")`` and ``make_controller("ccc", W_p=3e4, W_d=20)``
    are the same controller; a keyword given both ways is a ``ValueError``. ``name``: the
    string, or the :class:`ControllerSpec` :func:`parse_spec` made of it (not read again).
    ``plant_family="five-axis"``: the five-axis class of the name
    (:data:`FIVE_AXIS_CONTROLLERS`: ``pd`` is then Chen 2022's joint PD); a name with none is
    a ``ValueError``. ``env``: take the family from that env (:func:`plant_family_of`).

    :meth:`Controller.bind` binds the class built here or refuses: a feed-drive controller
    built without the family and bound to a five-axis env is a ``ValueError`` naming this
    call with ``env=env`` as the fix."""
    if env is not None:
        family = plant_family_of(env)
        if plant_family is not None and plant_family != family:
            raise ValueError(
                f"plant_family: {plant_family!r} given, but the env's plant family is {family!r}"
            )
        plant_family = family
    spec = parse_spec(name, plant_family)
    ctrl = _make(spec, kwargs)
    ctrl._spec, ctrl._spec_kwargs = spec, dict(kwargs)  # five_axis_counterpart, bind's errors
    return ctrl


def five_axis_counterpart(controller):
    """The five-axis controller (unbound) of the spec ``controller`` was built from by
    :func:`make_controller` (its :class:`ControllerSpec` resolved for ``"five-axis"``);
    ``ValueError`` where the name has none or the controller was built directly."""
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
    kwargs = getattr(controller, "_spec_kwargs", {})
    return make_controller(spec, plant_family="five-axis", **kwargs)


def _make(spec: ControllerSpec, kwargs: dict):
    """The controller of a parsed ``spec`` with the extra constructor ``kwargs``."""
    both = sorted(set(spec.keywords) & set(kwargs))
    if both:
        raise ValueError(
            f"controller {spec.label!r}: {', '.join(both)} given both in the spec and as a keyword"
        )
    cls = _class_for(spec.name, spec.family)
    if not spec.keywords:
        return cls(**kwargs)
    try:  # fresh copies: a per-axis list of the record is not handed to the controller
        return cls(**copy.deepcopy(dict(spec.keywords)), **kwargs)
    except ValueError as exc:
        raise ValueError(f"controller {spec.label!r}: {exc}") from None
