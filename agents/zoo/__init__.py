"""RL Baselines3 Zoo (``rl_zoo3``) as a client: hyperparameter files, the residual wrapper the
zoo can name, and the bridge from a zoo run back to the project's scoring.

Install with ``pip install -e ".[zoo]"``. Importing this module (``--gym-packages agents.zoo``)
registers, besides ``contour_env/Contouring-v0``, the id :data:`RESIDUAL_ENV_ID`
(``contour_env/ResidualContouring-v0``): **the same plain env under a second id**, because the
zoo keys hyperparameters by env id and the residual entry needs its own key. The residual law
is applied by that entry's ``env_wrapper`` (:func:`residual_wrapper`), so the run's saved
``config.yml`` records it and ``python -m rl_zoo3.enjoy`` rebuilds it. ``gymnasium.make`` of
the second id alone gives the plain env.

- :func:`conf_file` — the shipped hyperparameter file of an algorithm
  (``agents/zoo/{sac,td3,ppo}.yml``, installed with the package; one file per algorithm
  because the zoo reads one file for the run and keys it by env id only).
- :func:`residual_wrapper` — the ``env_wrapper`` of the residual entries:
  :class:`agents.residual.ResidualWrapper` with explicit, checked keywords and the trainer's
  reward (``residual_penalty`` 1.0).
- :func:`load_agent` — a finished zoo run (its folder or one of its ``.zip`` files) as a
  :class:`agents.base.Controller`, scored by :func:`contour_env.evaluation.evaluate` like any
  controller: a residual run becomes a :class:`agents.residual.ResidualAgent` on its base, a
  plain run a :class:`ZooAgent` that commands the axes itself. Both read the observation
  statistics the zoo saved (``vecnormalize.pkl``).
- :func:`export_agent` — a residual zoo run as a model DIR of ``contour-env train``'s format
  (``agent.json``, ``model.zip``, ``normalization.json``) for ``contour-env evaluate --model``
  and ``contour-env compare --controllers …,residual --model``.

The zoo stores a run in ``LOG_FOLDER/ALGO/ENV_NAME_N/`` (``ENV_NAME`` is the id with ``/``
replaced by ``-``): the final model ``ENV_NAME.zip``, ``best_model.zip`` when ``--eval-freq``
evaluations ran, and ``ENV_NAME/`` with ``config.yml`` (the hyperparameters used),
``args.yml`` (the command line, ``env_kwargs`` among it) and ``vecnormalize.pkl``. The zoo
writes ``vecnormalize.pkl`` on each new best evaluation and again at the end, so the file holds
the final statistics: score the final model (the default), not ``best_model.zip``, unless the
run ended at its best.
"""

from __future__ import annotations

import json
import pickle
import shutil
from pathlib import Path

import numpy as np
from gymnasium.envs.registration import register, registry

from contour_env import ENV_ID
from contour_env.env.core import core_of

from ..base import Controller
from ..registry import controller_names
from ..residual import (
    DEFAULT_SCALE,
    MODEL_FORMAT,
    OBSERVATIONS,
    ResidualAgent,
    ResidualWrapper,
)

RESIDUAL_ENV_ID = "contour_env/ResidualContouring-v0"
ALGOS = ("sac", "td3", "ppo")
# the trainer's reward weight on the residual (agents/rl/config.py)
DEFAULT_RESIDUAL_PENALTY = 1.0
WRAPPER_NAME = "agents.zoo.residual_wrapper"

if RESIDUAL_ENV_ID not in registry:
    register(
        id=RESIDUAL_ENV_ID,
        entry_point="contour_env.env.contouring_env:make_contouring_env",
        disable_env_checker=False,
    )

__all__ = [
    "ALGOS",
    "RESIDUAL_ENV_ID",
    "ZooAgent",
    "ZooRun",
    "conf_file",
    "export_agent",
    "latest_run",
    "load_agent",
    "residual_wrapper",
]


def conf_file(algo: str) -> Path:
    """The shipped zoo hyperparameter file of ``algo`` (``sac``, ``td3`` or ``ppo``)."""
    if algo not in ALGOS:
        raise ValueError(f"algo: one of {', '.join(ALGOS)}, got {algo!r}")
    return Path(__file__).with_name(f"{algo}.yml")


def residual_wrapper(
    env,
    *,
    base: str = "pd",
    scale: float = DEFAULT_SCALE,
    observation: str = "full",
    observe_base_command: bool = False,
    action_repeat: int | None = None,
    residual_penalty: float = DEFAULT_RESIDUAL_PENALTY,
    base_kwargs: dict | None = None,
    residual_axes: str = "path",
    **unknown,
) -> ResidualWrapper:
    """The zoo's ``env_wrapper`` for residual training: ``env`` (the zoo's Monitor around a
    contour_env env) in :class:`agents.residual.ResidualWrapper` on top of ``base``.

    Keywords (the yaml's ``agents.zoo.residual_wrapper:`` mapping): ``base`` a controller name
    (``contour-env controllers``), ``scale`` the residual authority as a fraction of the force
    limit in (0, 2], ``observation`` ``"full"`` or ``"errors"``, ``observe_base_command``,
    ``action_repeat`` (servo periods per agent action; None: one per ms),
    ``residual_penalty`` (reward weight on ‖a_agent‖²/n, default 1.0 as ``contour-env
    train``), ``base_kwargs`` (the base controller's arguments, e.g. ``{W_p: 3.0e4}``) and
    ``residual_axes`` (``"path"``, default, or ``"all"``; see :mod:`agents.residual`). An
    unknown or ill-typed keyword is a ``ValueError`` naming it.
    """
    if unknown:
        known = (
            "base, scale, observation, observe_base_command, action_repeat, "
            "residual_penalty, base_kwargs, residual_axes"
        )
        raise ValueError(
            f"{WRAPPER_NAME}: unknown keyword(s) {', '.join(sorted(unknown))}; known: {known}"
        )
    if not isinstance(base, str) or base not in controller_names():
        raise ValueError(
            f"{WRAPPER_NAME}: base must be one of {', '.join(controller_names())}, got {base!r}"
        )
    if not isinstance(observation, str) or observation not in OBSERVATIONS:
        raise ValueError(
            f"{WRAPPER_NAME}: observation must be one of {', '.join(OBSERVATIONS)}, "
            f"got {observation!r}"
        )
    if not isinstance(observe_base_command, (bool, np.bool_)):
        raise ValueError(
            f"{WRAPPER_NAME}: observe_base_command must be true or false, "
            f"got {observe_base_command!r}"
        )
    if base_kwargs is not None and not isinstance(base_kwargs, dict):
        raise ValueError(
            f"{WRAPPER_NAME}: base_kwargs must be a mapping of the base controller's "
            f"arguments, got {base_kwargs!r}"
        )
    if isinstance(residual_penalty, bool) or not isinstance(
        residual_penalty, (int, float, np.number)
    ):
        raise ValueError(
            f"{WRAPPER_NAME}: residual_penalty must be a number >= 0, got {residual_penalty!r}"
        )
    try:
        return ResidualWrapper(
            env,
            base,
            scale=scale,
            observe_base_command=bool(observe_base_command),
            observation=observation,
            action_repeat=action_repeat,
            residual_penalty=residual_penalty,
            base_kwargs=dict(base_kwargs or {}),
            residual_axes=residual_axes,
        )
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{WRAPPER_NAME}: {exc}") from None


# --- reading a finished zoo run ---------------------------------------------------------------


def latest_run(log_folder, algo: str, env_id: str) -> Path:
    """The newest run of ``algo`` on ``env_id`` under the zoo's ``--log-folder`` (the highest
    ``ENV_NAME_N``, what ``rl_zoo3.enjoy --exp-id 0`` picks)."""
    name = env_id.replace("/", "-")
    base = Path(log_folder) / algo
    runs = []
    for d in base.glob(f"{name}_*") if base.is_dir() else ():
        n = d.name[len(name) + 1 :].split("_")[0]
        if d.is_dir() and n.isdigit():
            runs.append((int(n), d))
    if not runs:
        raise FileNotFoundError(f"zoo run: no {algo} run of {env_id} in {base}")
    return max(runs)[1]


def _run_loader():
    """Safe YAML loader for the zoo's ``config.yml``/``args.yml`` (dumped with ``yaml.dump``:
    OrderedDicts and tuples as Python tags); nothing else is constructed. PyYAML comes with
    rl_zoo3, so it is imported here, not at module import."""
    import yaml

    class RunLoader(yaml.SafeLoader):
        pass

    def ordered_dict(loader, node):
        args = loader.construct_sequence(node, deep=True)
        return {k: v for k, v in (args[0] if args else [])}

    def as_tuple(loader, node):
        return tuple(loader.construct_sequence(node, deep=True))

    RunLoader.add_constructor(
        "tag:yaml.org,2002:python/object/apply:collections.OrderedDict", ordered_dict
    )
    RunLoader.add_constructor("tag:yaml.org,2002:python/tuple", as_tuple)
    return RunLoader


def _read_yaml(path: Path) -> dict:
    import yaml

    try:
        data = yaml.load(path.read_text(), Loader=_run_loader())  # a SafeLoader subclass
    except yaml.YAMLError as exc:
        raise ValueError(f"zoo run: {path} cannot be read ({exc})") from None
    if not isinstance(data, dict):
        raise ValueError(f"zoo run: {path} is not a mapping")
    return data


class ZooRun:
    """A finished ``rl_zoo3.train`` run: ``ZooRun(path)`` with ``path`` the run folder
    (``LOG_FOLDER/ALGO/ENV_NAME_N``) or a model ``.zip`` in it (default model: the final
    ``ENV_NAME.zip``).

    Attributes: ``folder``, ``model_path``, ``algo``, ``env_id``, ``env_kwargs`` (what the
    run's env was built with), ``hyperparams`` (the saved ``config.yml``), ``wrapper_kwargs``
    (the :func:`residual_wrapper` keywords; None for a plain run), ``residual`` (bool),
    ``normalize_path`` (``vecnormalize.pkl`` or None).
    """

    def __init__(self, path):
        p = Path(path)
        if p.is_file() and p.suffix == ".zip":
            folder, model = p.parent, p
        elif p.is_dir():
            folder, model = p, None
        else:
            raise FileNotFoundError(
                f"zoo run: {p} is neither a run folder (LOG_FOLDER/ALGO/ENV_NAME_N) nor a "
                "model .zip in one"
            )
        params = [d for d in folder.iterdir() if d.is_dir() and (d / "config.yml").is_file()]
        if len(params) != 1:
            raise ValueError(
                f"zoo run: {folder} should hold exactly one ENV_NAME/config.yml folder "
                f"(found {len(params)}); give the run folder LOG_FOLDER/ALGO/ENV_NAME_N"
            )
        params_dir = params[0]
        if model is None:
            model = folder / f"{params_dir.name}.zip"
            if not model.is_file():
                raise FileNotFoundError(
                    f"zoo run: no final model {model} (training not finished?); give a .zip "
                    "of the run (best_model.zip, rl_model_*_steps.zip) instead"
                )
        self.folder = folder
        self.model_path = model
        self.hyperparams = _read_yaml(params_dir / "config.yml")
        args_path = params_dir / "args.yml"
        args = _read_yaml(args_path) if args_path.is_file() else {}
        self.algo = str(args.get("algo") or "")
        if self.algo not in ALGOS:
            raise ValueError(
                f"zoo run: algorithm {self.algo!r} in {args_path}; this bridge reads "
                f"{', '.join(ALGOS)} runs"
            )
        self.env_id = str(args.get("env") or "")
        self.env_kwargs = dict(self.hyperparams.get("env_kwargs") or args.get("env_kwargs") or {})
        self.wrapper_kwargs = _wrapper_kwargs(self.hyperparams.get("env_wrapper"), args_path)
        self.residual = self.wrapper_kwargs is not None
        norm = params_dir / "vecnormalize.pkl"
        self.normalize_path = norm if norm.is_file() else None
        if self.hyperparams.get("normalize") and self.normalize_path is None:
            raise FileNotFoundError(f"zoo run: normalize is on but {norm} is missing")

    def make_env(self):
        """The run's env (the plain contour_env env, built with the run's ``env_kwargs``)."""
        import gymnasium as gym

        return gym.make(ENV_ID, **self.env_kwargs)

    def normalizer(self):
        """The observation transform of the saved statistics (identity without them)."""
        if self.normalize_path is None:
            return lambda x: np.asarray(x, dtype=np.float32)
        from ..rl.checkpoint import normalizer_of

        with open(self.normalize_path, "rb") as f:
            vecnormalize = pickle.load(f)  # the zoo's own file (sb3 VecNormalize, no env)
        if not getattr(vecnormalize, "norm_obs", True):
            return lambda x: np.asarray(x, dtype=np.float32)
        return normalizer_of(vecnormalize)

    def load_model(self, device: str = "cpu"):
        from ..rl.checkpoint import load_model

        return load_model(self.model_path, self.algo, device=device)

    def residual_metadata(self, model) -> dict:
        """``agent.json`` content (:data:`agents.residual.MODEL_FORMAT`) of a residual run."""
        if not self.residual:
            raise ValueError(
                f"zoo run: {self.folder} is a plain run (no {WRAPPER_NAME} env_wrapper); "
                "load it with load_agent (a ZooAgent), not as a residual agent"
            )
        env = self.make_env()
        wrapped = residual_wrapper(env, **self.wrapper_kwargs)
        _, core = core_of(env)
        obs_dim = int(wrapped.observation_space.shape[0])
        model_dim = int(model.observation_space.shape[0])
        if obs_dim != model_dim:
            raise ValueError(
                f"zoo run: the model sees {model_dim} observation fields, the run's residual "
                f"env has {obs_dim}"
            )
        return {
            "format": MODEL_FORMAT,
            "algo": self.algo,
            "plant": core.setup.plant.name,
            "n_axes": int(core.dim),
            "obs_dim": obs_dim,
            "base": self.wrapper_kwargs.get("base", "pd"),
            "base_kwargs": dict(self.wrapper_kwargs.get("base_kwargs") or {}),
            "scale": float(wrapped.scale),
            "observe_base_command": bool(wrapped.observe_base_command),
            "observation": wrapped.observation,
            "residual_axes": wrapped.residual_axes,
            "action_repeat": int(wrapped.action_repeat),
            "servo_period_s": float(core.T),
            "cases": [self.env_kwargs["case"]] if "case" in self.env_kwargs else [],
            "gcode": [],
            "timesteps": int(getattr(model, "num_timesteps", 0)),
            "seed": model.seed if isinstance(model.seed, int) else None,
            "source": f"rl_zoo3 run {self.folder.resolve()} ({self.model_path.name})",
        }


def _wrapper_kwargs(spec, where) -> dict | None:
    """The residual_wrapper keywords of a saved ``env_wrapper`` (None if there is none)."""
    if spec is None:
        return None
    items = spec if isinstance(spec, list) else [spec]
    found = None
    for item in items:
        name, kwargs = next(iter(item.items())) if isinstance(item, dict) else (item, {})
        if name == WRAPPER_NAME:
            found = dict(kwargs or {})
        else:
            raise ValueError(
                f"zoo run: env_wrapper {name!r} in {where}; this bridge rebuilds only "
                f"{WRAPPER_NAME}"
            )
    return found


class ZooAgent(Controller):
    """A plain zoo agent (its action is the whole command) as a controller: reads the bound
    env's current observation, normalises it with the run's statistics, and returns the
    model's deterministic action × force limit. Made by :func:`load_agent`."""

    name = "zoo"

    def __init__(self, model, normalizer, *, deterministic: bool = True, source: str = ""):
        super().__init__()
        self.model = model
        self.norm = normalizer
        self.deterministic = bool(deterministic)
        self.source = source

    def bind(self, env) -> ZooAgent:
        _, core = core_of(env)
        want = int(self.model.observation_space.shape[0])
        if core.obs_dim != want:
            raise ValueError(
                f"env: observation size {core.obs_dim} differs from the agent's {want} "
                "(another plant, axis count or preview_times_s)"
            )
        super().bind(env)
        return self

    def applied_action(self, signals: dict) -> np.ndarray:
        if self._core is None:
            raise ValueError("zoo agent: call bind(env) first")
        from contour_env.env.core import signals_to_batch

        B = np.shape(signals_to_batch(signals)["measured_position"])[0]
        x = self.norm(self._core.obs[:B])
        a, _ = self.model.predict(x, deterministic=self.deterministic)
        return np.clip(np.asarray(a, dtype=np.float64).reshape(B, -1), -1.0, 1.0)

    def act(self, signals: dict) -> np.ndarray:
        return self.applied_action(signals) * self.force_limit

    def action(self, signals: dict) -> np.ndarray:
        return self.applied_action(signals)


def load_agent(path, *, deterministic: bool = True, device: str = "cpu") -> Controller:
    """A finished zoo run (folder or model ``.zip``, see :class:`ZooRun`) as a controller for
    :func:`contour_env.evaluation.evaluate`: a :class:`agents.residual.ResidualAgent` for a
    run with the :func:`residual_wrapper` ``env_wrapper`` (on the base and law of its
    ``config.yml``), a :class:`ZooAgent` for a plain run."""
    run = ZooRun(path)
    model = run.load_model(device)
    if run.residual:
        agent = ResidualAgent.from_parts(
            run.residual_metadata(model), model, run.normalizer(), deterministic=deterministic
        )
        agent.model_dir = run.folder
        return agent
    return ZooAgent(
        model, run.normalizer(), deterministic=deterministic, source=str(run.model_path)
    )


def export_agent(path, out_dir) -> Path:
    """Write a residual zoo run as a model DIR of ``contour-env train``'s format
    (``agent.json``, ``model.zip``, ``normalization.json``), scored by ``contour-env evaluate
    --model OUT`` and the ``residual`` row of ``contour-env compare --model OUT``."""
    run = ZooRun(path)
    model = run.load_model()
    meta = run.residual_metadata(model)
    # the same transform ResidualAgent applies (identity statistics when normalize is off)
    norm = run.normalizer()
    if hasattr(norm, "to_dict"):
        norm_dict = norm.to_dict()
    else:
        n = meta["obs_dim"]
        norm_dict = {"mean": [0.0] * n, "var": [1.0] * n, "clip_obs": 1e30, "epsilon": 0.0}
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(run.model_path, out / "model.zip")
    (out / "normalization.json").write_text(json.dumps(norm_dict, indent=2) + "\n")
    (out / "agent.json").write_text(json.dumps(meta, indent=2) + "\n")
    return out
