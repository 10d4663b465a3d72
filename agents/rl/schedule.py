"""The learning-rate schedule of a training run (``TrainConfig.learning_rate_final``).

sb3 reads the learning rate from a schedule of its "progress remaining", which it computes from
the total timesteps; a run stopped by ``time_budget_s`` would never reach its end that way. The
trainer therefore sets the fraction of the run done itself (training time over the budget, or
timesteps over the total) and the rate follows geometrically,
lr(f) = lr₀ · (lr_final / lr₀)^f, f ∈ [0, 1]: a run ends on small steps, so that its last
checkpoints — the candidates of keep-best — are not as far apart as the first ones.
"""

from __future__ import annotations

import math


class AnnealedRate:
    """A callable sb3 schedule whose value is set by :meth:`at` (the fraction of the run)."""

    def __init__(self, start: float, final: float | None):
        if not (start > 0 and math.isfinite(start)):
            raise ValueError(f"learning_rate: must be > 0, got {start!r}")
        if final is not None and not (0 < final <= start):
            raise ValueError(f"learning_rate_final: must be > 0 and <= {start}, got {final!r}")
        self.start = float(start)
        self.final = float(start if final is None else final)
        self.value = self.start

    def at(self, fraction: float) -> float:
        """Set and return the rate at ``fraction`` of the run (clipped to [0, 1])."""
        f = min(max(float(fraction), 0.0), 1.0)
        self.value = self.start * (self.final / self.start) ** f
        return self.value

    def __call__(self, _progress_remaining: float) -> float:
        return self.value
