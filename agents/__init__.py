"""Controllers used as policies: every controller (and later every trained agent) is reset at
the start of an episode and acts through stable-baselines3's ``predict`` signature."""

from .base import Controller
from .registry import CONTROLLERS, controller_names, make_controller

__all__ = ["CONTROLLERS", "Controller", "controller_names", "make_controller"]
