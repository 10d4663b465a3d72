"""The RL algorithms a residual agent trains with, by name (``TrainConfig.algo``,
``contour-env train --algo``, a checkpoint's ``algo``). No imports: the CLI reads these
names without the RL stack."""

#: stable-baselines3's (PyTorch) implementations.
SB3_ALGOS = ("sac", "td3", "ppo")
#: The JAX implementations (sbx-rl, the optional extra ``pip install -e ".[jax]"``): sb3's
#: classes, API and model.zip, flax parameters inside (docs/RESIDUAL_TRAINING.md, "JAX").
JAX_ALGOS = ("sbx-sac", "sbx-ppo")
ALGOS = SB3_ALGOS + JAX_ALGOS
#: On-policy algorithms: rollouts of ``ppo_n_steps`` per env, no replay buffer.
ON_POLICY = ("ppo", "sbx-ppo")
