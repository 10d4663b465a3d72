"""``contour_env/FiveAxis-v0``: the five-axis machine (Chen, Khong & Hsieh 2022) as an env id of
its own. It is ``contour_env/Contouring-v0`` with ``plant="five-axis"`` (the same class and
core, so the same results to the bit), restricted to that machine: its cases
(``five-axis-line``, the default, and ``five-axis-circle``) or a path or G-code program with A
and C words on it. A feed-drive plant or case is refused with the allowed values named; the
``Contouring-v0`` spelling keeps working as an alias."""

from __future__ import annotations

from ..cases import five_axis_case_names
from .contouring_env import ContouringEnv
from .vector_env import ContouringVectorEnv

PLANT = "five-axis"
# the env id's default, as Contouring-v0's is hsm2-circle-II
DEFAULT_CASE = "five-axis-line"


def _arguments(case, plant, path) -> tuple:
    if plant is not None and plant != PLANT:
        raise ValueError(
            f"plant: contour_env/FiveAxis-v0 drives the five-axis machine only: None or "
            f"{PLANT!r}, got {plant!r} (the feed-drive plants: contour_env/Contouring-v0)"
        )
    if case is not None and case not in five_axis_case_names():
        raise ValueError(
            f"case: contour_env/FiveAxis-v0 has the five-axis cases "
            f"{', '.join(five_axis_case_names())}, got {case!r} (the feed-drive cases: "
            "contour_env/Contouring-v0)"
        )
    if case is None and path is None:
        case = DEFAULT_CASE
    if path is not None and case is None:
        plant = PLANT
    return case, plant, path


def make_five_axis_env(case=None, plant=None, path=None, **kwargs) -> ContouringEnv:
    """The entry point of ``contour_env/FiveAxis-v0`` (see the module docstring)."""
    return ContouringEnv(*_arguments(case, plant, path), **kwargs)


class FiveAxisVectorEnv(ContouringVectorEnv):
    """The vector entry point of ``contour_env/FiveAxis-v0``: ``ContouringVectorEnv`` on the
    five-axis machine."""

    def __init__(self, num_envs: int = 1, case=None, plant=None, path=None, **kwargs):
        super().__init__(num_envs, *_arguments(case, plant, path), **kwargs)
