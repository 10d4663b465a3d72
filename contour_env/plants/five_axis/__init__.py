"""Five-axis A–C tilting-table machine (Chen, Khong & Hsieh 2022): kinematics, coupled
joint-space dynamics and a batched compiled plant step (not yet wired into the env)."""

from .dynamics import coriolis_matrix, drift_and_gain, energy, gravity, mass_matrix
from .kinematics import FiveAxisGeometry, forward, inverse, tool_towards
from .params import FIVE_AXIS_PLANTS, FiveAxisInertia, FiveAxisParams, five_axis_params
from .plant import (
    FiveAxisPlant,
    FiveAxisState,
    PackedFiveAxis,
    five_axis_step_batch,
    pack_five_axis,
)

__all__ = [
    "FIVE_AXIS_PLANTS",
    "FiveAxisGeometry",
    "FiveAxisInertia",
    "FiveAxisParams",
    "FiveAxisPlant",
    "FiveAxisState",
    "PackedFiveAxis",
    "coriolis_matrix",
    "drift_and_gain",
    "energy",
    "five_axis_params",
    "five_axis_step_batch",
    "forward",
    "gravity",
    "inverse",
    "mass_matrix",
    "pack_five_axis",
    "tool_towards",
]
