"""Training residual agents with stable-baselines3 (see :mod:`agents.rl.trainer`).

``TrainConfig`` (the configuration), ``train`` (the run), ``TaskSampler`` (domain
randomisation), ``generate_path`` / ``validation_set`` (training path families and the
validation set, :mod:`agents.rl.families`; keep-best in :mod:`agents.rl.validation`),
``ResidualTrainVecEnv`` (the sb3 VecEnv), checkpoints in :mod:`agents.rl.checkpoint`.
stable-baselines3 and torch are imported lazily by ``train``.
"""

from .config import ALGOS, PATH_VARIETY, TrainConfig, load_config
from .families import FAMILIES, generate_path, validation_set

__all__ = [
    "ALGOS",
    "FAMILIES",
    "PATH_VARIETY",
    "TrainConfig",
    "generate_path",
    "load_config",
    "train",
    "validation_set",
]


def train(*args, **kwargs):
    from .trainer import train as _train

    return _train(*args, **kwargs)
