"""``make_core``: the simulation core of a case, plant or path — :class:`.core.EnvCore` for the
feed-drive plants, :class:`.five_axis_core.FiveAxisCore` for the five-axis machine (what
:class:`ContouringEnv` and :class:`ContouringVectorEnv` step)."""

from __future__ import annotations

import inspect

from ..cases import FIVE_AXIS_ABORT_CONTOUR_M, build_setup, get_case
from .core import EnvConfig, EnvCore, StepThreads, check_env_arguments
from .five_axis_core import FiveAxisCore
from .protocol import Core

# the keywords that describe the setup (build_setup's); every other keyword is an EnvConfig one
SETUP_KEYWORDS = tuple(
    name
    for name, param in inspect.signature(build_setup).parameters.items()
    if param.kind is inspect.Parameter.KEYWORD_ONLY
)


def make_core(
    case=None, plant=None, path=None, *, n_envs=1, plant_params=None, num_threads=None, **kwargs
) -> Core:
    """The core of ``gym.make``'s env (a :class:`.protocol.Core`: both classes implement it):
    the setup from ``case`` / ``plant`` / ``path`` and the setup keywords
    (:data:`SETUP_KEYWORDS`, those of :func:`contour_env.cases.build_setup`), the env
    configuration (:class:`~.core.EnvConfig`) from the others; ``num_threads``: the step's
    thread policy (None / "auto": adaptive; see :class:`~.core.StepThreads`)."""
    config = {key: value for key, value in kwargs.items() if key not in SETUP_KEYWORDS}
    check_env_arguments(config)
    setup_kw = {key: value for key, value in kwargs.items() if key in SETUP_KEYWORDS}
    setup = build_setup(case, plant, path, **setup_kw)
    if isinstance(case, str):
        # the case's own env settings (e.g. corner-blend: random disturbance phase, encoder
        # noise) unless given here
        config = {**get_case(case).env_config, **config}
    if getattr(setup, "family", None) == "five-axis":
        # the coupled five-axis machine: its own core and kernel (contour_env.env.five_axis_core)
        # its contour guard is on ε + L·θ: the family's default (programs too) unless given
        config = {"abort_contour_error_m": FIVE_AXIS_ABORT_CONTOUR_M, **config}
        return FiveAxisCore(
            setup, EnvConfig(**config), n_envs, plant_params=plant_params, num_threads=num_threads
        )
    threads = StepThreads(num_threads, n_envs)  # checked before the arrays are built
    core = EnvCore(setup, EnvConfig(**config), n_envs=n_envs, plant_params=plant_params)
    core.threads = threads
    return core
