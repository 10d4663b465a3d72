"""Plants from a JSON file of parameters: ``plant="plant.json"`` (``gym.make``, ``Plant``) and
``--plant plant.json`` on the command line, e.g. the file ``contour-env identify`` writes.

The file holds one JSON object, the same mapping of parameters a custom plant takes
(:func:`contour_env.plants.params.params_from_mapping`: ``mass``, ``viscous``, ``coulomb``,
``static``, ``force_limit``, ``servo_period``, ...). A plant argument is read as a file when
it is an ``os.PathLike`` or a string ending in ``.json`` (any case); everything else is a
plant name as before.
"""

from __future__ import annotations

import json
import os

__all__ = ["is_plant_file", "load_plant_file"]


def is_plant_file(plant) -> bool:
    """True when ``plant`` names a JSON file of parameters rather than a named plant."""
    if isinstance(plant, os.PathLike):
        return True
    return isinstance(plant, str) and plant.lower().endswith(".json")


def load_plant_file(path) -> dict:
    """The mapping of parameters in the JSON file ``path``; ValueError with one line naming
    the file when it is missing, unreadable, not JSON or not a JSON object."""
    name = os.fspath(path)
    try:
        with open(name, encoding="utf-8") as fh:
            data = json.load(fh)
    except FileNotFoundError:
        raise ValueError(f"plant: no such file: {name}") from None
    except json.JSONDecodeError as exc:
        raise ValueError(f"plant: {name} is not valid JSON ({exc})") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"plant: cannot read {name} ({getattr(exc, 'strerror', exc)})") from None
    if not isinstance(data, dict):
        raise ValueError(
            f"plant: {name} must hold a JSON object of plant parameters, got {type(data).__name__}"
        )
    return data
