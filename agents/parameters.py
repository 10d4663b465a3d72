"""Controller variants written as one string: ``name[:key=value[:key=value ...]]``.

Every controller class declares the parameters users may set this way in a public class
attribute ``PARAMETERS``: a mapping from the short lower-case name users type to a
:class:`Param` (the constructor keyword, a one-line description with units, the value kind
and an optional range check). Subclasses extend their parent's table (``{**Parent.PARAMETERS,
...}``). Examples::

    pd:w=80                 PD with ω = 80 rad/s
    ccc:wp=3e4:wd=20        CCC with W_p = 3·10⁴ 1/s², W_d = 20 1/s
    adaptive-ccc:gamma=0    Lee's adaptive CCC with the adaptation switched off
    pd:p=2e6/1e6            per-axis values separated by "/" (x/y(/z))
    vilcfd:dob=0:friction=false

Values are numbers (``3e4``, ``0.5``), integers where the constructor needs one, ``true`` /
``false`` (or ``1`` / ``0``) for switches, and ``a/b(/c)`` for per-axis values; NaN and
infinities are refused. A class may define ``adapt_parameters(kwargs) -> kwargs`` (a
classmethod) to turn parsed values into its constructor's keywords (``adaptive-ccc``'s
``gamma``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import NamedTuple

# the value kinds of a parameter
FLOAT, INT, BOOL, AXES = "float", "int", "bool", "axes"
_KIND_TEXT = {
    FLOAT: "a number",
    INT: "an integer",
    BOOL: "true or false (1 or 0)",
    AXES: "a number",
}
_CHECK_TEXT = {"": "", ">0": "> 0", ">=0": ">= 0"}
_TRUE, _FALSE = ("true", "1"), ("false", "0")


class Param(NamedTuple):
    """One command-line parameter of a controller."""

    keyword: str  # the constructor keyword it sets
    description: str  # one line, with units
    kind: str = FLOAT  # FLOAT, INT, BOOL or AXES (a scalar or one value per axis)
    check: str = ""  # "", ">0" or ">=0": the range the value must lie in

    def allowed(self) -> str:
        """What a value may be, in words."""
        text = _KIND_TEXT[self.kind]
        if self.check:
            text += f" {_CHECK_TEXT[self.check]}"
        if self.kind == AXES:
            text += ", or one per axis as x/y(/z)"
        return text


@dataclass(frozen=True)
class ControllerSpec:
    """A controller spec parsed once (:func:`agents.registry.parse_spec`, the one function that
    reads the string); everything after the parse takes this record.

    ``name``: the controller name (``"ccc"``). ``keywords``: the constructor keywords of the
    spec's parameters (``{"W_p": 3e4}``, read-only), already checked against the class's
    :attr:`PARAMETERS` table and its ``adapt_parameters``. ``label``: the string as the user
    wrote it (a row's name in ``contour-env compare``, and what error messages quote).
    ``family``: the plant family the class was resolved for (None: the feed-drive class of the
    name, or its only class; ``"five-axis"``: :data:`agents.registry.FIVE_AXIS_CONTROLLERS`).
    ``parameters``: the ``key=value`` pairs as typed, so the record can be resolved for another
    plant family without reading the string again."""

    name: str
    keywords: Mapping[str, object] = field(default_factory=dict)
    label: str = ""
    family: str | None = None
    parameters: tuple[tuple[str, str], ...] = ()

    def __post_init__(self):
        object.__setattr__(self, "keywords", MappingProxyType(dict(self.keywords)))
        object.__setattr__(self, "label", self.label or self.name)
        object.__setattr__(self, "parameters", tuple(tuple(p) for p in self.parameters))

    def __hash__(self):  # the keywords follow from name, family and parameters
        return hash((self.name, self.label, self.family, self.parameters))

    def __reduce__(self):  # a read-only mapping does not pickle; its dict does
        return (
            ControllerSpec,
            (self.name, dict(self.keywords), self.label, self.family, self.parameters),
        )


def split_spec(spec: str) -> tuple[str, list[tuple[str, str]]]:
    """``"ccc:wp=3e4:wd=20"`` → ``("ccc", [("wp", "3e4"), ("wd", "20")])``; ``ValueError`` for
    a malformed spec (empty name, empty part, a part without ``=``, a key given twice).

    The tokenizer of :func:`agents.registry.parse_spec`, its only caller: code that needs a
    spec's parts takes the :class:`ControllerSpec` that function returns."""
    if not isinstance(spec, str):
        raise ValueError(f"controller: expected a name such as 'ccc' or 'ccc:wp=3e4', got {spec!r}")
    name, *parts = [p.strip() for p in spec.split(":")]
    if not name:
        raise ValueError(
            f"controller {spec!r}: no controller name before ':' (write e.g. 'ccc:wp=3e4')"
        )
    pairs: list[tuple[str, str]] = []
    for part in parts:
        key, eq, value = (s.strip() for s in part.partition("="))
        if not part:
            raise ValueError(
                f"controller {spec!r}: empty parameter after ':'; write {name}:key=value "
                f"(`contour-env controllers` lists the parameters)"
            )
        if not eq or not key:
            raise ValueError(
                f"controller {spec!r}: parameter {part!r} is not key=value (e.g. {name}:"
                f"{key or 'key'}=1.5)"
            )
        if not value:
            raise ValueError(f"controller {spec!r}: parameter {key!r} has no value ({key}=...)")
        if any(key == k for k, _ in pairs):
            raise ValueError(f"controller {spec!r}: parameter {key!r} given twice")
        pairs.append((key, value))
    return name, pairs


def _number(text: str) -> float:
    v = float(text)  # ValueError for anything that is not a number
    if not math.isfinite(v):
        raise ValueError("not finite")
    return v


def parse_value(spec: str, key: str, param: Param, text: str):
    """The value of ``key=text`` as ``param`` needs it; ``ValueError`` naming the parameter and
    what it allows."""
    try:
        if param.kind == BOOL:
            low = text.lower()
            if low not in _TRUE + _FALSE:
                raise ValueError(text)
            return low in _TRUE
        if param.kind == INT:
            value = int(text)
            values = [value]
        elif param.kind == AXES and "/" in text:
            value = [_number(t.strip()) for t in text.split("/")]
            values = value
        else:
            value = _number(text)
            values = [value]
    except ValueError:
        raise ValueError(
            f"controller {spec!r}: {key} must be {param.allowed()}, got {text!r} ({key}: "
            f"{param.description})"
        ) from None
    if (param.check == ">0" and any(v <= 0 for v in values)) or (
        param.check == ">=0" and any(v < 0 for v in values)
    ):
        raise ValueError(
            f"controller {spec!r}: {key} must be {param.allowed()}, got {text!r} ({key}: "
            f"{param.description})"
        )
    return value


def describe_parameters(name: str, table: dict[str, Param], indent: str = "  ") -> str:
    """One line per parameter: ``key  description  [what it allows]``."""
    if not table:
        return f"{indent}(no parameters)"
    width = max(len(k) for k in table) + 2
    return "\n".join(
        f"{indent}{key:{width}s}{p.description}  [{p.allowed()}]" for key, p in table.items()
    )


def spec_kwargs(spec: str, cls, pairs: list[tuple[str, str]]) -> dict:
    """Constructor keywords of ``cls`` from the parsed ``key=value`` pairs of ``spec``."""
    table = getattr(cls, "PARAMETERS", {})
    name = getattr(cls, "name", spec)
    kwargs: dict = {}
    for key, text in pairs:
        if key not in table:
            raise ValueError(
                f"controller {spec!r}: unknown parameter {key!r} of {name!r}; its parameters:\n"
                f"{describe_parameters(name, table)}"
            )
        param = table[key]
        kwargs[param.keyword] = parse_value(spec, key, param, text)
    adapt = getattr(cls, "adapt_parameters", None)
    if adapt is not None and kwargs:
        try:
            kwargs = adapt(dict(kwargs))
        except ValueError as exc:
            raise ValueError(f"controller {spec!r}: {exc}") from None
    return kwargs


__all__ = [
    "AXES",
    "BOOL",
    "ControllerSpec",
    "FLOAT",
    "INT",
    "Param",
    "describe_parameters",
    "parse_value",
    "spec_kwargs",
    "split_spec",
]
