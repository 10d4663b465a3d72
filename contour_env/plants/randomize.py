"""Plant-parameter variations for robustness studies (the controller keeps the nominal model)."""

from __future__ import annotations

import numpy as np

from .params import PlantParams

# per-axis fields varied by ``randomized``: inertia, viscous and Coulomb/static friction,
# ripple and disturbance amplitudes
RANDOMIZED_FIELDS = (
    "mass_kg",
    "viscous_Ns_m",
    "coulomb_N",
    "static_N",
    "ripple_amplitude_N",
    "disturbance_amplitude_N",
)


def randomized(params: PlantParams, fraction: float, n: int, seed: int = 0) -> list[PlantParams]:
    """n copies of ``params`` with each field of RANDOMIZED_FIELDS, per axis, multiplied by an
    independent uniform factor in [1 − fraction, 1 + fraction] (seeded). Static friction is
    kept ≥ Coulomb friction. Feed-drive plants only: the five-axis plant's parameters are the
    masses, inertias and offsets of one coupled model, not per-axis drives (ValueError)."""
    if not isinstance(params, PlantParams):
        raise ValueError(
            f"randomize: plant variations are defined for the feed-drive plants (PlantParams: "
            f"hsm2, jee-triaxial, linear-motor, friction-table, plant files), got "
            f"{type(params).__name__} ({getattr(params, 'name', '?')!r}): the five-axis plant's "
            "parameters are masses, inertias and offsets of a coupled model, not per-axis "
            "drives; compare it on the nominal plant and with --ideal"
        )
    if not (np.isfinite(fraction) and 0 <= fraction < 1):
        raise ValueError(f"randomize: the fraction must be in [0, 1), got {fraction!r}")
    if n < 1:
        raise ValueError(f"episodes: must be >= 1, got {n}")
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        changes = {}
        for key in RANDOMIZED_FIELDS:
            factor = rng.uniform(1 - fraction, 1 + fraction, params.n_axes)
            changes[key] = getattr(params, key) * factor
        changes["static_N"] = np.maximum(changes["static_N"], changes["coulomb_N"])
        out.append(params.replace(**changes))
    return out
