"""A trained policy's deterministic action as a few NumPy matrix products.

stable-baselines3's ``model.predict`` costs 0.1–0.4 ms a call on these machines (tensor
conversion, mode switches, checks) for networks of two 64-unit layers whose arithmetic is a
few microseconds; an agent that acts every servo period calls it thousands of times per
part. :func:`numpy_actor` reads the actor's layers once and evaluates them in float32 with
NumPy, the deterministic action of each algorithm:

- SAC: tanh(mu(latent_pi(x))) (the squashed Gaussian's mode);
- TD3: mu(x) (its last layer is a tanh);
- PPO: action_net(policy_net(x)) (the Gaussian's mean), clipped to [−1, 1] as sb3 clips it.

The same for the JAX implementations (sbx-rl, algorithms ``sbx-sac`` and ``sbx-ppo``), read
from the actor's flax parameters (``policy.actor_state.params``: ``Dense_0`` … ``Dense_{k-1}``
the hidden layers of ``net_arch``, ``Dense_k`` the Gaussian's mean):

- sbx SAC: tanh(mean(x)) (``TanhTransformedDistribution.mode``);
- sbx PPO: mean(x), clipped to [−1, 1] as its ``predict`` clips it.

The result agrees with ``model.predict(x, deterministic=True)`` to float32 rounding
(``tests/agents/test_actor.py``, ``tests/agents/test_sbx.py``); every path of
:class:`agents.residual.ResidualAgent` — the Python loop, the compiled loop, the trainer's
validation — uses this one function, so they agree with each other to the bit, and an sbx
agent acts without a JAX call per step (loading its ``model.zip`` still needs sbx).
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


def _tanh_rows(x) -> None:
    """tanh in place, row by row: NumPy's float32 tanh takes a SIMD loop or a scalar one
    depending on where an element falls in the array, which can differ by one unit in the
    last place; row by row, a row's result is the same alone or in a batch (what lets
    :mod:`agents.compiled.residual_batch` score several parts at once to the bit)."""
    if x.shape[0] == 1:
        np.tanh(x, out=x)
    else:
        for row in x:
            np.tanh(row, out=row)


def _apply(layers, x):
    for kind, W, b in layers:
        if kind == "linear":
            x = x @ W
            x += b
        elif kind == "relu":
            np.maximum(x, 0.0, out=x)
        else:
            _tanh_rows(x)
    return x


class NumpyActor:
    """``actor(x)``: (B, obs) float32 → (B, n_act) float64 actions in [−1, 1]."""

    def __init__(self, layers, squash: bool):
        self.layers = layers
        self.squash = squash

    def __call__(self, x) -> np.ndarray:
        y = _apply(self.layers, np.asarray(x, dtype=np.float32))
        if self.squash:
            y = y.copy()
            _tanh_rows(y)
        # np.clip's value, without its Python wrapper (a few µs a call)
        out = y.astype(np.float64)
        np.maximum(out, -1.0, out=out)
        np.minimum(out, 1.0, out=out)
        return out


def _is_sbx(model) -> bool:
    """Whether ``model`` is an sbx model (without importing sbx, hence JAX, otherwise)."""
    return any(c.__module__.split(".")[0] == "sbx" for c in type(model).__mro__)


def _activation(fn) -> str:
    """ "relu" or "tanh": which one a flax activation function computes (probed, so that any
    alias of it — flax.linen, jax.nn, jax.numpy — is recognised)."""
    x = np.array([-2.0, -0.5, 0.0, 0.5, 2.0], dtype=np.float32)
    try:
        y = np.asarray(fn(x), dtype=np.float64)
    except Exception:  # noqa: BLE001 - any failure: not one of ours
        y = None
    if y is not None and y.shape == x.shape:
        if np.allclose(y, np.maximum(x, 0.0), atol=1e-6):
            return "relu"
        if np.allclose(y, np.tanh(x), atol=1e-6):
            return "tanh"
    raise ValueError(f"actor: activation {fn!r} is not supported (relu or tanh)")


def _sbx_actor(model) -> NumpyActor:
    """The deterministic actor of an sbx SAC or PPO model (MLP policy, no gSDE)."""
    import sbx
    from sbx.common.policies import SquashedGaussianActor
    from sbx.ppo.policies import Actor as PPOActor

    pol = model.policy
    if getattr(pol, "use_sde", False):
        raise ValueError("actor: gSDE policies are not supported")
    if isinstance(model, sbx.SAC):
        want, squash = SquashedGaussianActor, True
    elif isinstance(model, sbx.PPO):
        want, squash = PPOActor, False
        if getattr(pol, "features_extractor_class", None) is not None:
            raise ValueError("actor: sbx PPO with a features extractor is not supported")
    else:
        raise ValueError(f"actor: expected an sbx SAC or PPO model, got {type(model).__name__}")
    if pol.actor_class is not want:
        raise ValueError(f"actor: sbx actor {pol.actor_class.__name__} is not supported")
    params = pol.actor_state.params["params"]
    act = _activation(pol.activation_fn)
    layers = []
    n_hidden = len(pol.net_arch_pi)
    for i in range(n_hidden + 1):  # the hidden layers, then the mean
        dense = params[f"Dense_{i}"]
        layers.append(
            (
                "linear",
                np.asarray(dense["kernel"], dtype=np.float32).copy(),
                np.asarray(dense["bias"], dtype=np.float32).copy(),
            )
        )
        if i < n_hidden:
            layers.append((act, None, None))
    return NumpyActor(layers, squash=squash)


def numpy_actor(model) -> NumpyActor:
    """The deterministic actor of an sb3 SAC, TD3 or PPO model, or of an sbx SAC or PPO model
    (MLP policy, no gSDE)."""
    if _is_sbx(model):
        return _sbx_actor(model)
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
    raise ValueError(
        f"actor: expected an sb3 SAC, TD3 or PPO model (or sbx SAC, PPO), got "
        f"{type(model).__name__}"
    )
