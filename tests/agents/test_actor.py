"""The NumPy actor (agents.rl.actor) gives sb3's deterministic action to float32 rounding."""

import numpy as np
import pytest
import torch
from gymnasium import spaces

from agents.rl.actor import numpy_actor


class _Env:
    """The spaces sb3 needs to build a model (never stepped)."""

    def __init__(self, n_obs, n_act):
        import gymnasium as gym

        class E(gym.Env):
            observation_space = spaces.Box(-10, 10, (n_obs,), dtype=np.float32)
            action_space = spaces.Box(-1, 1, (n_act,), dtype=np.float32)

            def reset(self, *, seed=None, options=None):
                return np.zeros(n_obs, dtype=np.float32), {}

            def step(self, action):
                return np.zeros(n_obs, dtype=np.float32), 0.0, False, False, {}

        self.env = E()


@pytest.mark.parametrize("algo", ["sac", "td3", "ppo"])
@pytest.mark.parametrize("net_arch", [[16], [64, 64]])
def test_numpy_actor_matches_sb3_predict(algo, net_arch):
    from stable_baselines3 import PPO, SAC, TD3

    cls = {"sac": SAC, "td3": TD3, "ppo": PPO}[algo]
    torch.manual_seed(0)
    model = cls(
        "MlpPolicy", _Env(7, 3).env, seed=0, device="cpu", policy_kwargs={"net_arch": net_arch}
    )
    # weights large enough that the squash and the clip are exercised
    with torch.no_grad():
        for p in model.policy.parameters():
            p.mul_(4.0)
    rng = np.random.default_rng(1)
    x = rng.normal(size=(256, 7)).astype(np.float32) * 3
    want, _ = model.predict(x, deterministic=True)
    got = numpy_actor(model)(x)
    assert got.shape == (256, 3) and got.dtype == np.float64
    assert np.all(np.abs(got) <= 1.0)
    np.testing.assert_allclose(got, want, rtol=0, atol=2e-5)
    if algo != "ppo":  # (PPO's action layer starts 100x smaller: no saturation here)
        assert np.mean(np.abs(got) > 0.99) > 0.05  # saturated actions are in the sample


def test_an_unknown_model_is_refused():
    with pytest.raises(ValueError, match="SAC, TD3 or PPO"):
        numpy_actor(object())
