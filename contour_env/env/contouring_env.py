"""The Gymnasium contouring environment (a batch of one of :class:`EnvCore`)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.error import ResetNeeded

from .core import EnvConfig, check_seed
from .factory import make_core
from .protocol import Core


class ContouringEnv(gym.Env):
    """Multi-axis CNC feed drive following a reference contour.

    ``gymnasium.make("contour_env/Contouring-v0", case="hsm2-circle-II")`` or
    ``gymnasium.make("contour_env/Contouring-v0", plant="hsm2", path="part.nc")``.

    ## Description

    The tool is driven by n = 2 or 3 feed axes (``m ẍ + b ẋ + f_friction(ẋ) + f_ripple(x) + d(t)
    = sat(u)`` per axis, with the plant's documented realistic effects, see
    :mod:`contour_env.plants.catalog`). A reference point moves along the path with a
    jerk-bounded feed profile, one servo period T per step. The task is to keep the tool on
    the path: the reward comes from the **true contour error** ε, the shortest distance from
    the tool to the whole path.

    The five-axis machine (``plant="five-axis"``; cases ``five-axis-line`` and
    ``five-axis-circle``, or a G-code program with A and C words) is driven by its five
    coupled joints x, y, z, A, C instead: its action, observation, reward (tool-tip contour
    and orientation error) and info keys are documented in
    :mod:`contour_env.env.five_axis_core`, its use in docs/FIVE_AXIS.md.

    ## Action Space

    ``Box(-1, 1, (n,), float32)``: the per-axis actuator command as a fraction of the axis
    force limit (``plant.params.force_limit_N``; for ``jee-triaxial`` the velocity-command
    limit). Values outside [-1, 1] are clipped. With the plant's computation delay the command
    is applied one servo period later. A NaN or infinite action, a complex, boolean or
    non-numeric one, or one of the wrong shape raises ``ValueError``.

    ## Observation Space

    ``Box(-clip, clip, (3n + 3 + p·n,), float32)`` (clip = ``obs_clip``, default 10), computed
    from the *measured* state (encoder, with quantisation and optional noise; velocity by
    backward difference), in the task frame F = [t n b] of the reference (Lee 2012 eqs. 2–3):

    | index | field (unit before scaling) | scale |
    |---|---|---|
    | 0 .. n−1 | Fᵀ(x_d − x): tangential, normal (, binormal) error (m) | / error_obs_scale_m |
    | n .. 2n−1 | Fᵀ(ẋ_d − ẋ): task-frame velocity error (m/s) | / velocity_error_obs_scale_m_s |
    | 2n | reference feedrate ṡ (m/s) | / case feedrate |
    | 2n+1 | reference tangential acceleration s̈ (m/s²) | / case max acceleration |
    | 2n+2 | reference curvature κ, signed for planar paths (1/m) | × curvature_obs_scale_m |
    | 2n+3 .. | preview Fᵀ(x_d(t + τ_j) − x_d(t)), τ_j in preview_times_s (m) | / (feed · τ_j) |
    | last n | previous action | – |

    For a 2-axis plant the frame is the in-plane [t n] with n the left normal (Lee eq. 36).

    ## Rewards

    While the episode runs:
    ``r = −(w_contour · ε + w_lag · |e_t|) / contour_error_scale_m − w_effort · ‖a‖² / n``
    with ε the true contour error (m), e_t the tangential (lag) error (m) and a the action.
    Defaults: w_contour = 1, w_lag = 0, w_effort = 0, scale 10 µm (r = −1 at ε = 10 µm).

    When a guard ends the episode (see Episode End) the reward of that step is
    ``r = −P · (n_steps − k)``: the guard penalty P for the terminating step and for each of the
    steps it skips (k is ``info["step"]``; a full episode has n_steps − 1 steps), with
    ``P = (w_contour · abort_contour_error_m + w_lag · abort_tracking_error_m)
    / contour_error_scale_m + w_effort`` (``env.config.guard_penalty``; 500 by default).

    Why: ε is the distance to the *whole* path and the tool starts on it, so a tool that never
    moves has ε = 0; with the ε reward alone, standing still would earn the best return there
    is (0). ε stays the measure (it is the part's error), and lag is bounded rather than
    priced: a lag term at every step would change the reward of every controller that follows
    the path (PD lags 0.2–0.6 mm on the named cases) and would need a tolerance, the same
    number as a guard. So the tracking guard ends an episode whose tool is more than
    ``abort_tracking_error_m`` from the reference, and ending costs P per step left. 10 mm
    is 3× the largest tracking error of a classical controller on the named cases (jee-ccc,
    3.1 mm), twice the contour guard, and reached by a standing tool within 0.13–0.55 s. No
    running step costs more than P (ε ≤ the contour guard, |e_t| ≤ ‖x_d − x‖ ≤ the tracking
    guard, ‖a‖²/n ≤ 1), so every episode's return is a sum over the same n_steps − 1 steps of
    terms ≥ −P, and ending early (contour guard, tracking guard or a non-finite state) never
    pays. Standing still scores about −P per remaining step: on every named case at least 18×
    below PD's return (zero command vs PD: hsm2-circle-III −6.0·10⁵ vs −3.2·10⁴,
    hsm2-circle-I −1.6·10⁶ vs −1.8·10⁴, sharp-corner −1.4·10⁶ vs −1.6·10⁴, lm-circle3d
    −7.8·10⁷ vs −2.1·10⁵). A controller that keeps within 10 mm of the reference is never
    stopped and earns exactly the ε reward (the classical ones on the named cases: rewards
    unchanged by the guard). ``w_lag > 0`` adds a dense lag term for learners that want one
    (it raises P to keep the bound). The terminating step's reward is large (up to
    P · n_steps); a learner that needs small rewards can scale them in a wrapper. The metrics
    apply the same follow limit: ``metrics.score`` reports ``completed`` only for a run that
    followed the program.

    ## Starting State

    At rest on the start point of the path, k = 0 (noise-free named cases are deterministic).

    ## Episode End

    - terminated, checked in this order: ε > ``abort_contour_error_m`` (contour guard, default
      5 mm), ``"contour_error_limit"``; ``‖x_d − x‖ > abort_tracking_error_m`` (tracking guard
      on the true tracking error, default 10 mm: the tool is not following the program, e.g.
      it stands still), ``"tracking_error_limit"``; a non-finite state, ``"non_finite_state"``
      (the reason is ``info["termination_reason"]``). The step's reward is −P · (n_steps − k),
      see Rewards.
    - truncated: the path and the settle time are done (k = n_steps − 1).
    - after either, ``step`` raises ``gymnasium.error.ResetNeeded`` until ``reset`` is called
      (and so does a ``step`` before the first ``reset``)
      (also on the unwrapped env: an ended episode neither advances time nor pays rewards).

    ## Info (every step, physical units)

    | key | unit | shape | meaning |
    |---|---|---|---|
    | `time` | s | scalar | k · T |
    | `step` | samples | scalar | reference index k |
    | `position` | m | (n,) | true position |
    | `measured_position` | m | (n,) | encoder reading |
    | `velocity` | m/s | (n,) | true velocity |
    | `reference` | m | (n,) | reference position x_d |
    | `contour_error` | m | scalar | true contour error ε |
    | `contour_error_estimate` | m | (n,) | Fᵀ(x_d − x): tangential, normal (, binormal) |
    | `tracking_error` | m | (n,) | x_d − x |
    | `force` | N | (n,) | applied command after delay and saturation |
    | `saturated` | flag | (n,) | the force at its limit |
    | `termination_reason` | – | scalar | None while running, then the guard's reason |

    The guard's reason is ``"contour_error_limit"``, ``"tracking_error_limit"`` or
    ``"non_finite_state"`` (see Episode End). The vector env's info has the same keys, each
    with a leading batch axis (``termination_reason``: ``""`` while an env runs).

    ## Arguments

    case : str — a named case (``contour-env cases``); its plant/path/feed are defaults.
    plant : str or mapping — a named plant or custom parameters (with ``path``).
    path : PathGeometry, G-code program text or a G-code file: a ``pathlib.Path``, or a str
        that names an existing file or ends in a usual extension (.nc .ngc .gcode .tap .cnc
        .txt .mpf .eia .ptp); a str with a line break or a G0–G3 word is program text
        (``path="G1 X5 F600"``), see :mod:`contour_env.paths.gcode_source`. (G-code is read in
        its own units and converted to metres; setup words are reported in
        ``env.unwrapped.setup.program_summary``; G61/G64 and G04 drive the look-ahead feed
        planner, see docs/FEED_PLANNER.md).
    strict : bool — refuse a G-code program with Z motion on a 2-axis plant (default False: Z
        is taken by an unsimulated axis, Z-only moves become pauses of their duration).
    rapid_feed_m_s : float — the machine's rapid rate for G00 moves (m/s; default the
        program's highest F).
    num_threads : "auto" (default) or an int ≥ 1 — threads for a batch of 256 envs or more
        (``gym.make_vec``); "auto" times the step and keeps the fastest team, an int fixes it
        (1: serial). Results are bit-identical for any value (see ``EnvCore`` ``StepThreads``).
    feedrate_m_s, max_accel_m_s2, max_jerk_m_s3, settle_time_s : feed profile overrides.
    ideal : bool — switch off every effect the textbook model leaves out.
    structural_mode : bool — add the axial two-mass mode.
    abort_contour_error_m : the contour guard (m, > 0, default 5e-3).
    abort_tracking_error_m : the tracking guard on ‖x_d − x‖ (m, > 0, default 1e-2, the same
        follow limit as ``metrics.score``'s ``completed``).
    contour_error_scale_m (m, > 0), w_contour, w_lag, w_effort (≥ 0, dimensionless),
    error_obs_scale_m, velocity_error_obs_scale_m_s, curvature_obs_scale_m, preview_times_s,
    obs_clip : see above.
    measurement_noise_std_m : Gaussian encoder noise before quantisation (default 0).
    disturbance_force_N : bounded random force, uniform in ±value per step and axis (default 0).
    disturbance_phase : ``"fixed"`` (default) or ``"random"``. The phase of the plant's own
        periodic disturbance d(t) (``friction-table``: 8/6 N at 1.5/2.3 Hz). ``"fixed"``: the
        documented phase, the same in every episode (named cases are deterministic).
        ``"random"``: a disturbance not synchronised with the part program — each episode draws
        its time offset per axis, uniform over one period, from the episode seed (the same
        seed repeats it; the trials of a repeated batch, seeded anew, see a disturbance that
        iterative learning cannot learn).
    render_mode : None or one of ``metadata["render_modes"]`` (``"rgb_array"``); any other
        (``"human"`` too) raises ``ValueError``.

    Any other argument raises ``ValueError`` naming it and listing the known ones. ``reset``
    takes a ``seed`` in numpy's range 0 … 2**64 − 1 (``ValueError`` otherwise).

    Random elements (noise, random disturbance) are drawn from a counter-based generator keyed
    by the episode seed: ``reset(seed=s)`` gives a bit-identical episode every time.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(self, case=None, plant=None, path=None, *, render_mode=None, **kwargs):
        modes = self.metadata["render_modes"]
        if render_mode is not None and render_mode not in modes:
            raise ValueError(
                f"render_mode: must be None or one of the env's render modes "
                f"({', '.join(map(repr, modes))}), got {render_mode!r}"
            )
        self.core: Core = make_core(case, plant, path, n_envs=1, **kwargs)
        self.render_mode = render_mode
        n = self.core.dim
        self.action_space = spaces.Box(-1.0, 1.0, (n,), dtype=np.float32)
        clip = self.core.config.obs_clip
        self.observation_space = spaces.Box(-clip, clip, (self.core.obs_dim,), dtype=np.float32)
        self._action = np.zeros((1, n))
        self._history: list[tuple] = []
        self._was_reset = False  # step before the first reset: ResetNeeded

    # properties users script against
    @property
    def setup(self):
        return self.core.setup

    @property
    def config(self) -> EnvConfig:
        return self.core.config

    @property
    def plant(self):
        return self.core.setup.plant

    @property
    def servo_period_s(self) -> float:
        return self.core.T

    def signals(self) -> dict:
        """What a servo controller measures now (see :meth:`EnvCore.signals`)."""
        return self.core.signals(0)

    def reset(self, *, seed=None, options=None):
        if seed is not None:
            seed = check_seed(seed)
        super().reset(seed=seed)
        noise_seed = seed if seed is not None else int(self.np_random.integers(0, 2**63))
        self.core.reset_env(0, int(noise_seed))
        self._was_reset = True
        self._history = [] if self.render_mode else self._history
        if self.render_mode:
            self._record()
        return self.core.obs[0].copy(), self.core.info(0)

    def step(self, action):
        if not self._was_reset:
            raise ResetNeeded(
                "step: call reset() before the first step (the episode has not begun)"
            )
        if self.core.terminated[0] or self.core.truncated[0]:
            reason = self.core.info(0)["termination_reason"] or "truncated: the path is done"
            raise ResetNeeded(
                f"step: the episode has ended ({reason}, step {int(self.core.k[0])}); call "
                "reset() before stepping again"
            )
        a = np.asarray(action)
        if a.dtype.kind not in "fiu":
            # complex (its imaginary part would be dropped), bool, text, objects: no command
            raise ValueError(f"action: expected real numbers, got dtype {a.dtype} ({action!r})")
        a = a.astype(np.float64, copy=False)
        if a.shape != (self.core.dim,):
            a = a.reshape(-1)
            if a.shape != (self.core.dim,):
                raise ValueError(
                    f"action: expected shape ({self.core.dim},), got {np.shape(action)}"
                )
        self._action[0] = a
        core = self.core
        # the kernel fills fresh info arrays as it steps (cheaper than copying afterwards)
        info = core.new_info_arrays()
        core.step(self._action, core.all_active, info)
        if self.render_mode:
            self._record()
        return (
            core.obs[0].copy(),
            float(core.reward[0]),
            bool(core.terminated[0]),
            bool(core.truncated[0]),
            core.info_of(info, 0),
        )

    # --- rendering -------------------------------------------------------------------------
    def _record(self):
        c = self.core
        self._history.append((float(c.k[0]) * c.T, c.z[0, :, 0].copy(), float(c.eps[0])))

    def render(self):
        if self.render_mode != "rgb_array":
            return None
        from .render import render_rgb

        return render_rgb(self.core, self._history)


def make_contouring_env(**kwargs) -> ContouringEnv:
    """The entry point of ``contour_env/Contouring-v0``: a function, not the class, so that
    ``gym.make`` hands ``render_mode`` to the env as given (with the class it would wrap a
    ``"human"`` request in HumanRendering with only a warning) and the env refuses the modes
    it does not have."""
    return ContouringEnv(**kwargs)
