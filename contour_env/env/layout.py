"""The layout of the env kernel's arrays, and the records that group them.

The compiled step (:mod:`.kernel`) works on plain arrays; this module says what is where:
the float and integer configuration slots (``cfg``, ``icfg``), the per-axis rows of ``ax``
(``ax[row, b, axis]``), the termination status codes and their ``info`` reasons, the rows of
the batched info. The stages of the step receive the arrays grouped in four records (named
tuples, free in compiled code):

- :class:`EnvState` — what each env carries from one servo period to the next: plant state
  ``z`` (B, A, ns), axis rows ``ax`` (AX_SIZE, B, A), reference index ``k`` (B,), true contour
  error ``eps`` (B,) m, task-frame error ``est`` (B, A) m, ``status`` (B,), noise ``seed``
  (B,), and ``scratch`` (2 B, ns), the plant integrator's work space;
- :class:`PathArrays` — the reference and the path: ``ref_pav`` (n, 3, 3) rows [position,
  velocity, acceleration], ``frame`` (n, 3, 3) columns [t n b], ``obs_tab`` (n, n_static)
  float32, the path's segment table ``seg_type``, ``seg_data``, ``seg_bounds``;
- :class:`PlantArrays` — the plant parameters packed per parameter set
  (:func:`contour_env.plants.pack_params`): ``mat_T``, ``mat_h``, ``cont``, ``nl``, and
  ``pidx`` (B,), the set of each env;
- :class:`StepOutputs` — what a step returns per env: ``obs`` (B, O) float32, ``reward``
  (B,), ``terminated``, ``truncated`` (B,) bool.

Python hands the kernel's entry points the arrays one by one (a numba call with a tuple
argument costs about 0.4 µs more per step, measured); the entry points build the records.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from .borrow import register_record

EnvState = register_record(namedtuple("EnvState", "z ax k eps est status seed scratch"))
PathArrays = register_record(
    namedtuple("PathArrays", "ref_pav frame obs_tab seg_type seg_data seg_bounds")
)
PlantArrays = register_record(namedtuple("PlantArrays", "mat_T mat_h cont nl pidx"))
StepOutputs = register_record(namedtuple("StepOutputs", "obs reward terminated truncated"))
# what a compiled episode records per step of env 0 (time s, contour error m, position,
# reference, applied force per axis): the arrays of contour_env.env.rollout.empty_record
EpisodeTrace = register_record(namedtuple("EpisodeTrace", "time eps pos ref force"))

# float configuration (cfg)
(
    C_T,
    C_ERR_SCALE,
    C_VERR_SCALE,
    C_FEED_SCALE,
    C_ACC_SCALE,
    C_CURV_SCALE,
    C_W_CONTOUR,
    C_W_LAG,
    C_W_EFFORT,
    C_EPS_SCALE,
    C_ABORT,
    C_NOISE_STD,
    C_DIST_AMP,
    C_OBS_CLIP,
    C_DIST_PHASE_RANDOM,
    C_INV_T,
    C_INV_ERR,
    C_INV_VERR,
    C_INV_FEED,
    C_INV_ACC,
    C_INV_EPS,
    C_INV_AXES,
    C_ABORT_TRACK2,
    C_GUARD_PENALTY,
) = range(24)
# C_ABORT_TRACK2: the tracking-error guard squared (m²), compared with ‖x_d − x‖² (no root);
# C_GUARD_PENALTY: P ≥ 0, the penalty of one step at the guards, charged for the terminating
# step and every step a termination skips (see EnvConfig.guard_penalty)
# cfg[CFG_SIZE + j]: 1 / (feed scale · preview time j), the preview's scale; the reciprocals
# are computed once by EnvCore so that the per-step code multiplies instead of dividing
CFG_SIZE = 24
# integer configuration (icfg)
I_NSTEPS, I_NSUB, I_DELAY = range(3)
ICFG_SIZE = 3
# per-axis env state and readout rows (ax[row, b, axis]; row-major so each row of the batch
# is contiguous and the info arrays are plain copies)
# AX_TOFF: the env's time offset of the plant's periodic disturbance d(t) (s), drawn per episode
AX_STUCK, AX_UPEND, AX_MEAS, AX_VEL, AX_PREV, AX_APPLIED, AX_SAT, AX_REF, AX_TOFF = range(9)
AX_SIZE = 9
# termination status codes (both kernels) and the reason ``info`` reports for each
STATUS_OK, STATUS_CONTOUR_LIMIT, STATUS_NONFINITE, STATUS_TRACKING_LIMIT = 0, 1, 2, 3
TERMINATION_REASONS = {
    STATUS_CONTOUR_LIMIT: "contour_error_limit",
    STATUS_NONFINITE: "non_finite_state",
    STATUS_TRACKING_LIMIT: "tracking_error_limit",
}
# the reasons indexed by status code ("" while running), for the batched info
REASON_BY_STATUS = ("", "contour_error_limit", "non_finite_state", "tracking_error_limit")
# noise streams of the counter-based generator (contour_env.noise)
STREAM_MEAS, STREAM_DIST, STREAM_PHASE = 0, 1, 2

# rows of the float block of the batched info (each (B, A)); info_s rows: time, contour error
(
    INFO_POSITION,
    INFO_MEASURED,
    INFO_VELOCITY,
    INFO_REFERENCE,
    INFO_ESTIMATE,
    INFO_TRACKING,
    INFO_FORCE,
) = range(7)
INFO_ROWS = 7


def zero_outputs(n_envs: int, obs_dim: int) -> StepOutputs:
    """New step outputs of a batch, zeroed: obs (B, obs_dim) float32, reward (B,), terminated
    and truncated (B,) bool."""
    return StepOutputs(
        np.zeros((n_envs, obs_dim), dtype=np.float32),
        np.zeros(n_envs),
        np.zeros(n_envs, dtype=bool),
        np.zeros(n_envs, dtype=bool),
    )
