"""The setup of a five-axis env: the machine (:class:`FiveAxisMachine`), the path (a named
test path of Chen, Khong & Hsieh 2022 or a five-axis G-code program) and its joint-space
reference; built by :func:`contour_env.cases.build_setup` when the plant is ``five-axis``.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

import numpy as np

from ..paths.feed import FeedProfile
from ..paths.five_axis import FiveAxisPath, FiveAxisReference, five_axis_path
from ..paths.gcode import parse_gcode, read_gcode
from ..paths.gcode_source import is_program_text
from ..paths.geometry import PathGeometry
from ..plants import FIVE_AXIS_PLANT_ALIASES
from ..plants.five_axis import FiveAxisPlant, forward
from ..tool_errors import reference_polyline

FIVE_AXIS_PLANT = "five-axis"


class _ParamsView:
    """The true FiveAxisParams under the names the env-side readers use for every plant
    (``force_limit_N`` = the drive limits, N and N·m; ``encoder_resolution_m`` = the encoder
    counts, m and rad); every other attribute is the FiveAxisParams' own."""

    n_axes = 5
    axis_names = ("x", "y", "z", "A", "C")

    def __init__(self, params):
        self._params = params

    @property
    def force_limit_N(self) -> np.ndarray:
        return self._params.drive_limit_N_Nm

    @property
    def encoder_resolution_m(self) -> np.ndarray:
        return self._params.encoder_resolution_m_rad

    def __getattr__(self, name):
        return getattr(self._params, name)


class NotAFeedDrivePlant(AttributeError, ValueError):
    """A feed-drive controller asked the five-axis model for a per-axis drive parameter."""


class _NominalView:
    """The nominal FiveAxisParams (the model controllers get); a field it does not have
    (e.g. ``mass_kg`` of the decoupled feed drives) is a clear error naming the fix."""

    def __init__(self, params):
        self._params = params

    def __getattr__(self, name):
        try:
            return getattr(self._params, name)
        except AttributeError:
            raise NotAFeedDrivePlant(
                f"plant: the five-axis model has no {name!r} (a controller for the feed-drive "
                "plants was bound to the five-axis plant); build its five-axis controller "
                "with agents.make_controller(name, plant_family='five-axis') (pd, pid, ismc)"
            ) from None


class FiveAxisMachine:
    """The five-axis plant as a setup holds it: ``plant`` (the :class:`FiveAxisPlant`),
    ``params`` (its true parameters, see :class:`_ParamsView`), ``nominal`` (the model
    controllers get: the nominal FiveAxisParams, see :class:`_NominalView`), ``geometry``,
    ``n_axes`` = 5, ``axis_names``, ``servo_period_s``; ``name`` is the family name
    ``five-axis``."""

    family = "five-axis"
    n_axes = 5
    axis_names = ("x", "y", "z", "A", "C")

    def __init__(self, plant: str = FIVE_AXIS_PLANT, *, ideal: bool = False):
        self.plant = FiveAxisPlant(FIVE_AXIS_PLANT_ALIASES[plant], ideal=ideal)
        self.params = _ParamsView(self.plant.params)
        self.nominal = _NominalView(self.plant.nominal)
        self.ideal = bool(ideal)

    name = FIVE_AXIS_PLANT

    @property
    def geometry(self):
        return self.plant.params.geometry

    @property
    def servo_period_s(self) -> float:
        return self.plant.servo_period_s


@dataclass(frozen=True, eq=False)
class FiveAxisSetup:
    """Everything a five-axis env needs that does not change between episodes.

    ``five_axis_path``: the algebraic test path (FiveAxisPath; None for a G-code program);
    ``path``: the reference tool-tip path in the workpiece frame (PathGeometry, for plots);
    ``reference``: the joint reference (FiveAxisReference: joints, joint_rate, joint_accel,
    tip_m, tool, feedrate_m_s per servo sample); ``feedrate_m_s``: its peak tip feed (case) or
    the program's joint-space feed (G-code)."""

    name: str
    plant: FiveAxisMachine
    path: PathGeometry
    reference: FiveAxisReference
    feedrate_m_s: float
    max_accel_m_s2: float
    five_axis_path: FiveAxisPath | None = None
    notes: str = ""
    program_summary: str = ""
    program_notes: tuple = ()
    segment_is_rapid: np.ndarray | None = None
    step_is_rapid: np.ndarray | None = None
    extra: dict = field(default_factory=dict)
    family = "five-axis"


def _gcode_reference(program, geometry, T, accel, jerk, settle_s) -> FiveAxisReference:
    """Joint reference of a five-axis program: each block a straight line in joint space,
    timed by the exact-stop S-curve of :class:`FeedProfile` over the blocks' joint-space
    lengths. The profile is planned on a stand-in path of the same segment lengths turning
    90° at every junction (a staircase in x and y), so it stops at the end of every block:
    the joint velocity changes direction there, which no blend in task space would smooth."""
    lengths = program.segment_lengths_m
    ends = np.concatenate([[0.0], np.cumsum(lengths)])
    corners = np.zeros((len(lengths) + 1, 3))
    for i, length in enumerate(lengths):
        corners[i + 1] = corners[i]
        corners[i + 1, i % 2] += length
    stand_in = PathGeometry.from_segments(
        [_line(corners[i], corners[i + 1]) for i in range(len(lengths))], dim=3
    )
    profile = FeedProfile.build(
        stand_in,
        program.feedrate_m_s,
        max_accel_m_s2=accel,
        max_jerk_m_s3=jerk,
        segment_feeds=program.segment_feeds_m_s,
        segment_blend_m=np.zeros(len(lengths)),
        segment_dwell_s=np.zeros(len(lengths)),
    )
    n = int(math.ceil((profile.duration + settle_s) / T - 1e-9)) + 1
    t = np.arange(n) * T
    s, sd, sdd = profile.sample(t)
    seg = np.clip(np.searchsorted(ends, s, side="right") - 1, 0, len(lengths) - 1)
    slope = np.diff(program.joints, axis=0) / lengths[:, None]  # dξ/ds per block
    joints = program.joints[seg] + (s - ends[seg])[:, None] * slope[seg]
    tip, tool = forward(joints, geometry)
    zero = np.zeros_like(joints)
    return FiveAxisReference(
        time_s=t,
        arc_length_m=s,
        feedrate_m_s=sd,
        feed_accel_m_s2=sdd,
        feed_jerk_m_s3=np.zeros_like(s),
        tip_m=tip,
        tool=tool,
        joints=joints,
        joint_rate=slope[seg] * sd[:, None],
        joint_accel=slope[seg] * sdd[:, None],
        joint_jerk=zero,
        joints_ds=slope[seg],
        joints_ds2=zero,
        joints_ds3=zero,
        servo_period_s=float(T),
    )


def _line(a, b):
    from ..paths.segments import Line

    return Line(a, b)


def build_five_axis_setup(
    case_spec, plant, path, *, ideal, structural_mode, feedrate, max_accel, max_jerk, settle,
    rapid_feed,
) -> FiveAxisSetup:  # fmt: skip
    """The setup of a five-axis case (``case_spec``: a CaseSpec whose plant is five-axis) or
    of a five-axis G-code program ``path`` on ``plant`` (a five-axis plant name)."""
    if structural_mode:
        raise ValueError("structural_mode: the five-axis plant has no structural mode option")
    machine = FiveAxisMachine(plant if plant is not None else case_spec.plant, ideal=ideal)
    geom = machine.geometry
    T = machine.servo_period_s
    if path is None:
        name = case_spec.path["name"]
        for label, value in (("feedrate_m_s", feedrate), ("max_accel_m_s2", max_accel)):
            if value is not None:
                raise ValueError(
                    f"{label}: the five-axis case {case_spec.name!r} runs the paper's 2.35 s "
                    "S-curve; it has no feed override"
                )
        fpath = five_axis_path(
            name,
            geometry=geom,
            servo_period_s=T,
            settle_time_s=case_spec.settle_time_s if settle is None else settle,
        )
        ref = fpath.reference
        return FiveAxisSetup(
            name=case_spec.name,
            plant=machine,
            path=fpath.tip_path,
            reference=ref,
            feedrate_m_s=float(np.max(ref.feedrate_m_s)),
            max_accel_m_s2=float(np.max(np.abs(ref.feed_accel_m_s2))),
            five_axis_path=fpath,
            notes=case_spec.notes,
        )
    if isinstance(path, PathGeometry):
        raise ValueError(
            "path: the five-axis plant needs a five-axis G-code program (X Y Z A C words) or a "
            "five-axis case (five-axis-line, five-axis-circle), not a PathGeometry (a tip path "
            "alone has no tool orientation)"
        )
    if not isinstance(path, (str, os.PathLike)):
        raise ValueError(
            f"path: expected five-axis G-code text or a G-code file, got {type(path).__name__}"
        )
    text = os.fspath(path)
    if is_program_text(path):  # the same rule as the three-axis plants (paths.gcode_source)
        program = parse_gcode(text, five_axis=geom, rapid_feed_m_s=rapid_feed)
        name = "gcode"
    else:
        program = read_gcode(text, five_axis=geom, rapid_feed_m_s=rapid_feed)
        name = os.path.basename(text)
    if feedrate is not None:
        program = _with_feed(program, feedrate)
    accel = 2.0 if max_accel is None else max_accel
    jerk = 40.0 if max_jerk is None else max_jerk
    settle_s = 0.1 if settle is None else settle
    ref = _gcode_reference(program, geom, T, accel, jerk, settle_s)
    tip_path, _ = reference_polyline(ref.tip_m)
    return FiveAxisSetup(
        name=name,
        plant=machine,
        path=tip_path,
        reference=ref,
        feedrate_m_s=float(program.feedrate_m_s),
        max_accel_m_s2=float(accel),
        notes="five-axis G-code program (linear in joint space)",
        program_summary=program.summary(),
        program_notes=tuple(program.notes),
    )


def _with_feed(program, feedrate):
    from dataclasses import replace

    feeds = np.where(program.segment_is_rapid, program.segment_feeds_m_s, float(feedrate))
    return replace(program, segment_feeds_m_s=feeds, feedrate_m_s=float(feedrate))
