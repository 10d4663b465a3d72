"""Feed-drive plants: parameters, named catalogue, exact discretisation and compiled step."""

from .catalog import Effects, nominal_params, plant_names
from .file_schema import params_from_mapping
from .five_axis import FiveAxisParams, FiveAxisPlant, five_axis_params
from .model import PackedPlant, Plant, PlantState, pack_params, quantize
from .params import PlantParams

# the five-axis family (its own plant class and kernel, contour_env.plants.five_axis): the
# plant names an env takes and the named parameter set each stands for
FIVE_AXIS_PLANT_ALIASES = {"five-axis": "nxv560a", "nxv560a": "nxv560a"}

__all__ = [
    "FIVE_AXIS_PLANT_ALIASES",
    "FiveAxisParams",
    "FiveAxisPlant",
    "five_axis_params",
    "Effects",
    "PackedPlant",
    "Plant",
    "PlantParams",
    "PlantState",
    "nominal_params",
    "pack_params",
    "params_from_mapping",
    "plant_names",
    "quantize",
]
