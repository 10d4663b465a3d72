"""Export of a trained residual agent's control law to other languages.

:func:`write_c` writes the whole law of a model directory (observation, normalisation, actor
network, envelope fade, action repeat, path-frame residual, gate, rest fade) as one
dependency-free C99 source, ``residual.c`` + ``residual.h``, that a servo loop calls once per
servo period (:mod:`agents.export.c_law`).
"""

from __future__ import annotations

from .c_law import describe_interface, write_c

__all__ = ["describe_interface", "write_c"]
