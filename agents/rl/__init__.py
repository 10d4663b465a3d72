"""Training residual agents with stable-baselines3 (see :mod:`agents.rl.trainer`).

``TrainConfig`` (the configuration), ``train`` (the run), ``TaskSampler`` (domain
randomisation), ``ResidualTrainVecEnv`` (the sb3 VecEnv), checkpoints in
:mod:`agents.rl.checkpoint`. stable-baselines3 and torch are imported lazily by ``train``.
"""

from .config import ALGOS, PATH_VARIETY, TrainConfig, load_config

__all__ = ["ALGOS", "PATH_VARIETY", "TrainConfig", "load_config", "train"]


def train(*args, **kwargs):
    from .trainer import train as _train

    return _train(*args, **kwargs)
