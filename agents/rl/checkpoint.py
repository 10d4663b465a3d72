"""Model files, normalisation statistics and atomic, verified checkpoints.

A checkpoint is a directory ``checkpoints/step_<timesteps>`` holding ``model.zip`` (sb3's
format; for the JAX algorithms ``sbx-*`` the same zip with the flax parameters pickled in its
``data`` entry instead of torch state dicts), ``vecnormalize.pkl`` (sb3's VecNormalize, for
resuming), ``normalization.json`` (the same observation statistics as plain numbers, what
:class:`agents.residual.ResidualAgent` reads), ``replay_buffer.pkl`` (the off-policy
algorithms), ``state.json`` (timesteps, learning curve so far) and ``manifest.json`` (size and
SHA-256 of every file). It is written into a temporary directory that is renamed into place
only once complete (``os.replace`` on the same filesystem), so an interrupted write never
leaves a ``step_*`` directory; the oldest checkpoints beyond ``keep_checkpoints`` are deleted
only after a new one is in place. On ``--resume`` the newest checkpoint is verified against
its manifest: a corrupt or half-written one is a clear error that names it and the previous
(intact) checkpoint, which is left untouched.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np

from agents.algos import JAX_ALGOS, SB3_ALGOS
from contour_env.io import apply_default_mode, atomic_write_json

MANIFEST = "manifest.json"
CHECKPOINT_PREFIX = "step_"


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


SBX_ALGOS = JAX_ALGOS
JAX_EXTRA = 'pip install -e ".[jax]"'


def sbx_module():
    """The ``sbx`` package (imported on first use: JAX starts in seconds, not needed by sb3
    runs); without it a ``ValueError`` that names the extra."""
    try:
        import sbx
    except ImportError as exc:
        raise ValueError(
            f"--algo sbx-sac / sbx-ppo: the JAX implementation sbx-rl is not installed "
            f"({type(exc).__name__}: {exc}); install the optional extra with {JAX_EXTRA}, or "
            "use --algo sac / td3 / ppo (stable-baselines3)"
        ) from None
    return sbx


def algo_class(algo: str):
    """The model class of ``algo``: sb3's SAC, TD3, PPO, or sbx's SAC, PPO (``sbx-*``)."""
    if algo in SBX_ALGOS:
        sbx = sbx_module()
        return {"sbx-sac": sbx.SAC, "sbx-ppo": sbx.PPO}[algo]
    from stable_baselines3 import PPO, SAC, TD3

    classes = {"sac": SAC, "td3": TD3, "ppo": PPO}
    if algo not in classes:
        raise ValueError(f"algo: must be one of {', '.join(SB3_ALGOS + SBX_ALGOS)}, got {algo!r}")
    return classes[algo]


def load_model(path, algo: str, *, env=None, device: str = "cpu"):
    """An sb3 (or sbx, ``algo`` ``sbx-*``) model from ``path`` (a .zip); a damaged file is a
    ``ValueError`` naming it, and so is an sbx model without the ``[jax]`` extra."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"model: no such file {path}")
    if algo in SBX_ALGOS:
        try:
            sbx_module()
        except ValueError as exc:
            raise ValueError(f"model: {path} is an {algo} model (JAX); {exc}") from None
    from agents.model_files import check_model_zip

    check_model_zip(path)
    try:
        return algo_class(algo).load(path, env=env, device=device)
    except FileNotFoundError:
        raise
    except ValueError as exc:  # a JSON error in another member, a shape mismatch ...
        raise ValueError(f"model: {path} cannot be loaded ({type(exc).__name__}: {exc})") from None
    except Exception as exc:  # zipfile.BadZipFile, pickle / torch errors
        raise ValueError(f"model: {path} cannot be loaded ({type(exc).__name__}: {exc})") from None


class ObsNormalizer:
    """VecNormalize's observation transform: clip((x − mean) / sqrt(var + eps), ±clip)."""

    def __init__(self, mean, var, clip_obs: float, epsilon: float):
        self.mean = np.asarray(mean, dtype=np.float64)
        self.var = np.asarray(var, dtype=np.float64)
        self.clip_obs = float(clip_obs)
        self.epsilon = float(epsilon)

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        x = (np.asarray(obs, dtype=np.float64) - self.mean) / np.sqrt(self.var + self.epsilon)
        return np.clip(x, -self.clip_obs, self.clip_obs).astype(np.float32)

    def to_dict(self) -> dict:
        return {
            "mean": self.mean.tolist(),
            "var": self.var.tolist(),
            "clip_obs": self.clip_obs,
            "epsilon": self.epsilon,
        }


def normalizer_of(vecnormalize) -> ObsNormalizer:
    rms = vecnormalize.obs_rms
    return ObsNormalizer(rms.mean, rms.var, vecnormalize.clip_obs, vecnormalize.epsilon)


def load_normalization(path, obs_dim: int | None = None) -> ObsNormalizer:
    """The observation statistics in ``normalization.json``, checked key by key
    (:func:`agents.model_files.read_normalization`; ``obs_dim``: agent.json's)."""
    from agents.model_files import read_normalization

    path = Path(path)
    if not path.is_file() and not path.is_dir():
        raise FileNotFoundError(f"model: no normalisation statistics {path}")
    d = read_normalization(path, obs_dim)
    return ObsNormalizer(d["mean"], d["var"], d["clip_obs"], d["epsilon"])


def write_manifest(folder: Path) -> None:
    files = {}
    for p in sorted(folder.iterdir()):
        if p.is_file() and p.name != MANIFEST:
            files[p.name] = {"bytes": p.stat().st_size, "sha256": _sha256(p)}
    atomic_write_json(folder / MANIFEST, {"files": files})


def verify(folder: Path) -> None:
    """Raise ``ValueError`` if ``folder`` is not a complete checkpoint."""
    man = folder / MANIFEST
    if not man.is_file():
        raise ValueError(f"{folder}: no {MANIFEST} (half-written)")
    try:
        files = json.loads(man.read_text())["files"]
    except (json.JSONDecodeError, KeyError, TypeError) as exc:
        raise ValueError(f"{folder}: {MANIFEST} is damaged ({exc})") from None
    for name, entry in files.items():
        p = folder / name
        if not p.is_file():
            raise ValueError(f"{folder}: {name} is missing")
        if p.stat().st_size != entry["bytes"] or _sha256(p) != entry["sha256"]:
            raise ValueError(f"{folder}: {name} does not match its checksum (corrupt)")


def checkpoint_dirs(root: Path) -> list[Path]:
    """``step_*`` checkpoints under ``root``, oldest first."""
    if not root.is_dir():
        return []
    found = []
    for p in root.iterdir():
        if p.is_dir() and p.name.startswith(CHECKPOINT_PREFIX):
            try:
                found.append((int(p.name[len(CHECKPOINT_PREFIX) :]), p))
            except ValueError:
                continue
    return [p for _, p in sorted(found)]


def write_checkpoint(root: Path, timesteps: int, writer, keep: int) -> Path:
    """Create ``root/step_<timesteps>`` atomically: ``writer(tmp_dir)`` fills a temporary
    directory, a manifest is added, and the directory is renamed into place."""
    root.mkdir(parents=True, exist_ok=True)
    final = root / f"{CHECKPOINT_PREFIX}{timesteps:012d}"
    tmp = Path(tempfile.mkdtemp(prefix=".tmp-", dir=root))
    try:
        apply_default_mode(tmp, directory=True)  # mkdtemp's 0700 → as the umask says
        writer(tmp)
        write_manifest(tmp)
        for p in tmp.iterdir():
            with open(p, "rb") as fh:
                os.fsync(fh.fileno())
        if final.exists():
            shutil.rmtree(final)
        os.replace(tmp, final)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    for old in checkpoint_dirs(root)[:-keep]:
        shutil.rmtree(old, ignore_errors=True)
    return final


def latest_checkpoint(root: Path) -> Path | None:
    """The newest checkpoint, verified. A damaged newest checkpoint raises ``ValueError``
    naming it and the previous one (both left as they are)."""
    dirs = checkpoint_dirs(root)
    if not dirs:
        return None
    newest = dirs[-1]
    try:
        verify(newest)
    except ValueError as exc:
        prev = dirs[-2] if len(dirs) > 1 else None
        hint = (
            f"the previous checkpoint {prev} is kept; delete {newest} to resume from it"
            if prev is not None
            else "there is no earlier checkpoint; delete it and train without --resume"
        )
        raise ValueError(f"checkpoint: {exc}; {hint}") from None
    return newest
