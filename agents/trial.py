"""The full record of one trial of a repeated-batch run, handed to a learning controller.

Conventions: leading axis B (envs of the batch; a single env is a batch of one), then the
sample index k = 0 … N−1 (N = ``n_steps − 1``, one per servo period), then the axis. SI units.
Servo-side quantities (``measured_*``, ``command``, errors) are taken at sample k, *before* the
command of sample k is computed — what the controller saw; plant-side quantities
(``position``, ``contour_error``, ``force``) after the step (sample k + 1), as
:func:`contour_env.evaluation.run_episode` records them for the metrics.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from contour_env.metrics import EpisodeRecord


@dataclass
class TrialRecord:
    """One trial of B envs over N samples.

    time_s (N,): t_k = k T. reference_position / reference_velocity /
    reference_acceleration (N, A): x_d, ẋ_d, ẍ_d at sample k. frame (N, A, A): F = [t n (b)]
    at sample k. curvature (N,) 1/m. measured_position / measured_velocity (B, N, A): encoder
    reading and its backward difference at sample k. command (B, N, A): the command the
    controller issued at k (plant units, N; before the delay and saturation). axis_error
    (B, N, A) = x_d − x_meas at k; task_error (B, N, A) = Fᵀ axis_error (tangential,
    normal(, binormal)). position (B, N, A) true, reference_after (N, A) the reference after
    the step, force (B, N, A) applied, contour_error (B, N)
    true ε after the step. valid (B, N): samples before the episode ended (False after a
    crash-guard stop). termination_reason: per env, None if the trial ran to its end.
    fingerprint: what the trial ran on (case, plant, path, N, A, T) — learning states check it.
    """

    time_s: np.ndarray
    servo_period_s: float
    reference_position: np.ndarray
    reference_velocity: np.ndarray
    reference_acceleration: np.ndarray
    frame: np.ndarray
    curvature: np.ndarray
    measured_position: np.ndarray
    measured_velocity: np.ndarray
    command: np.ndarray
    axis_error: np.ndarray
    task_error: np.ndarray
    position: np.ndarray
    reference_after: np.ndarray
    force: np.ndarray
    saturated: np.ndarray
    contour_error: np.ndarray
    valid: np.ndarray
    termination_reason: list
    force_limit: np.ndarray
    fingerprint: dict

    @property
    def n_envs(self) -> int:
        return self.measured_position.shape[0]

    @property
    def n_samples(self) -> int:
        return self.measured_position.shape[1]

    def episode(self, b: int = 0) -> EpisodeRecord:
        """Env b's trial as an :class:`EpisodeRecord` for the one scoring function."""
        n = int(self.valid[b].sum())
        pos = self.position[b, :n]
        ref = self.reference_after[:n]
        force = self.force[b, :n]
        return EpisodeRecord(
            time=self.time_s[:n] + self.servo_period_s,
            contour_error=self.contour_error[b, :n],
            tracking_error=ref - pos,
            force=force,
            saturated=self.saturated[b, :n],
            position=pos,
            reference=ref,
            force_limit=self.force_limit.copy(),
            termination_reason=self.termination_reason[b],
            n_steps_planned=self.n_samples,
        )
