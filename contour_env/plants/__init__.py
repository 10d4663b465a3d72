"""Feed-drive plants: parameters, named catalogue, exact discretisation and compiled step."""

from .catalog import Effects, nominal_params, plant_names
from .model import PackedPlant, Plant, PlantState, pack_params, quantize
from .params import PlantParams, params_from_mapping

__all__ = [
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
