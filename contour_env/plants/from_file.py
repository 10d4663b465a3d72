"""Plants from a JSON file of parameters: ``plant="plant.json"`` (``gym.make``, ``Plant``) and
``--plant plant.json`` on the command line, e.g. the file ``contour-env identify`` writes.

The file holds one JSON object, the same mapping of parameters a custom plant takes
(:func:`contour_env.plants.file_schema.params_from_mapping`: ``mass``, ``viscous``, ``coulomb``,
``static``, ``force_limit``, ``servo_period``, ...). A plant argument is read as a file when
it is an ``os.PathLike`` or a string ending in ``.json`` (any case); everything else is a
plant name as before.
"""

from __future__ import annotations

import os

__all__ = ["is_plant_file", "load_plant_file"]


def is_plant_file(plant) -> bool:
    """True when ``plant`` names a JSON file of parameters rather than a named plant."""
    if isinstance(plant, os.PathLike):
        return True
    return isinstance(plant, str) and plant.lower().endswith(".json")


def load_plant_file(path) -> dict:
    """The mapping of parameters in the JSON file ``path``, checked key by key against
    :data:`contour_env.plants.file_schema.PLANT_KEYS`: a ``FileFormatError`` (ValueError)
    with one line naming the file (and the key, its value and the allowed range) when it is
    missing, unreadable, not JSON, not a JSON object or holds a value out of range."""
    from ..schema import read_json
    from .file_schema import check_plant_mapping

    name = os.fspath(path)
    data = read_json(name, "plant file")
    check_plant_mapping(data, name)
    return data
