"""What a trained model folder's ``agent.json`` and ``normalization.json`` may hold (each key,
its unit and its range), checked on load by :func:`contour_env.schema.check_object`: a
value out of range is refused with the file, the key, the value and the allowed range named,
before it can hang an evaluation (``action_repeat`` 0), poison it (``scale`` NaN) or be
silently ignored (a misspelt key). The tables in docs/FILES.md are generated from
:data:`AGENT_KEYS` and :data:`NORMALIZATION_KEYS`.
"""

from __future__ import annotations

import json
import os
import zipfile

from contour_env.schema import FileFormatError, Key, check_object, read_json, show

from .algos import JAX_ALGOS, SB3_ALGOS
from .residual_law import RESIDUAL_FRAMES

MODEL_FORMAT = "contour_env.residual_agent/1"
OBSERVATIONS = ("full", "state", "errors")
RESIDUAL_AXES = ("path", "all")
KEPT = ("best-validation", "final", "base")
TEACHER_NAMES = ("ilc-contour", "none")
MAX_ACTION_REPEAT = 100_000
SCALE_RANGE = (0.0, 2.0)  # fractions of the force limit; TrainConfig's range

_ANY_NUMBER = dict(nullable=True)

AGENT_KEYS = (
    Key("format", "choice", choices=(MODEL_FORMAT,), required=True, doc="the file's format"),
    Key("algo", "choice", choices=SB3_ALGOS + JAX_ALGOS, required=True, doc="the RL algorithm"),
    Key("plant", "string", required=True, doc="the plant's name the agent is bound to"),
    Key("plant_file", "string", doc="the plant file it was trained on (informative)"),
    Key("n_axes", "integer", "", 2, 3, required=True, doc="axes of the plant"),
    Key("obs_dim", "integer", "", 1, 10_000, required=True, doc="observation size"),
    Key("base", "string", required=True, doc="the base controller (a controller name)"),
    Key("base_kwargs", "object", nullable=True, doc="the base controller's keywords"),
    Key(
        "scale",
        "number",
        "fraction of the force limit",
        *SCALE_RANGE,
        lo_open=True,
        required=True,
        doc="the residual's bound per axis",
    ),
    Key("observe_base_command", "bool", required=True, doc="the base command is observed"),
    Key("observation", "choice", choices=OBSERVATIONS, doc='what it sees (default "full")'),
    Key("residual_axes", "choice", choices=RESIDUAL_AXES, doc='axes pushed (default "all")'),
    Key("residual_frame", "choice", choices=RESIDUAL_FRAMES, doc='frame (default "axes")'),
    Key("gate", "bool", doc="a gate action scales the residual (default false)"),
    Key("observe_axes", "bool", doc="per-axis observation (default false)"),
    Key("fade_at_rest", "bool", doc="the residual fades out at rest (default false)"),
    Key(
        "action_repeat",
        "integer",
        "servo periods",
        1,
        MAX_ACTION_REPEAT,
        required=True,
        doc="the agent acts every k servo periods",
    ),
    Key(
        "servo_period_s",
        "number",
        "s",
        1e-6,
        0.1,
        doc="the servo period it was trained at (must be the env's)",
    ),
    Key("cases", "strings", doc="named cases trained on"),
    Key("gcode", "strings", doc="G-code files trained on"),
    Key("timesteps", "integer", "", 0, 10**12, doc="training steps in the model"),
    Key("seed", "integer", "", 0, 2**64 - 1, nullable=True, doc="training seed"),
    Key("teacher", "choice", choices=TEACHER_NAMES, nullable=True, doc="the teacher used"),
    Key("envelope", "object", nullable=True, doc="ranges trained on (agents/envelope.py)"),
    Key("kept", "choice", choices=KEPT, nullable=True, doc='"base": the agent is its base'),
    Key("release", "object", nullable=True, doc="the release gate's verdict"),
    Key("source", "string", doc="where the model came from (rl-zoo runs)"),
    Key("final_timesteps", "integer", "", 0, 10**12, **_ANY_NUMBER, doc="steps trained"),
    Key("train_wall_s", "number", "s", 0, None, **_ANY_NUMBER, doc="training time"),
    Key("run_wall_s", "number", "s", 0, None, **_ANY_NUMBER, doc="run time"),
    Key("eval_share", "number", "", 0, 1, **_ANY_NUMBER, doc="share of time evaluating"),
    Key("time_to_target", "object", nullable=True, doc="time to the validation targets"),
    Key("validation_paths", "integer", "", 0, 10**6, **_ANY_NUMBER, doc="validation parts"),
    *(
        Key(name, "number", unit, None, None, **_ANY_NUMBER, doc=doc)
        for name, unit, doc in (
            ("base_rms_contour_error_um", "µm", "the base on the training tasks"),
            ("final_rms_contour_error_um", "µm", "the final model on them"),
            ("validation_rms_contour_error_um", "µm", "the kept model on validation"),
            ("validation_base_rms_contour_error_um", "µm", "the base on validation"),
            ("validation_score", "", "keep-best's score of the kept model"),
        )
    ),
)

NORMALIZATION_KEYS = (
    Key("mean", "numbers", required=True, doc="observation mean, one per field (obs_dim)"),
    Key("var", "numbers", "", 0, None, required=True, doc="observation variance, ≥ 0"),
    Key(
        "clip_obs",
        "number",
        "",
        0,
        1e6,
        lo_open=True,
        required=True,
        doc="clip of the normalised observation",
    ),  # fmt: skip
    Key("epsilon", "number", "", 0, 1, required=True, doc="added to the variance"),
)


def read_agent_json(path) -> dict:
    """``agent.json`` at ``path``, checked against :data:`AGENT_KEYS` (and its envelope);
    FileFormatError naming the file, the key, the value and the allowed values otherwise."""
    name = os.fspath(path)
    meta = read_json(name, "agent.json")
    if isinstance(meta, dict) and meta.get("format", MODEL_FORMAT) != MODEL_FORMAT:
        raise FileFormatError(
            f"{name}: format: must be {MODEL_FORMAT!r} (a residual agent written by contour-env "
            f"train), got {show(meta.get('format'))}"
        )
    check_object(meta, AGENT_KEYS, name)
    if meta.get("envelope") is not None:
        from .envelope import Envelope

        try:
            Envelope.from_dict(meta["envelope"], int(meta["n_axes"]), where=f"{name}: envelope")
        except ValueError as exc:
            raise FileFormatError(str(exc)) from None
    return meta


def read_normalization(path, obs_dim: int | None = None) -> dict:
    """``normalization.json`` at ``path``, checked against :data:`NORMALIZATION_KEYS`, with
    ``mean`` and ``var`` of one entry per observation field (``obs_dim``, agent.json's)."""
    name = os.fspath(path)
    data = read_json(name, "normalization.json")
    check_object(data, NORMALIZATION_KEYS, name)
    n_mean, n_var = len(data["mean"]), len(data["var"])
    if n_mean != n_var or (obs_dim is not None and n_mean != obs_dim):
        want = f"{obs_dim} (agent.json's obs_dim)" if obs_dim is not None else "equal lengths"
        raise FileFormatError(
            f"{name}: mean and var: one value per observation field, {want}; got {n_mean} "
            f"and {n_var}"
        )
    return data


def check_model_zip(path) -> None:
    """``model.zip`` opens as a zip and its JSON member ``data`` (stable-baselines3's
    settings) parses: FileFormatError naming the file and the member otherwise."""
    name = os.fspath(path)
    try:
        with zipfile.ZipFile(name) as zf:
            if "data" not in zf.namelist():
                raise FileFormatError(
                    f"{name}: no member 'data' (not a stable-baselines3 model archive)"
                )
            text = zf.read("data").decode("utf-8")
    except FileFormatError:
        raise
    except (zipfile.BadZipFile, OSError, UnicodeDecodeError, KeyError) as exc:
        raise FileFormatError(f"{name}: not a readable model archive ({exc})") from None
    try:
        json.loads(text)
    except json.JSONDecodeError as exc:
        raise FileFormatError(f"{name}, member 'data': not valid JSON ({exc})") from None
