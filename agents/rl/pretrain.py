"""The student: a residual actor pretrained on the teacher's data, a critic warmed on it
(issue 48; the teacher and the data in :mod:`agents.teacher`, :mod:`agents.rl.teacher_data`).

1. **Observation statistics** from the teacher's observations: the VecNormalize mean and
   variance the actor will see its inputs through (RL then keeps updating them, as before).
2. **Actor regression.** The deterministic action of the policy (SAC: tanh(μ(x)); TD3: μ(x);
   PPO: the Gaussian's mean, clipped) is fitted to the teacher's action where the residual
   acts (the reference moves), by the loss on what the action *does* rather than on its
   components: with the push p̂ = a_p / max(1, ‖a_p‖) (path frame; the axes frame: a_p) and the
   gate g = clip(a_g, 0, 1),

       L = mean ‖g p̂ − g* p*‖² / mean ‖g* p*‖²  (+ 0.1 · mean (a_g − 0.9)² with a gate),

   so that a push and a gate that give the teacher's residual are equally right; the small
   second term keeps the gate open (0.9) where the teacher pushes, leaving the actor room to
   close it. SAC's log-σ head is fitted to log σ = −2.5 (a spread of 8 % of the action range:
   RL starts exploring near the teacher, not at sb3's initial σ ≈ 1). Adam, lr 1e-3, batches
   of 1024 drawn with the run's own cases and G-code files weighing a quarter
   (:data:`NOMINAL_SHARE`), the generated parts split 90/10: the epoch with the lowest loss on
   the held-back parts is kept (at most :data:`BC_EPOCHS` epochs or ``seconds``, and
   :data:`BC_PATIENCE` epochs after the best: on the plants' families the best epoch was the 2nd
   to the 6th).
3. **Critic warm start** (SAC): the teacher's transitions go into the replay buffer, and the
   critics take ``critic_steps`` gradient steps of SAC's soft Bellman loss (targets from the
   pretrained actor, sb3's target networks and entropy coefficient) with the actor frozen —
   so the first policy updates follow a critic that has seen the teacher's actions and their
   rewards, not a random one that would undo the regression. TD3: the buffer only. PPO: the
   actor only.

The learner's entropy coefficient starts at :data:`TEACHER_ENT_COEF_INIT` (sb3's
``"auto_0.01"``) after a teacher, instead of sb3's 1: with rewards of −1 per step at the base's
error, an entropy bonus of 1 per nat would pull the policy away from the teacher at once.
"""

from __future__ import annotations

import time

import numpy as np

BC_EPOCHS = 60
# the share of the regression's samples drawn from the run's own training cases and G-code
# files (the teacher's other parts: generated ones): a run asked to train on lm-circle3d
# regressed it as one part of 60 and kept a student 0.88x CCC there (0.43x on validation)
NOMINAL_SHARE = 0.25
# stop after this many epochs without a lower loss on the held-back parts
BC_PATIENCE = 6
BC_BATCH = 1024
BC_LR = 1e-3
LOG_STD_TARGET = -2.5
GATE_TARGET = 0.9
GATE_WEIGHT = 0.1
TEACHER_ENT_COEF_INIT = "auto_0.01"
DEFAULT_CRITIC_STEPS = 3000


def set_statistics(venv, obs: np.ndarray) -> None:
    """VecNormalize's observation mean and variance from the teacher's observations."""
    rms = venv.obs_rms
    rms.mean = np.asarray(obs.mean(axis=0), dtype=np.float64)
    rms.var = np.asarray(obs.var(axis=0), dtype=np.float64)
    rms.count = float(obs.shape[0])


def _normalize(venv, obs: np.ndarray) -> np.ndarray:
    return np.asarray(venv.normalize_obs(obs), dtype=np.float32)


def _deterministic(model, x):
    """(action, log_std or None) of the policy for normalised observations ``x`` (torch)."""
    import torch
    from stable_baselines3 import PPO, SAC, TD3

    if isinstance(model, SAC):
        actor = model.policy.actor
        latent = actor.latent_pi(actor.extract_features(x, actor.features_extractor))
        return torch.tanh(actor.mu(latent)), actor.log_std(latent)
    if isinstance(model, TD3):
        actor = model.policy.actor
        return actor.mu(actor.extract_features(x, actor.features_extractor)), None
    if isinstance(model, PPO):
        pol = model.policy
        latent = pol.mlp_extractor.forward_actor(pol.extract_features(x, pol.pi_features_extractor))
        return torch.clamp(pol.action_net(latent), -1.0, 1.0), None
    raise ValueError(f"teacher: pretraining takes sb3 sac, td3 or ppo, not {type(model).__name__}")


def _actor_parameters(model):
    from stable_baselines3 import PPO, SAC, TD3

    if isinstance(model, SAC):
        return list(model.policy.actor.parameters())
    if isinstance(model, TD3):
        return list(model.policy.actor.parameters())
    if isinstance(model, PPO):
        pol = model.policy
        return list(pol.mlp_extractor.policy_net.parameters()) + list(pol.action_net.parameters())
    raise ValueError(f"teacher: pretraining takes sb3 sac, td3 or ppo, not {type(model).__name__}")


def _effective(a, n: int, gate: bool, path_frame: bool):
    """g p̂ of actions ``a`` (torch, (B, n [+1]))."""
    import torch

    p = a[:, :n]
    if path_frame:
        norm = torch.sqrt(torch.sum(p * p, dim=1, keepdim=True))
        p = p / torch.clamp(norm, min=1.0)
    if gate:
        p = p * torch.clamp(a[:, n : n + 1], 0.0, 1.0)
    return p


def pretrain_actor(
    model, venv, data, *, n_axes: int, gate: bool, path_frame: bool, seed: int = 0,
    seconds: float | None = None, log=None,
) -> dict:  # fmt: skip
    """Fit the policy's deterministic action to the teacher's (module docstring, step 2);
    returns {"epochs", "loss", "validation_loss", "seconds"}."""
    import torch

    t0 = time.perf_counter()
    x_all = _normalize(venv, data.obs)
    mask = data.weight > 0
    nominal = set(getattr(data, "nominal_parts", ()) or ())
    parts = np.array([p for p in np.unique(data.part[mask]) if p not in nominal])
    rng = np.random.default_rng(seed)
    held = set()
    if len(parts) >= 2:
        held = set(rng.choice(parts, size=max(1, len(parts) // 10), replace=False).tolist())
    is_held = np.array([p in held for p in data.part]) & mask
    is_train = mask & ~is_held
    A = n_axes
    tgt_all = data.labels.astype(np.float32)
    eff_t = tgt_all[:, :A] * (tgt_all[:, A : A + 1] if gate else 1.0)
    scale = float(np.mean(np.sum(eff_t[is_train] ** 2, axis=1))) or 1.0
    params = _actor_parameters(model)
    opt = torch.optim.Adam(params, lr=BC_LR)
    gen = torch.Generator().manual_seed(int(seed))
    X = torch.as_tensor(x_all[is_train])
    Y = torch.as_tensor(eff_t[is_train])
    # the run's own tasks (cases, G-code files) weigh NOMINAL_SHARE of the regression
    on_task = np.isin(data.part[is_train], list(nominal))
    sample_w = None
    if on_task.any() and (~on_task).any():
        w = np.ones(int(is_train.sum()))
        w[on_task] = NOMINAL_SHARE / (1 - NOMINAL_SHARE) * (~on_task).sum() / on_task.sum()
        sample_w = torch.as_tensor(w / w.sum())
    Xv = torch.as_tensor(x_all[is_held]) if is_held.any() else None
    Yv = torch.as_tensor(eff_t[is_held]) if is_held.any() else None

    def loss_of(x, y):
        a, log_std = _deterministic(model, x)
        diff = _effective(a, A, gate, path_frame) - y
        loss = torch.mean(torch.sum(diff * diff, dim=1)) / scale
        if gate:
            loss = loss + GATE_WEIGHT * torch.mean((a[:, A] - GATE_TARGET) ** 2)
        if log_std is not None:
            loss = loss + 0.01 * torch.mean((log_std - LOG_STD_TARGET) ** 2)
        return loss

    best = (np.inf, None, 0)
    last_train = np.nan
    epoch = 0
    for epoch in range(1, BC_EPOCHS + 1):
        if sample_w is None:
            perm = torch.randperm(X.shape[0], generator=gen)
        else:
            perm = torch.multinomial(sample_w, X.shape[0], replacement=True, generator=gen)
        total, count = 0.0, 0
        for i in range(0, X.shape[0], BC_BATCH):
            idx = perm[i : i + BC_BATCH]
            loss = loss_of(X[idx], Y[idx])
            opt.zero_grad()
            loss.backward()
            opt.step()
            total += float(loss.detach()) * len(idx)
            count += len(idx)
        last_train = total / max(count, 1)
        with torch.no_grad():
            val = float(loss_of(Xv, Yv)) if Xv is not None else last_train
        if val < best[0]:
            best = (val, [p.detach().clone() for p in params], epoch)
        if seconds is not None and time.perf_counter() - t0 > seconds:
            break
        if epoch - best[2] >= BC_PATIENCE:
            break
    if best[1] is not None:
        with torch.no_grad():
            for p, v in zip(params, best[1], strict=True):
                p.copy_(v)
    _sync_targets(model)
    out = {
        "epochs": epoch,
        "kept_epoch": best[2],
        "loss": last_train,
        "validation_loss": best[0],
        "seconds": time.perf_counter() - t0,
    }
    if log is not None:
        log(
            f"student: actor fitted to the teacher in {out['seconds']:.0f} s ({epoch} epochs, "
            f"kept epoch {best[2]}; loss on held-back parts {best[0]:.3f} of the teacher's "
            "residual power)"
        )
    return out


def _sync_targets(model) -> None:
    """TD3's target actor follows the pretrained actor."""
    from stable_baselines3 import TD3

    if isinstance(model, TD3):
        model.actor_target.load_state_dict(model.actor.state_dict())


def fill_replay_buffer(model, data) -> int:
    """The teacher's transitions into an off-policy model's replay buffer (raw observations,
    as sb3 stores them under VecNormalize); returns how many."""
    buf = getattr(model, "replay_buffer", None)
    if buf is None:
        return 0
    n_env = buf.n_envs
    n = len(data) - len(data) % n_env
    room = buf.buffer_size * n_env
    n = min(n, room // 2)  # leave half the buffer to RL's own transitions
    n -= n % n_env
    for i in range(0, n, n_env):
        sl = slice(i, i + n_env)
        done = data.dones[sl]
        buf.add(
            data.obs[sl], data.next_obs[sl], data.actions[sl], data.rewards[sl], done,
            [{"TimeLimit.truncated": False} for _ in range(n_env)],
        )  # fmt: skip
    return n


def warm_critic(model, venv, steps: int = DEFAULT_CRITIC_STEPS, log=None) -> dict:
    """SAC's critic trained on the replay buffer with the actor frozen (module docstring)."""
    import torch
    import torch.nn.functional as F
    from stable_baselines3 import SAC

    if not isinstance(model, SAC) or steps <= 0 or model.replay_buffer.size() == 0:
        return {"critic_steps": 0}
    t0 = time.perf_counter()
    model.policy.set_training_mode(True)
    batch = model.batch_size
    losses = []
    for _ in range(steps):
        data = model.replay_buffer.sample(batch, env=venv)
        with torch.no_grad():
            ent_coef = (
                torch.exp(model.log_ent_coef.detach())
                if model.ent_coef_optimizer is not None
                else model.ent_coef_tensor
            )
            next_a, next_logp = model.actor.action_log_prob(data.next_observations)
            q_next = torch.cat(model.critic_target(data.next_observations, next_a), dim=1)
            q_next, _ = torch.min(q_next, dim=1, keepdim=True)
            q_next = q_next - ent_coef * next_logp.reshape(-1, 1)
            target = data.rewards + (1 - data.dones) * model.gamma * q_next
        q = model.critic(data.observations, data.actions)
        loss = 0.5 * sum(F.mse_loss(qi, target) for qi in q)
        model.critic.optimizer.zero_grad()
        loss.backward()
        model.critic.optimizer.step()
        from stable_baselines3.common.utils import polyak_update

        polyak_update(model.critic.parameters(), model.critic_target.parameters(), model.tau)
        polyak_update(model.batch_norm_stats, model.batch_norm_stats_target, 1.0)
        losses.append(float(loss.detach()))
    model.policy.set_training_mode(False)
    out = {
        "critic_steps": steps,
        "critic_loss": float(np.mean(losses[-100:])),
        "seconds": time.perf_counter() - t0,
    }
    if log is not None:
        log(f"student: critic warmed on the teacher's transitions, {steps} steps in "
            f"{out['seconds']:.0f} s (loss {out['critic_loss']:.3g})")  # fmt: skip
    return out


def attach_teacher_regularizer(
    model, venv, data, *, n_axes: int, gate: bool, path_frame: bool, alpha: float,
    batch: int = 256, seed: int = 0,
) -> bool:  # fmt: skip
    """Keep the fine-tuned actor near the teacher (TD3+BC's form, Fujimoto & Gu 2021): every
    actor update of SAC / TD3 adds the gradient of (mean |Q| / ``alpha``) · L_bc, L_bc the
    regression loss of step 2 on a batch of the teacher's rows, mean |Q| the critic's value of
    the actor's actions there (so the two terms keep their ratio as the values grow). The
    actor's optimiser ``step`` is wrapped: sb3 computes and back-propagates its actor loss,
    this adds the teacher's term to the gradients, then the optimiser steps. Returns whether
    it was attached (off-policy models with teacher rows)."""
    import torch
    from stable_baselines3 import SAC, TD3

    if not isinstance(model, (SAC, TD3)) or alpha <= 0:
        return False
    rows = np.flatnonzero(data.weight > 0)
    if rows.size == 0:
        return False
    A = n_axes
    tgt = data.labels[rows]
    eff_t = tgt[:, :A] * (tgt[:, A : A + 1] if gate else 1.0)
    power = float(np.mean(np.sum(eff_t**2, axis=1))) or 1.0
    obs = data.obs[rows]
    rng = np.random.default_rng(seed)
    opt = model.actor.optimizer
    real_step = opt.step

    def step(*args, **kwargs):
        idx = rng.integers(0, rows.size, size=batch)
        x = torch.as_tensor(np.asarray(venv.normalize_obs(obs[idx]), dtype=np.float32))
        y = torch.as_tensor(eff_t[idx])
        a, _ = _deterministic(model, x)
        diff = _effective(a, A, gate, path_frame) - y
        bc = torch.mean(torch.sum(diff * diff, dim=1)) / power
        with torch.no_grad():
            q = torch.cat(model.critic(x, a), dim=1)
            scale = float(q.abs().mean()) / alpha
        (scale * bc).backward()
        return real_step(*args, **kwargs)

    opt.step = step
    return True


__all__ = [
    "TEACHER_ENT_COEF_INIT",
    "attach_teacher_regularizer",
    "fill_replay_buffer",
    "pretrain_actor",
    "set_statistics",
    "warm_critic",
]
