"""Controllers used as policies: every controller (and later every trained agent) is reset at
the start of an episode and acts through stable-baselines3's ``predict`` signature.

The names below load on first use (PEP 562), so a light submodule such as
:mod:`agents.algos` imports without the controllers and their kernels (the CLI starts on it)."""

from __future__ import annotations

__all__ = [
    "CONTROLLERS",
    "Controller",
    "ControllerSpec",
    "controller_names",
    "make_controller",
    "parse_spec",
]


def __getattr__(name: str):
    if name == "Controller":
        from .base import Controller

        return Controller
    if name in (
        "CONTROLLERS",
        "ControllerSpec",
        "controller_names",
        "make_controller",
        "parse_spec",
    ):
        from . import registry

        return getattr(registry, name)
    raise AttributeError(f"module 'agents' has no attribute {name!r}")
