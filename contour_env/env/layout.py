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

Python hands the kernel's entry points the records' arrays flat (:data:`ENTRY_RECORDS`);
the entry points rebuild the records.
"""

from __future__ import annotations

from collections import namedtuple
from collections.abc import Callable
from typing import NamedTuple

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

# The entry points called from Python (contour_env.env.kernel: env_step, env_step_parallel,
# env_reset, fill_info_envs) take these four records' arrays flat, in this order, as their
# last arguments (``*state, *path, *plant, *out``) and rebuild the records
# (kernel.records_of): the list of arrays is the records' declarations above, written once.
# A call with the arrays flat costs ~1.3 µs, with the four named tuples ~3 µs (numba types a
# named tuple in Python, a plain array in C; measured), a tenth of a single env's step.
ENTRY_RECORDS = (EnvState, PathArrays, PlantArrays, StepOutputs)
_ends = np.cumsum([len(r._fields) for r in ENTRY_RECORDS])
(STATE_END, PATH_END, PLANT_END, OUT_END) = (int(e) for e in _ends)
del _ends

# --- the declared layout -------------------------------------------------------------------
# Every slot of the configuration vectors, every per-axis row of ``ax``, every row of the
# batched info, every info key and every observation field is declared once below, as a
# :class:`Field` (name, dtype, shape, unit, meaning). The index constants the kernels read
# (``C_<NAME>`` of cfg, ``I_<NAME>`` of icfg, ``AX_<NAME>``, ``INFO_<NAME>``) and the sizes
# are made from these tables (:func:`_index_constants`), the config packing
# (EnvCore._pack_config), ``obs_dim``, the info dicts (EnvCore.info_of / info_dict) and the
# docstring tables (:mod:`contour_env.env.layout_doc`) too.


class Field(NamedTuple):
    """One declared entry: ``name`` (the index constant's suffix, or the info key), ``dtype``,
    ``shape`` per env ("" a scalar; "A" one per axis), ``unit``, ``doc`` (one line), and for
    a configuration slot ``value(config, setup, T, A)``: its value from the env
    configuration, the setup, the servo period T (s) and the axis count A."""

    name: str
    dtype: str
    shape: str
    unit: str
    doc: str
    value: Callable | None = None


def _inverse(of: Callable) -> Callable:
    # a reciprocal computed once, so the per-step code multiplies instead of dividing
    return lambda c, s, T, A: 1.0 / of(c, s, T, A)


def _T(c, s, T, A):
    return T


def _feed(c, s, T, A):
    return s.feedrate_m_s


def _acc(c, s, T, A):
    return s.max_accel_m_s2


def _config(name: str) -> Callable:
    return lambda c, s, T, A: getattr(c, name)


F64, I64 = "float64", "int64"
# float configuration (cfg); then cfg[CFG_SIZE + j] = 1 / (feed · preview time j), the
# preview's scale (1/m), one per preview time
CFG_FIELDS = (
    Field("T", F64, "", "s", "servo period", _T),
    Field(
        "ERR_SCALE", F64, "", "m", "position-error observation scale", _config("error_obs_scale_m")
    ),
    Field(
        "VERR_SCALE",
        F64,
        "",
        "m/s",
        "velocity-error observation scale",
        _config("velocity_error_obs_scale_m_s"),
    ),
    Field("FEED_SCALE", F64, "", "m/s", "the case feedrate (feed observation scale)", _feed),
    Field(
        "ACC_SCALE", F64, "", "m/s²", "the case acceleration (acceleration observation scale)", _acc
    ),
    Field(
        "CURV_SCALE", F64, "", "m", "curvature observation scale", _config("curvature_obs_scale_m")
    ),
    Field("W_CONTOUR", F64, "", "1", "reward weight of the contour error", _config("w_contour")),
    Field("W_LAG", F64, "", "1", "reward weight of the lag error", _config("w_lag")),
    Field("W_EFFORT", F64, "", "1", "reward weight of the effort ‖a‖²/n", _config("w_effort")),
    Field("EPS_SCALE", F64, "", "m", "the reward's error scale", _config("contour_error_scale_m")),
    Field("ABORT", F64, "", "m", "the contour guard", _config("abort_contour_error_m")),
    Field(
        "NOISE_STD",
        F64,
        "",
        "m",
        "encoder noise before quantisation",
        _config("measurement_noise_std_m"),
    ),
    Field("DIST_AMP", F64, "", "N", "random disturbance amplitude", _config("disturbance_force_N")),
    Field("OBS_CLIP", F64, "", "1", "observation clip", _config("obs_clip")),
    Field(
        "DIST_PHASE_RANDOM",
        F64,
        "",
        "flag",
        "the plant disturbance's phase drawn per episode",
        lambda c, s, T, A: 1.0 if c.disturbance_phase == "random" else 0.0,
    ),
    Field("INV_T", F64, "", "1/s", "1 / T", _inverse(_T)),
    Field(
        "INV_ERR",
        F64,
        "",
        "1/m",
        "1 / position-error scale",
        _inverse(_config("error_obs_scale_m")),
    ),
    Field(
        "INV_VERR",
        F64,
        "",
        "s/m",
        "1 / velocity-error scale",
        _inverse(_config("velocity_error_obs_scale_m_s")),
    ),
    Field("INV_FEED", F64, "", "s/m", "1 / case feedrate", _inverse(_feed)),
    Field("INV_ACC", F64, "", "s²/m", "1 / case acceleration", _inverse(_acc)),
    Field(
        "INV_EPS",
        F64,
        "",
        "1/m",
        "1 / the reward's error scale",
        _inverse(_config("contour_error_scale_m")),
    ),
    Field("INV_AXES", F64, "", "1", "1 / axis count", lambda c, s, T, A: 1.0 / A),
    Field(
        "ABORT_TRACK2",
        F64,
        "",
        "m²",
        "the tracking guard squared, compared with ‖x_d − x‖²",
        lambda c, s, T, A: c.abort_tracking_error_m**2,
    ),
    Field(
        "GUARD_PENALTY",
        F64,
        "",
        "1",
        "P: the penalty of each step a guard ends or skips",
        lambda c, s, T, A: c.guard_penalty,
    ),
)
# integer configuration (icfg)
ICFG_FIELDS = (
    Field("NSTEPS", I64, "", "samples", "reference samples n_steps"),
    Field("NSUB", I64, "", "1", "friction substeps per period"),
    Field("DELAY", I64, "", "samples", "computation delay (0 or 1)"),
)
# per-axis env state and readout rows (ax[row, b, axis]; row-major so each row of the batch
# is contiguous and the info arrays are plain copies)
AX_FIELDS = (
    Field("STUCK", F64, "A", "flag", "held by static friction"),
    Field("UPEND", F64, "A", "N", "the command waiting out the computation delay"),
    Field("MEAS", F64, "A", "m", "measured position (encoder)"),
    Field("VEL", F64, "A", "m/s", "measured velocity (backward difference)"),
    Field("PREV", F64, "A", "1", "previous action"),
    Field("APPLIED", F64, "A", "N", "force applied in the last period"),
    Field("SAT", F64, "A", "flag", "the last period's force at the limit"),
    Field("REF", F64, "A", "m", "reference position"),
    Field("TOFF", F64, "A", "s", "time offset of the plant's periodic disturbance, per episode"),
)
# The info dict of a step (``info`` of ContouringEnv, per env; the vector env's, batched):
# each key, and where the batched info arrays hold it: ("f", row) the float block (B, A)
# rows, ("s", row) the scalar block (2, B) (time s, contour error m), "sat" the saturation
# flags (B, A), "step" the reference index (B,), "reason" the termination status
INFO_KEYS = (
    (Field("time", F64, "", "s", "k · T"), ("s", 0)),
    (Field("step", I64, "", "samples", "reference index k"), "step"),
    (Field("position", F64, "A", "m", "true position"), ("f", "POSITION")),
    (Field("measured_position", F64, "A", "m", "encoder reading"), ("f", "MEASURED")),
    (Field("velocity", F64, "A", "m/s", "true velocity"), ("f", "VELOCITY")),
    (Field("reference", F64, "A", "m", "reference position x_d"), ("f", "REFERENCE")),
    (Field("contour_error", F64, "", "m", "true contour error ε"), ("s", 1)),
    (Field("contour_error_estimate", F64, "A", "m",
           "Fᵀ(x_d − x): tangential, normal (, binormal)"), ("f", "ESTIMATE")),
    (Field("tracking_error", F64, "A", "m", "x_d − x"), ("f", "TRACKING")),
    (Field("force", F64, "A", "N", "applied command after delay and saturation"), ("f", "FORCE")),
    (Field("saturated", "bool", "A", "flag", "the force at its limit"), "sat"),
    (Field("termination_reason", "str", "", "–", "None while running, then the guard's reason"),
     "reason"),
)  # fmt: skip

# rows of the float block of the batched info (each (B, A)), in order: the INFO_KEYS entries
# held there ("f", row), each named by its row (INFO_POSITION, ...); the scalar block: time,
# contour error
INFO_FIELDS = tuple(
    field._replace(name=where[1])
    for field, where in INFO_KEYS
    if isinstance(where, tuple) and where[0] == "f"
)


def _index_constants(prefix: str, fields) -> dict:
    return {f"{prefix}{f.name}": i for i, f in enumerate(fields)}


# C_T, C_ERR_SCALE, ..., I_NSTEPS, ..., AX_STUCK, ..., INFO_POSITION, ...: the index of each
# declared field in its array (module constants: numba compiles them in as literals)
globals().update(_index_constants("C_", CFG_FIELDS))
globals().update(_index_constants("I_", ICFG_FIELDS))
globals().update(_index_constants("AX_", AX_FIELDS))
globals().update(_index_constants("INFO_", INFO_FIELDS))
CFG_SIZE = len(CFG_FIELDS)
ICFG_SIZE = len(ICFG_FIELDS)
AX_SIZE = len(AX_FIELDS)
INFO_ROWS = len(INFO_FIELDS)


# The observation, in order (float32, clipped to ±obs_clip): ``shape`` in axes A and preview
# times p; ``unit`` before scaling, ``doc`` ending in the scale
OBS_FIELDS = (
    Field("tracking_error", "float32", "A", "m",
          "Fᵀ(x_d − x): tangential, normal (, binormal) error; / error_obs_scale_m"),
    Field("velocity_error", "float32", "A", "m/s",
          "Fᵀ(ẋ_d − ẋ): task-frame velocity error; / velocity_error_obs_scale_m_s"),
    Field("feedrate", "float32", "1", "m/s", "reference feedrate ṡ; / case feedrate"),
    Field("feed_acceleration", "float32", "1", "m/s²",
          "reference tangential acceleration s̈; / case max acceleration"),
    Field("curvature", "float32", "1", "1/m",
          "reference curvature κ, signed for planar paths; × curvature_obs_scale_m"),
    Field("preview", "float32", "p·A", "m",
          "preview Fᵀ(x_d(t + τ_j) − x_d(t)), τ_j in preview_times_s; / (feed · τ_j)"),
    Field("previous_action", "float32", "A", "1", "previous action"),
)  # fmt: skip


def field_size(field: Field, n_axes: int, n_preview: int = 0) -> int:
    """Entries of ``field`` per env: 1 for a scalar, A, or p·A."""
    return {"": 1, "1": 1, "A": n_axes, "p·A": n_preview * n_axes}[field.shape]


def obs_dim(n_axes: int, n_preview: int) -> int:
    """The observation's length for A axes and p preview times (:data:`OBS_FIELDS`)."""
    return sum(field_size(f, n_axes, n_preview) for f in OBS_FIELDS)


# noise streams of the counter-based generator (contour_env.noise)
STREAM_MEAS, STREAM_DIST, STREAM_PHASE = 0, 1, 2

# termination status codes (both kernels) and the reason ``info`` reports for each
STATUS_OK, STATUS_CONTOUR_LIMIT, STATUS_NONFINITE, STATUS_TRACKING_LIMIT = 0, 1, 2, 3
TERMINATION_REASONS = {
    STATUS_CONTOUR_LIMIT: "contour_error_limit",
    STATUS_NONFINITE: "non_finite_state",
    STATUS_TRACKING_LIMIT: "tracking_error_limit",
}
# the reasons indexed by status code ("" while running), for the batched info
REASON_BY_STATUS = ("", "contour_error_limit", "non_finite_state", "tracking_error_limit")


def zero_outputs(n_envs: int, obs_dim: int) -> StepOutputs:
    """New step outputs of a batch, zeroed: obs (B, obs_dim) float32, reward (B,), terminated
    and truncated (B,) bool."""
    return StepOutputs(
        np.zeros((n_envs, obs_dim), dtype=np.float32),
        np.zeros(n_envs),
        np.zeros(n_envs, dtype=bool),
        np.zeros(n_envs, dtype=bool),
    )
