"""The residual law's arithmetic, shared by the training wrappers and the trained agent
(:mod:`agents.residual`): the frame the agent acts in, its gate, and the extra observation
fields it is given.

**Frame** (``residual_frame``). The agent's action a ∈ [−1, 1]ⁿ becomes a residual command
r ∈ [−scale, scale]ⁿ (fractions of the axis force limit) on the machine axes:

- ``"axes"``: r = scale · a, one action component per machine axis (the agents shipped before
  the option);
- ``"path"``: r = scale · w ⊙ (F · â), â = a / max(1, ‖a‖₂), F = [t n (b)] the reference's
  task frame at that servo period (columns in machine coordinates, what the env's observation
  errors are expressed in). a₀ pushes along the path tangent, a₁ along the normal, a₂ along
  the binormal, whatever the direction of the path in the machine: a correction learned on
  one part applies to the same situation on a rotated part, as cross-coupled control's gains
  (the frame's components) do.

  w_i = (m_i / F_max,i) / max_j (m_j / F_max,j) (nominal masses and force limits) makes the
  push the same *acceleration* in every direction — the way CCC distributes its correction,
  u = −M C(ε) n — on plants whose axes differ (``hsm2``: 3 030 kg / 13.6 kN on x, 1 144 kg /
  6 kN on y, so w = (1, 0.86)); w = 1 on plants with equal axes and on velocity-command
  drives (``jee-triaxial``: a fraction of the limit is the same velocity on every axis). The
  action is limited in its Euclidean norm rather than per component, so the bound does not
  depend on the direction of the path: |r_i| ≤ scale · w_i · ‖â‖ ≤ scale, the bound of the axes
  frame, on every axis.

Either way r is multiplied by the axis mask (:func:`agents.residual.path_axes_mask`: zero on
axes the path does not use) and, with a gate, by g.

**At rest** (``fade_at_rest``). While the reference stands still — a pause for a Z move, a
dwell, an exact stop, the settle at the end — there is no path to follow: the task frame and
the curvature are those of the segment about to start (a 3 mm fillet after a plunge pause
reads as a curvature at the clip of the observation), and the base controller regulates a
point. An agent that pushes there holds the table off the path through the whole pause (what
the first path-frame agents did on held-out programs: 50–180 µm for 3–5 s behind stiction).
With ``fade_at_rest`` the residual is multiplied by min(1, ṡ / v_rest), ṡ the reference's path
speed and v_rest = :data:`REST_FADE_FEED_FRACTION` × the case feedrate: zero at rest, full
from 5 % of the feed on (a few servo periods into a start at the plants' jerk limits).

**Gate** (``gate``). The agent has one more action component a_g and the residual is
g · r with g = clip(a_g, 0, 1): a_g ≤ 0 closes it (the base controller alone). A freshly
initialised actor outputs a ≈ 0, so the gate starts closed, and the agent opens it where a
residual pays. It is judged against keep-best's fallback to the base in the README's ablation.

**Axis observation** (``observe_axes``). In the path frame the observation (task-frame errors,
curvature, preview) no longer tells which machine axes the path moves, and friction, ripple
and stiction live on the axes: a quadrant glitch is an axis reversing, not a property of the
path's frame. So the agent may also see, per axis, the reference velocity ẋ_d,i / (case
feedrate) and the reference acceleration ẍ_d,i / (case acceleration limit), clipped to
±obs_clip: what a model-based friction compensator uses (the sign and size of each axis'
commanded velocity, and the acceleration that announces its reversal) and what an inertia
feedforward uses. With ``observe_axes`` the agent is no longer invariant to rotating a part
(deliberately: a friction plant is not); without it, a path-frame agent on a plant whose axes
are alike gives the same result on a part rotated in the plane (``tests/agents/
test_residual_frame.py``).

In the path frame, the previous-action fields of the ``"full"`` observation (the applied
command per axis) are given in the path frame too (Fᵀ a_prev), so that every field the agent
sees, but the axis observation, is a task-frame quantity.
"""

from __future__ import annotations

import numpy as np

RESIDUAL_FRAMES = ("axes", "path")
# the residual fades in over the first 5 % of the feed (fade_at_rest)
REST_FADE_FEED_FRACTION = 0.05


def check_frame(residual_frame) -> str:
    if residual_frame not in RESIDUAL_FRAMES:
        raise ValueError(
            f"residual_frame: must be one of {', '.join(RESIDUAL_FRAMES)}, got {residual_frame!r}"
        )
    return residual_frame


def check_flag(value, name: str) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name}: expected true or false, got {value!r}")
    return bool(value)


def action_size(n_axes: int, gate: bool) -> int:
    """Components of the agent's action: one per axis (or frame direction), plus the gate."""
    return n_axes + (1 if gate else 0)


def path_weights(plant_params) -> np.ndarray:
    """w (n,): the per-axis weights of the path-frame residual (see the module docstring)."""
    p = plant_params
    n = p.n_axes
    if p.input_kind != "force":
        return np.ones(n)
    ratio = np.asarray(p.mass_kg, dtype=np.float64) / np.asarray(p.force_limit_N, dtype=np.float64)
    return ratio / ratio.max()


def rest_fade(feedrate, v_rest: float):
    """min(1, ṡ / v_rest) per env (ones when ``v_rest`` is 0: no fade)."""
    s = np.asarray(feedrate, dtype=np.float64)
    if v_rest <= 0:
        return np.ones(s.shape)
    return np.minimum(s / v_rest, 1.0)


def residual_command(
    a, frame, scale: float, mask, residual_frame: str, gate: bool, weights=None, fade=None
):  # fmt: skip
    """The residual (B, n) in fractions of the force limit and the gate g (B,) for agent
    actions ``a`` (B, n [+ 1]) already clipped to [−1, 1], the task frames ``frame`` (B, n, n)
    of the current servo period, the axis ``mask`` (n,), in the path frame the axis
    ``weights`` (n,) of :func:`path_weights` (None: ones), and the rest ``fade`` (B,) of
    :func:`rest_fade` (None: none)."""
    n = mask.shape[0]
    a = np.asarray(a, dtype=np.float64)
    push = a[:, :n]
    if residual_frame == "path":
        norm = np.sqrt(np.sum(push * push, axis=1, keepdims=True))
        push = push / np.maximum(norm, 1.0)
        # r_i = scale w_i Σ_j F_ij â_j
        r = np.zeros_like(push)
        for j in range(n):
            r += frame[:, :, j] * push[:, j : j + 1]
        r = scale * r if weights is None else scale * (r * weights)
    else:
        r = scale * push
    r = r * mask
    if gate:
        g = np.clip(a[:, n], 0.0, 1.0)
        r = r * g[:, None]
    else:
        g = np.ones(a.shape[0])
    if fade is not None:
        r = r * fade[:, None]
    return r, g
