"""The declared layout (contour_env.env.layout) is the one source of the kernel's slots, the
observation's length, the info keys and the docstring tables; the entry points' array list is
written once, in the records' declarations."""

from __future__ import annotations

import inspect
import re
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from contour_env import ENV_ID
from contour_env.env import kernel as K
from contour_env.env import layout as L
from contour_env.env.contouring_env import ContouringEnv
from contour_env.env.layout_doc import info_table, observation_table

ENV_DIR = Path(L.__file__).parent


def test_the_index_constants_are_the_declared_positions():
    # the slots of the code before the declaration (a change of any is a kernel change)
    assert (L.C_T, L.C_ERR_SCALE, L.C_W_CONTOUR, L.C_ABORT, L.C_OBS_CLIP) == (0, 1, 6, 10, 13)
    assert (L.C_INV_T, L.C_INV_AXES, L.C_ABORT_TRACK2, L.C_GUARD_PENALTY) == (15, 21, 22, 23)
    assert (L.CFG_SIZE, L.ICFG_SIZE, L.AX_SIZE, L.INFO_ROWS) == (24, 3, 9, 7)
    assert (L.I_NSTEPS, L.I_NSUB, L.I_DELAY) == (0, 1, 2)
    assert (L.AX_STUCK, L.AX_MEAS, L.AX_VEL, L.AX_SAT, L.AX_TOFF) == (0, 2, 3, 6, 8)
    assert (L.INFO_POSITION, L.INFO_ESTIMATE, L.INFO_FORCE) == (0, 4, 6)
    for prefix, fields in (("C_", L.CFG_FIELDS), ("I_", L.ICFG_FIELDS), ("AX_", L.AX_FIELDS)):
        for i, f in enumerate(fields):
            assert getattr(L, prefix + f.name) == i == getattr(K, prefix + f.name)
            assert f.unit and f.doc and f.dtype in ("float64", "int64")
    assert all(f.value is not None for f in L.CFG_FIELDS)


def test_the_config_is_packed_from_the_declaration():
    env = gym.make(ENV_ID, case="hsm2-circle-II", w_lag=0.5, abort_tracking_error_m=0.02)
    core = env.unwrapped.core
    cfg, c, s = core.cfg, core.config, core.setup
    assert cfg[L.C_T] == core.T and cfg[L.C_INV_T] == 1.0 / core.T
    assert cfg[L.C_W_LAG] == 0.5 and cfg[L.C_ABORT_TRACK2] == 0.02**2
    assert cfg[L.C_FEED_SCALE] == s.feedrate_m_s and cfg[L.C_INV_AXES] == 0.5
    assert cfg[L.C_GUARD_PENALTY] == c.guard_penalty
    assert cfg.size == L.CFG_SIZE + len(c.preview_times_s)
    params = s.plant.params
    assert list(core.icfg) == [
        core.n_steps, params.friction_substeps, int(params.computation_delay)
    ]  # fmt: skip
    with pytest.raises(ValueError, match=r"b: an env index in \[0, 1\), got 5"):
        core.info(5)


def test_obs_dim_and_the_observation_table():
    for kw, A in ((dict(case="hsm2-circle-II"), 2), (dict(case="jee-circle3d"), 3)):
        for preview in ((0.005, 0.02, 0.05), (0.01,)):
            env = gym.make(ENV_ID, preview_times_s=preview, **kw)
            n = L.obs_dim(A, len(preview))
            assert env.observation_space.shape == (n,) == (3 * A + 3 + len(preview) * A,)
    doc = inspect.cleandoc(ContouringEnv.__doc__)
    assert observation_table() in doc
    assert info_table() in doc
    # the table's rows are the declared fields
    assert len(observation_table().splitlines()) == 2 + len(L.OBS_FIELDS)


def test_the_info_keys_are_the_declared_ones_single_and_batched():
    keys = [f.name for f, _ in L.INFO_KEYS]
    env = gym.make(ENV_ID, case="hsm2-circle-II")
    _, info0 = env.reset(seed=0)
    _, _, _, _, info = env.step(np.array([0.1, -0.1], dtype=np.float32))
    assert list(info0) == keys == list(info)
    core = env.unwrapped.core
    # the step's info (kernel-filled arrays) equals info(b) read from the state
    again = core.info(0)
    for key in keys:
        np.testing.assert_array_equal(np.asarray(info[key]), np.asarray(again[key]), key)
    assert isinstance(info["time"], float) and isinstance(info["step"], int)
    assert info["position"].shape == (2,) and info["saturated"].dtype == bool
    venv = gym.make_vec(ENV_ID, num_envs=3, vectorization_mode="vector_entry_point",
                        case="hsm2-circle-II")  # fmt: skip
    venv.reset(seed=0)
    _, _, _, _, binfo = venv.step(np.zeros((3, 2), dtype=np.float32))
    assert list(binfo) == keys
    assert binfo["position"].shape == (3, 2) and binfo["contour_error"].shape == (3,)


def _names_in_a_row(text: str, names: set[str], run: int) -> list[str]:
    # every comma-separated run of at least ``run`` record field names, bare or as attributes
    # (``z, ax, k`` or ``self.z, self.ax, self.k``): an array list written out
    found = []
    pattern = r"(?:[\w.]+\s*,\s*){" + str(run - 1) + r",}[\w.]+"
    for m in re.finditer(pattern, text):
        streak = 0
        for word in m.group(0).split(","):
            streak = streak + 1 if word.strip().rsplit(".", 1)[-1] in names else 0
            if streak >= run:
                found.append(m.group(0)[:80])
                break
    return found


def test_the_entry_points_array_list_is_written_once():
    """The records' fields (EnvState, PathArrays, PlantArrays, StepOutputs) are listed in their
    declarations only: no run of 6 of them, comma-separated, in the kernel or the core."""
    names = set()
    for rec in L.ENTRY_RECORDS:
        names |= set(rec._fields)
    for module in ("kernel.py", "core.py"):
        text = (ENV_DIR / module).read_text()
        assert _names_in_a_row(text, names, 6) == [], module
    # the check itself finds the old form
    old = "cfg, icfg, obs_tab, z, ax, k, eps, est, status, seed, ref_pav, frame, seg_type"
    assert _names_in_a_row(old, names, 6)
    assert _names_in_a_row(
        "EnvState(self.z, self.ax, self.k, self.eps, self.est, s.status)", names, 6
    )
    # and the entry points rebuild the records from the flat arrays in the declared order
    bounds = (L.STATE_END, L.PATH_END, L.PLANT_END, L.OUT_END)
    assert bounds == tuple(np.cumsum([len(r._fields) for r in L.ENTRY_RECORDS]))


def test_the_five_axis_entry_points_take_records():
    """The five-axis kernel's arrays are listed in its record declarations only (no run of 6
    field names in its kernel or core), and FiveAxisCore builds each record from its own
    attributes of the same names."""
    from contour_env.env import five_axis_kernel as K5

    records = (K5.FiveAxisPath, K5.FiveAxisEnvState, K5.FiveAxisPlantArrays, L.StepOutputs)
    names = set().union(*(r._fields for r in records))
    for module in ("five_axis_kernel.py", "five_axis_core.py"):
        assert _names_in_a_row((ENV_DIR / module).read_text(), names, 6) == [], module
    assert _names_in_a_row("q, qd, tau, u_pending, meas, mprev, mvel", names, 6)
    env = gym.make("contour_env/FiveAxis-v0").unwrapped
    env.reset(seed=0)
    core = env.core
    path, state, plant, out = core.records()
    for rec in (path, state, out):
        for name in rec._fields:
            assert getattr(rec, name) is getattr(core, name), name
    assert plant.ip is core.packed.ip and plant.pidx is core.packed.pidx
    assert plant.q0_hold is core.q0_hold and plant.resolution is core.resolution
    # the outputs a step hands out are replaced (renew_outputs): the record follows
    old = core.obs
    core.renew_outputs()
    assert core.obs is not old and core.records()[3].obs is core.obs
    assert core.records()[1] is state  # the rest is kept


def test_the_packed_plant_unpacks_in_the_records_order():
    from dataclasses import fields

    from contour_env.plants import PackedPlant, Plant

    assert tuple(f.name for f in fields(PackedPlant)) == L.PlantArrays._fields
    packed = Plant("hsm2").packed_batch(2)
    assert all(a is b for a, b in zip(packed, (packed.mat_T, packed.mat_h, packed.cont,
                                                packed.nl, packed.pidx), strict=True))  # fmt: skip
