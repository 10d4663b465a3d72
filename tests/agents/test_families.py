"""Training path families (agents.rl.families): seeded, within each plant's ranges, accepted by
the env on every plant, polylines blended at non-axis-aligned corners, and wired into
TaskSampler, TrainConfig and ``contour-env train``."""

from __future__ import annotations

import math
import re
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from agents import make_controller
from agents.rl import TrainConfig
from agents.rl.families import (
    CORNER_ANGLE_DEG,
    FAMILIES,
    MIN_AXIS_ANGLE_DEG,
    PLANT_RANGES,
    VALIDATION_SEED_BASE,
    families_for,
    generate_path,
    validation_set,
)
from agents.rl.tasks import TaskSampler
from contour_env import ENV_ID
from contour_env.cases import build_setup
from contour_env.evaluation import run_episode
from contour_env.metrics import score
from contour_env.paths.gcode import parse_gcode
from contour_env.paths.geometry import PathGeometry
from contour_env.paths.planner import junction_angles
from contour_env.plants import Plant

PLANTS = tuple(PLANT_RANGES)
CASES = [(plant, fam) for plant in PLANTS for fam in families_for(plant)]


def _geometry(part) -> PathGeometry:
    return build_setup(plant=part.plant, path=part.path, feedrate_m_s=part.feedrate_m_s).path


def _points(part, n=500) -> np.ndarray:
    return _geometry(part).sample_points(n)


def test_families_per_plant_helices_only_on_three_axes():
    assert families_for("hsm2") == families_for("friction-table") == FAMILIES[:-1]
    assert families_for("jee-triaxial") == families_for("linear-motor") == FAMILIES
    assert families_for("lm") == FAMILIES  # aliases resolve


@pytest.mark.parametrize("plant, family", CASES)
def test_same_seed_same_path_other_seed_other_path(plant, family):
    a = generate_path(family, plant, 7, plant_variation=0.2)
    b = generate_path(family, plant, 7, plant_variation=0.2)
    c = generate_path(family, plant, 8, plant_variation=0.2)
    assert a.describe() == b.describe()
    np.testing.assert_array_equal(_points(a), _points(b))
    assert a.plant_params[0].to_dict() == b.plant_params[0].to_dict()
    assert a.feedrate_m_s != c.feedrate_m_s
    assert _points(a).shape != _points(c).shape or not np.allclose(_points(a), _points(c))
    assert a.plant_params[0].to_dict() != c.plant_params[0].to_dict()


@pytest.mark.parametrize("plant, family", CASES)
def test_every_family_runs_with_pd_on_every_plant(plant, family):
    for seed in (0, 1):
        part = generate_path(family, plant, seed, plant_variation=0.1)
        env = gym.make(ENV_ID, **part.env_kwargs())
        assert env.unwrapped.config.disturbance_phase == "random"
        m = score(run_episode(env, make_controller("pd").bind(env), seed=part.reset_seed))
        assert m["completed"], (seed, m["incomplete_reason"])
        assert np.isfinite(m["rms_contour_error_um"])


@pytest.mark.parametrize("plant, family", CASES)
def test_sizes_feeds_and_travel_within_the_plant_ranges(plant, family):
    r = PLANT_RANGES[plant]
    for seed in range(12):
        part = generate_path(family, plant, seed)
        geom = _geometry(part)
        f = part.feedrate_m_s
        assert r.feed_m_s[0] <= f <= r.feed_m_s[1]
        assert (part.max_accel_m_s2, part.max_jerk_m_s3) == (r.max_accel_m_s2, r.max_jerk_m_s3)
        # (G-code coordinates are rounded to 0.1 µm)
        assert geom.total_length / f <= r.max_path_time_s * (1 + 1e-4)
        pts = geom.sample_points(800)
        assert np.all(np.abs(pts) <= r.travel_m)
        assert np.max(np.ptp(pts, axis=0)) <= r.size_m[1] * (1 + 1e-6)
        if family not in ("polylines", "programs") or (
            family == "programs" and max(part.params["fillet_radius_m"]) > 0
        ):  # curves (and fillets): the feed respects the centripetal limit
            _, kappa, _ = geom.frames(np.linspace(0, geom.total_length, 2001))
            assert f**2 * np.max(np.abs(kappa)) <= r.max_centripetal_m_s2 * 1.02
        if geom.dim == 3:
            assert Plant(plant).n_axes == 3


@pytest.mark.parametrize("plant", PLANTS)
def test_polyline_corners_are_blended_and_no_leg_is_axis_aligned(plant):
    lo, hi = CORNER_ANGLE_DEG
    for seed in range(10):
        part = generate_path("polylines", plant, seed)
        assert "G64 P" in part.path
        program = parse_gcode(part.path)
        # G64 P: a path tolerance at every corner (the last segment ends in a stop)
        assert np.all(program.segment_blend_m[:-1] > 0)
        assert program.segment_blend_m[-1] == 0
        setup = build_setup(plant=plant, path=part.path, feedrate_m_s=part.feedrate_m_s)
        geom = setup.path
        legs = np.array([geom.evaluate([s])["d1"][0] for s in geom.seg_s0 + 1e-9])
        cos_axis = np.max(np.abs(legs / np.linalg.norm(legs, axis=1, keepdims=True)), axis=1)
        assert np.all(np.degrees(np.arccos(cos_axis)) >= MIN_AXIS_ANGLE_DEG - 1e-3), seed
        turns = np.degrees(junction_angles(geom))
        assert np.all((turns >= lo - 0.01) & (turns <= hi + 0.01)), turns
        # blended, not an exact stop: the reference passes each corner at a speed > 0, and the
        # part takes less time than the same legs with G61
        ref = setup.reference
        speed = np.linalg.norm(ref.velocity, axis=1)
        for s_corner in geom.seg_s0[1:]:
            k = int(np.argmin(np.abs(ref.arc_length - s_corner)))
            assert np.min(speed[k - 1 : k + 2]) > 0, (seed, s_corner)
        exact = re.sub(r"G64 P[0-9.]+", "G61", part.path)
        stop = build_setup(plant=plant, path=exact, feedrate_m_s=part.feedrate_m_s)
        assert stop.path.total_length == pytest.approx(geom.total_length)
        assert setup.profile.duration < stop.profile.duration


def test_polyline_orientations_and_planes_vary():
    headings = set()
    tilted = 0
    for seed in range(20):
        part = generate_path("polylines", "jee-triaxial", seed)
        headings.add(round(math.degrees(math.atan2(*_first_leg(part)[1::-1])) % 360, 1))
        tilted += abs(part.params["normal"][2]) < 0.999
    assert len(headings) == 20
    assert 3 <= tilted <= 17  # about half in a tilted plane on a 3-axis plant
    for seed in range(10):
        assert generate_path("polylines", "hsm2", seed).params["normal"] == [0.0, 0.0, 1.0]


def _first_leg(part) -> np.ndarray:
    geom = _geometry(part)
    return geom.evaluate([1e-9])["d1"][0]


@pytest.mark.parametrize("plant", ("hsm2", "friction-table"))
def test_three_axis_families_are_refused_on_two_axis_plants(plant, tmp_path):
    with pytest.raises(ValueError, match=r"families: \['helices'\] need a 3-axis plant"):
        generate_path("helices", plant, 0)
    with pytest.raises(ValueError, match="need a 3-axis plant"):
        TrainConfig(plant=plant, path_variety=("families",), families=("helices",))


def test_bad_family_plant_and_seed_are_clear_errors():
    with pytest.raises(ValueError, match="family: unknown 'squares'; allowed: polylines"):
        generate_path("squares", "hsm2", 0)
    with pytest.raises(ValueError, match="no training path families for 'nope'"):
        generate_path("arcs", "nope", 0)
    with pytest.raises(ValueError, match="seed: expected an integer >= 0"):
        generate_path("arcs", "hsm2", -1)
    with pytest.raises(ValueError, match=r"plant_variation: must be in \[0, 1\)"):
        generate_path("arcs", "hsm2", 0, plant_variation=1.0)
    with pytest.raises(ValueError, match=r"families: unknown \['squares'\]"):
        TrainConfig(plant="hsm2", path_variety=("families",), families=("squares",))


def test_validation_set_is_fixed_and_uses_seeds_training_never_draws():
    a = validation_set("friction-table", (), 6, plant_variation=0.1)
    b = validation_set("friction-table", (), 6, plant_variation=0.1)
    assert [p.describe() for p in a] == [p.describe() for p in b]
    assert [p.seed for p in a] == [VALIDATION_SEED_BASE + k for k in range(6)]
    assert [p.family for p in a] == ["polylines", "arcs", "circles", "splines", "programs"] + [
        "polylines",
    ]
    cfg = TrainConfig(plant="friction-table", path_variety=("families",), validation_paths=2)
    sampler = TaskSampler(cfg, 0)
    drawn = []
    real = generate_path

    def spy(family, plant, seed, **kw):
        drawn.append(seed)
        return real(family, plant, seed, **kw)

    import agents.rl.tasks as tasks

    tasks.generate_path, saved = spy, tasks.generate_path
    try:
        for _ in range(30):
            sampler.sample()
    finally:
        tasks.generate_path = saved
    assert len(drawn) == 30 and all(0 <= s < VALIDATION_SEED_BASE for s in drawn)


def test_task_sampler_draws_families_with_plant_variation_and_random_phase():
    cfg = TrainConfig(
        plant="linear-motor",
        path_variety=("families",),
        families=("helices", "arcs"),
        randomize_plant=0.2,
        validation_paths=1,
    )
    assert cfg.randomized and cfg.training_families == ("helices", "arcs")
    sampler = TaskSampler(cfg, 3)
    tasks = [sampler.sample() for _ in range(6)]
    again = TaskSampler(cfg, 3)
    assert [t["feedrate_m_s"] for t in tasks] == [again.sample()["feedrate_m_s"] for _ in range(6)]
    masses = set()
    for t in tasks:
        assert t["plant"] == "linear-motor" and t["disturbance_phase"] == "random"
        assert t["w_contour"] == cfg.w_contour  # the reward weights come along
        masses.add(tuple(t["plant_params"][0].mass_kg))
        assert isinstance(t["path"], PathGeometry)
    assert len(masses) == 6
    env = gym.make(ENV_ID, **tasks[0])
    obs, _ = env.reset(seed=0)
    for _ in range(20):
        obs, _, term, trunc, _ = env.step(np.zeros(3, dtype=np.float32))
    assert not term and np.all(np.isfinite(obs))


def test_plant_alone_with_families_is_a_valid_configuration_and_cli_value():
    from contour_env.app.cli import build_parser
    from contour_env.app.cli_rl import config_from_args

    args = build_parser().parse_args(
        [
            "train", "--plant", "hsm2", "--paths", "families", "--families", "polylines,arcs",
            "--validation-paths", "3", "--out", "unused", "--scale", "0.05",
            "--residual-penalty", "1",
        ]
    )  # fmt: skip
    cfg = config_from_args(args)
    assert cfg.path_variety == ("families",) and cfg.families == ("polylines", "arcs")
    assert cfg.validation_paths == 3 and cfg.cases == () and cfg.gcode == ()
    assert TrainConfig.from_dict(cfg.to_dict()) == cfg
    # --plant alone trains on the plant's families (issue 49: train --plant plant.json)
    args = build_parser().parse_args(
        ["train", "--plant", "hsm2", "--out", "unused", "--scale", "0.05",
         "--residual-penalty", "1"]
    )  # fmt: skip
    assert config_from_args(args).path_variety == ("families",)
    args = build_parser().parse_args(["train", "--out", "unused"])
    with pytest.raises(ValueError, match="--paths families"):
        config_from_args(args)
    with pytest.raises(ValueError, match="validation_paths: expected an integer >= 0"):
        TrainConfig(plant="hsm2", path_variety=("families",), validation_paths=-1)


def test_the_ranges_table_of_the_docs_is_the_code():
    doc = (Path(__file__).resolve().parents[2] / "docs" / "RESIDUAL_TRAINING.md").read_text()
    rows = {}
    for line in doc.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if cells and cells[0] in PLANT_RANGES:
            rows[cells[0]] = cells[1:]
    assert set(rows) == set(PLANT_RANGES)

    def span(text, unit):
        lo, hi = text.lstrip("±").split("–") if "–" in text else (text.lstrip("±"),) * 2
        return (float(lo) * unit, float(hi) * unit)

    for plant, r in PLANT_RANGES.items():
        size, feed, a, j, ac, tol, travel, cap = rows[plant]
        assert span(size, 1e-3) == pytest.approx(r.size_m)
        assert span(feed, 1e-3) == pytest.approx(r.feed_m_s)
        assert (float(a), float(j), float(ac)) == pytest.approx(
            (r.max_accel_m_s2, r.max_jerk_m_s3, r.max_centripetal_m_s2)
        )
        assert span(tol, 1e-6) == pytest.approx(r.blend_tolerance_m)
        assert span(travel, 1e-3)[0] == pytest.approx(r.travel_m)
        assert float(cap) == pytest.approx(r.max_path_time_s)
        # a part's size fits the travel
        assert r.size_m[1] <= r.travel_m


def test_every_seed_draws_a_spline_on_the_linear_motor():
    # the first spline draw (random points in a square) failed on 1 seed in ~60 here
    # (seed 2084654370 crashed a training run): its cusps were beyond any feed of the plant
    for seed in [2084654370, *range(60)]:
        part = generate_path("splines", "linear-motor", seed)
        assert part.path.total_length > 0
