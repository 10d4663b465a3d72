"""``make_core``: the simulation core of a case, plant or path — :class:`.core.EnvCore` for the
feed-drive plants, :class:`.five_axis_core.FiveAxisCore` for the five-axis machine (what
:class:`ContouringEnv` and :class:`ContouringVectorEnv` step)."""

from __future__ import annotations

from ..cases import FIVE_AXIS_ABORT_CONTOUR_M, build_setup, get_case
from .core import EnvConfig, EnvCore, StepThreads, check_env_arguments
from .five_axis_core import FiveAxisCore


def make_core(
    case=None,
    plant=None,
    path=None,
    *,
    n_envs=1,
    feedrate_m_s=None,
    max_accel_m_s2=None,
    max_jerk_m_s3=None,
    settle_time_s=None,
    ideal=False,
    structural_mode=False,
    plant_params=None,
    strict=False,
    rapid_feed_m_s=None,
    num_threads=None,
    **config,
) -> EnvCore | FiveAxisCore:
    # num_threads: the step's thread policy (None / "auto": adaptive; see StepThreads)
    check_env_arguments(config)
    setup = build_setup(
        case,
        plant,
        path,
        feedrate_m_s=feedrate_m_s,
        max_accel_m_s2=max_accel_m_s2,
        max_jerk_m_s3=max_jerk_m_s3,
        settle_time_s=settle_time_s,
        ideal=ideal,
        structural_mode=structural_mode,
        strict=strict,
        rapid_feed_m_s=rapid_feed_m_s,
    )
    if isinstance(case, str):
        # the case's own env settings (e.g. corner-blend: random disturbance phase, encoder
        # noise) unless given here
        config = {**get_case(case).env_config, **config}
    if getattr(setup, "family", None) == "five-axis":
        # the coupled five-axis machine: its own core and kernel (contour_env.env.five_axis_core)
        # its contour guard is on ε + L·θ: the family's default (programs too) unless given
        config = {"abort_contour_error_m": FIVE_AXIS_ABORT_CONTOUR_M, **config}
        return FiveAxisCore(
            setup, EnvConfig(**config), n_envs, plant_params=plant_params, num_threads=num_threads
        )
    threads = StepThreads(num_threads, n_envs)  # checked before the arrays are built
    core = EnvCore(setup, EnvConfig(**config), n_envs=n_envs, plant_params=plant_params)
    core.threads = threads
    return core
