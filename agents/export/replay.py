"""The exported law's inputs at an env's current sample: what a CNC's interpolator, encoders
and base controller hand the law each servo period, read from the env's core (for the parity
tests, and to run an exported law in the simulator before the machine)."""

from __future__ import annotations

import numpy as np


def inputs_from_core(core, axis_mask, base_command) -> dict:
    """{input name: float64 array} of env 0 of ``core`` at its current sample, the inputs of
    :func:`agents.export.c_law.describe_interface` (the reference sample the env observes,
    its preview, the encoder reading, the part's feed and acceleration limit); scalars as
    arrays of shape (1,), as the ONNX form takes them."""
    from contour_env.env.kernel import AX_MEAS

    n = core.dim
    kk = min(int(core.k[0]), core.n_steps - 1)
    kj = np.minimum(kk + core.preview, core.n_steps - 1)
    f64 = np.float64
    return {
        "ref_position": np.asarray(core.ref_pav[kk, 0, :n], f64),
        "ref_velocity": np.asarray(core.ref_pav[kk, 1, :n], f64),
        "ref_acceleration": np.asarray(core.ref_pav[kk, 2, :n], f64),
        "frame": np.asarray(core.frame[kk, :n, :n], f64),
        "path_speed": np.asarray(core.scal[kk, 0], f64).reshape(1),
        "path_accel": np.asarray(core.scal[kk, 1], f64).reshape(1),
        "curvature": np.asarray(core.scal[kk, 2], f64).reshape(1),
        "preview_position": np.asarray(core.ref_pav[kj, 0, :n], f64),
        "encoder_position": np.asarray(core.ax[AX_MEAS, 0], f64),
        "programmed_feed": np.asarray(core.setup.feedrate_m_s, f64).reshape(1),
        "max_accel": np.asarray(core.setup.max_accel_m_s2, f64).reshape(1),
        "axis_mask": np.asarray(axis_mask, f64).reshape(n),
        "base_command": np.asarray(base_command, f64).reshape(n),
    }
