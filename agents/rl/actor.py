"""A trained policy's deterministic action as a few NumPy matrix products.

stable-baselines3's ``model.predict`` costs 0.1–0.4 ms a call on these machines (tensor
conversion, mode switches, checks) for networks of two 64-unit layers whose arithmetic is a
few microseconds; an agent that acts every servo period calls it thousands of times per
part. :func:`numpy_actor` reads the actor's layers once and evaluates them in float32 with
NumPy, the deterministic action of each algorithm:

- SAC: tanh(mu(latent_pi(x))) (the squashed Gaussian's mode);
- TD3: mu(x) (its last layer is a tanh);
- PPO: action_net(policy_net(x)) (the Gaussian's mean), clipped to [−1, 1] as sb3 clips it.

The result agrees with ``model.predict(x, deterministic=True)`` to float32 rounding
(``tests/agents/test_actor.py``); every path of :class:`agents.residual.ResidualAgent` — the
Python loop, the compiled loop, the trainer's validation — uses this one function, so they
agree with each other to the bit.
"""

from __future__ import annotations

import numpy as np


def _layers(module) -> list:
    """(kind, W, b) for each Linear / ReLU / Tanh of a torch module, in order."""
    import torch.nn as nn

    out = []
    for m in module.modules():
        if isinstance(m, nn.Linear):
            out.append(
                (
                    "linear",
                    m.weight.detach().cpu().numpy().astype(np.float32).T.copy(),
                    m.bias.detach().cpu().numpy().astype(np.float32).copy(),
                )
            )
        elif isinstance(m, nn.ReLU):
            out.append(("relu", None, None))
        elif isinstance(m, nn.Tanh):
            out.append(("tanh", None, None))
        elif isinstance(m, (nn.Sequential, nn.Flatten, nn.Identity)) or m is module:
            continue
        elif len(list(m.children())) == 0:
            raise ValueError(f"actor: layer {type(m).__name__} is not supported")
    return out


def _apply(layers, x):
    for kind, W, b in layers:
        if kind == "linear":
            x = x @ W
            x += b
        elif kind == "relu":
            np.maximum(x, 0.0, out=x)
        else:
            np.tanh(x, out=x)
    return x


class NumpyActor:
    """``actor(x)``: (B, obs) float32 → (B, n_act) float64 actions in [−1, 1]."""

    def __init__(self, layers, squash: bool):
        self.layers = layers
        self.squash = squash

    def __call__(self, x) -> np.ndarray:
        y = _apply(self.layers, np.asarray(x, dtype=np.float32))
        if self.squash:
            y = np.tanh(y)
        return np.clip(y.astype(np.float64), -1.0, 1.0)


def numpy_actor(model) -> NumpyActor:
    """The deterministic actor of an sb3 SAC, TD3 or PPO model (MLP policy, no gSDE)."""
    from stable_baselines3 import PPO, SAC, TD3

    if isinstance(model, SAC):
        actor = model.policy.actor
        if actor.use_sde:
            raise ValueError("actor: gSDE policies are not supported")
        return NumpyActor(_layers(actor.latent_pi) + _layers(actor.mu), squash=True)
    if isinstance(model, TD3):
        return NumpyActor(_layers(model.policy.actor.mu), squash=False)
    if isinstance(model, PPO):
        pol = model.policy
        return NumpyActor(
            _layers(pol.mlp_extractor.policy_net) + _layers(pol.action_net), squash=False
        )
    raise ValueError(f"actor: expected an sb3 SAC, TD3 or PPO model, got {type(model).__name__}")
