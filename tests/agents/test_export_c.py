"""The C99 export of a trained residual agent (agents/export/c_law.py) against the Python agent.

The generated ``residual.c`` is built with the system compiler into a shared library and
called through ctypes once per servo period with what the env's core holds at that period;
its residual must equal the Python agent's (``ResidualAgent.applied_action``) to 1e-5 of the
force limit at every step, and the C law driving the env must give the Python agent's
contour error.
"""

from __future__ import annotations

import ctypes
import re
import shutil
import subprocess
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import agents.residual as residual_mod
import contour_env  # noqa: F401  (registers the env)
from agents.export import write_c
from agents.residual import ResidualAgent, make_base
from contour_env.env.kernel import AX_MEAS
from contour_env.evaluation import evaluate

MODELS = Path(__file__).resolve().parents[2] / "agents" / "models"
LM = MODELS / "linear-motor"
FT = MODELS / "friction-table"

TOL = 1e-5  # fraction of the force limit
# straight lines through two square corners and back on a diagonal
LINES = "G21 G90 G17 G61\nG01 X20 F3000\nG01 Y15\nG01 X0 Y0\n"
# a line, a corner into a CCW arc, a line, a CW arc, a line (blended corners)
CURVED = "G21 G90 G17 G64\nG01 X15 F3600\nG03 X25 Y10 R10\nG01 Y20\nG02 X15 Y30 R10\nG01 X0\n"
PARTS = {
    "lines": dict(plant="linear-motor", path=LINES, feedrate_m_s=0.05, max_accel_m_s2=0.5),
    "curved": dict(plant="linear-motor", path=CURVED, feedrate_m_s=0.06, max_accel_m_s2=0.5),
}
LM_CIRCLE_STEPS = 25_000

CC = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")


class Law:
    """The generated law, built and loaded with ctypes; inputs as one flat float64 buffer
    (every field of ``residual_inputs`` is a double, in the header's order)."""

    def __init__(self, model_dir, out_dir: Path):
        self.iface = write_c(model_dir, out_dir)
        lib_path = out_dir / "libresidual.so"
        cmd = [CC, "-O2", "-shared", "-fPIC", "-std=c99", "-Wall", "-Wextra", "-pedantic",
               "-o", str(lib_path), str(out_dir / "residual.c"), "-lm"]  # fmt: skip
        done = subprocess.run(cmd, capture_output=True, text=True, check=False)
        assert done.returncode == 0, done.stderr
        self.warnings = done.stderr
        self.lib = ctypes.CDLL(str(lib_path))
        n = self.iface["n_axes"]
        p = len(self.iface["preview_times_s"])
        self.n, self.p = n, p
        sizes = {
            row["name"]: int(np.prod(row["shape"])) if row["shape"] else 1
            for row in self.iface["inputs"]
        }
        self.slices = {}
        at = 0
        for row in self.iface["inputs"]:
            self.slices[row["name"]] = slice(at, at + sizes[row["name"]])
            at += sizes[row["name"]]
        self.buf = np.zeros(at, dtype=np.float64)

        class State(ctypes.Structure):
            _fields_ = [
                ("prev_encoder", ctypes.c_double * n),
                ("prev_applied", ctypes.c_double * n),
                ("held_action", ctypes.c_double * (n + 1)),
                ("envelope_fade", ctypes.c_double),
                ("count", ctypes.c_int),
                ("first", ctypes.c_int),
                ("prev_valid", ctypes.c_int),
            ]

        class Outputs(ctypes.Structure):
            _fields_ = [
                ("residual", ctypes.c_double * n),
                ("applied", ctypes.c_double * n),
                ("gate", ctypes.c_double),
                ("envelope_fade", ctypes.c_double),
                ("rest_fade", ctypes.c_double),
                ("bad_input", ctypes.c_int),
                ("decided", ctypes.c_int),
                ("status", ctypes.c_int),
            ]

        self.state = State()
        self.out = Outputs()
        self.lib.residual_step.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p]
        self.lib.residual_step.restype = None
        self.lib.residual_reset.argtypes = [ctypes.c_void_p]
        self.lib.residual_reset.restype = None
        self._in_ptr = self.buf.ctypes.data
        self._st_ptr = ctypes.addressof(self.state)
        self._out_ptr = ctypes.addressof(self.out)

    def reset(self) -> None:
        self.lib.residual_reset(self._st_ptr)

    def set(self, name, value) -> None:
        self.buf[self.slices[name]] = np.asarray(value, dtype=np.float64).reshape(-1)

    def fill_from_core(self, core, mask, base) -> None:
        """The inputs of env 0 of ``core`` at its current sample (as the env observes it)."""
        n = self.n
        kk = min(int(core.k[0]), core.n_steps - 1)
        kj = np.minimum(kk + core.preview, core.n_steps - 1)
        s = self.set
        s("ref_position", core.ref_pav[kk, 0, :n])
        s("ref_velocity", core.ref_pav[kk, 1, :n])
        s("ref_acceleration", core.ref_pav[kk, 2, :n])
        s("frame", core.frame[kk, :n, :n])
        s("path_speed", core.scal[kk, 0])
        s("path_accel", core.scal[kk, 1])
        s("curvature", core.scal[kk, 2])
        s("preview_position", core.ref_pav[kj, 0, :n])
        s("encoder_position", core.ax[AX_MEAS, 0])
        s("programmed_feed", core.setup.feedrate_m_s)
        s("max_accel", core.setup.max_accel_m_s2)
        s("axis_mask", mask)
        s("base_command", base)

    def step(self):
        self.lib.residual_step(self._in_ptr, self._st_ptr, self._out_ptr)
        o = self.out
        return np.array(o.residual[:]), np.array(o.applied[:])


@pytest.fixture(scope="module")
def lm_law(tmp_path_factory):
    if CC is None:
        pytest.skip("no C compiler (cc, gcc or clang) on this machine")
    return Law(LM, tmp_path_factory.mktemp("lm_c"))


@pytest.fixture(scope="module")
def ft_law(tmp_path_factory):
    if CC is None:
        pytest.skip("no C compiler (cc, gcc or clang) on this machine")
    return Law(FT, tmp_path_factory.mktemp("ft_c"))


def _parity_run(law: Law, env, max_steps: int, monkeypatch) -> dict:
    """Run the Python agent on ``env`` (it drives the env) and the C law alongside it on the
    same inputs; the largest |C residual − Python residual| and the Python run's errors."""
    core = env.unwrapped.core
    agent = ResidualAgent(LM).bind(env)
    seen = {}
    real_command = residual_mod.residual_command

    def capture_command(*args, **kwargs):
        res, g = real_command(*args, **kwargs)
        seen["res"], seen["g"] = res, g
        return res, g

    monkeypatch.setattr(residual_mod, "residual_command", capture_command)
    real_base = agent.base.action

    def capture_base(sig):
        a = real_base(sig)
        seen["base"] = np.asarray(a)
        return a

    agent.base.action = capture_base
    env.reset(seed=0)
    agent.reset(np.ones(1, dtype=bool))  # as run_episode's first predict
    law.reset()
    mask = agent._axis_mask()
    worst = 0.0
    worst_applied = 0.0
    eps = []
    gates_open = 0
    biggest = 0.0
    min_fade = 1.0
    steps = min(max_steps, core.n_steps - 1)
    for n in range(steps):
        applied = agent.applied_action(core.signals_batch())
        law.fill_from_core(core, mask, seen["base"][0])
        res_c, applied_c = law.step()
        d = float(np.max(np.abs(res_c - seen["res"][0])))
        assert d <= TOL, f"step {n}: C residual {res_c} vs Python {seen['res'][0]} (|d| {d:.3g})"
        worst = max(worst, d)
        worst_applied = max(worst_applied, float(np.max(np.abs(applied_c - applied[0]))))
        gates_open += law.out.gate > 0
        biggest = max(biggest, float(np.max(np.abs(res_c))))
        min_fade = min(min_fade, law.out.envelope_fade)
        _, _, terminated, truncated, _ = env.step(applied[0])
        eps.append(float(core.eps[0]))
        if terminated or truncated:
            break
    assert law.out.bad_input == 0
    e = np.asarray(eps)
    return {
        "steps": len(eps),
        "max_abs_residual_diff": worst,
        "max_abs_applied_diff": worst_applied,
        "gate_open_fraction": gates_open / max(len(eps), 1),
        "max_abs_residual": biggest,
        "min_envelope_fade": min_fade,
        "rms_um": float(np.sqrt(np.mean(e**2)) * 1e6),
        "max_um": float(e.max() * 1e6),
    }


def test_parity_outside_the_envelope(lm_law, monkeypatch):
    """A part programmed above the agent's feed range: the envelope fades the gate (f < 1)."""
    kw = dict(PARTS["lines"], feedrate_m_s=0.17)
    env = gym.make("contour_env/Contouring-v0", **kw)
    r = _parity_run(lm_law, env, 8000, monkeypatch)
    print("outside", r)
    assert 0.0 < r["min_envelope_fade"] < 1.0


def test_generated_code_is_plain_c99(lm_law, ft_law):
    for law in (lm_law, ft_law):
        assert law.warnings.strip() == "", law.warnings
        src = Path(law.iface["files"][1]).read_text()
        head = Path(law.iface["files"][0]).read_text()
        includes = [ln for ln in (src + head).splitlines() if ln.startswith("#include")]
        assert sorted(set(includes)) == ['#include "residual.h"', "#include <math.h>"]
        for word in ("malloc", "calloc", "free(", "printf"):
            assert word not in src
        # every array and constant is read-only: no mutable static data
        assert not re.search(r"^static (double|float|int)\s+\w+\s*(\[|=|;)", src, re.M)
        assert "void residual_step(const residual_inputs *in, residual_state *st, " in head
    names = [row["name"] for row in lm_law.iface["inputs"]]
    assert names[:3] == ["ref_position", "ref_velocity", "ref_acceleration"]
    assert {row["name"] for row in lm_law.iface["outputs"]} >= {
        "residual", "applied", "gate", "envelope_fade", "bad_input"
    }  # fmt: skip
    assert all(row["unit"] for row in lm_law.iface["inputs"])


def test_parity_lm_circle3d(lm_law, monkeypatch):
    env = gym.make("contour_env/Contouring-v0", case="lm-circle3d")
    r = _parity_run(lm_law, env, LM_CIRCLE_STEPS, monkeypatch)
    print("lm-circle3d", r)
    assert r["steps"] == LM_CIRCLE_STEPS
    # the agent acts: the parity is not of zeros
    assert r["gate_open_fraction"] > 0.1 and r["max_abs_residual"] > 1e-3


@pytest.mark.parametrize("part", sorted(PARTS))
def test_parity_gcode_parts(lm_law, monkeypatch, part):
    env = gym.make("contour_env/Contouring-v0", **PARTS[part])
    core = env.unwrapped.core
    r = _parity_run(lm_law, env, core.n_steps, monkeypatch)
    print(part, r)
    assert r["steps"] == core.n_steps - 1  # the whole part
    assert r["gate_open_fraction"] > 0.1 and r["max_abs_residual"] > 1e-3


class CLawPolicy:
    """The C law as a policy of :func:`contour_env.evaluation.evaluate`: a base controller
    bound to the env, plus the C residual; the env is driven by the C law's ``applied``."""

    def __init__(self, law: Law, model_dir):
        self.law = law
        self.model_dir = model_dir

    def bind(self, env):
        self.core = env.unwrapped.core
        meta = ResidualAgent(self.model_dir).meta
        self.base = make_base(meta["base"], env, meta.get("base_kwargs") or {})
        self.mask = residual_mod.path_axes_mask(self.core)
        self.law.reset()
        return self

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        if episode_start is not None and np.any(episode_start):
            self.base.reset()
            self.law.reset()
        base = np.asarray(self.base.action(self.core.signals_batch()))[0]
        self.law.fill_from_core(self.core, self.mask, base)
        _, applied = self.law.step()
        assert self.law.out.bad_input == 0
        return applied, state


# The closed loop itself is sensitive far below the C law's 5e-8 deviation: the encoder's
# quantisation and the stick-slip of the linear motor's friction turn a 1e-12 change of the
# command into a different sequence of encoder counts, and the episode's RMS contour error
# moves by 0.5-2 % (measured with the Python agent itself: lines 0.759 um -> 0.744-0.754 um
# at 1e-12, curved 1.562 -> 1.567-1.600 um at 1e-8; the max moves by up to 0.8 %).
# A law that is not bit-identical to the Python agent (its network runs in float32 BLAS)
# cannot meet 0.1 % on such a part; the test holds the C law to that reproducibility floor
# (measured: lines RMS +0.69 %, max -0.07 %; curved RMS +0.61 %, max +0.35 %; on the whole
# of lm-circle3d, not run here (25 s): RMS -0.05 %, max -0.21 %), and
# test_closed_loop_is_sensitive_below_float_rounding checks the floor is real.
EPISODE_REL = {"rms_contour_error_um": 0.03, "max_contour_error_um": 0.015}


@pytest.mark.parametrize("part", sorted(PARTS))
def test_c_law_drives_env_like_python(lm_law, part):
    py = evaluate(gym.make("contour_env/Contouring-v0", **PARTS[part]), ResidualAgent(LM))
    c = evaluate(gym.make("contour_env/Contouring-v0", **PARTS[part]), CLawPolicy(lm_law, LM))
    print(part, "python", py["rms_contour_error_um"], py["max_contour_error_um"],
          "C", c["rms_contour_error_um"], c["max_contour_error_um"])  # fmt: skip
    assert c["completed"] and py["completed"]
    for key, rel in EPISODE_REL.items():
        assert c[key] == pytest.approx(py[key], rel=rel), key


class _Perturbed(ResidualAgent):
    """The Python agent with a 1e-12 random change of its applied command."""

    def applied_action(self, signals):
        a = super().applied_action(signals)
        return a + self._rng.normal(0.0, 1e-12, a.shape)


def test_closed_loop_is_sensitive_below_float_rounding():
    kw = PARTS["lines"]
    ref = evaluate(gym.make("contour_env/Contouring-v0", **kw), ResidualAgent(LM))
    agent = _Perturbed(LM)
    agent._rng = np.random.default_rng(1)
    pert = evaluate(gym.make("contour_env/Contouring-v0", **kw), agent, compiled=False)
    ratio = pert["rms_contour_error_um"] / ref["rms_contour_error_um"]
    print("1e-12 perturbation: RMS ratio", ratio)
    assert abs(ratio - 1.0) > 1e-3


def _fill_static(law: Law, env) -> None:
    core = env.unwrapped.core
    core.k[0] = min(2000, core.n_steps - 1)
    base = np.full(law.n, 0.3)
    law.fill_from_core(core, np.ones(law.n), base)


def test_nan_input_closes_the_gate(lm_law):
    env = gym.make("contour_env/Contouring-v0", **PARTS["curved"])
    env.reset(seed=0)
    law = lm_law
    for name, value in (
        ("encoder_position", np.nan),
        ("frame", np.inf),
        ("preview_position", -np.inf),
        ("base_command", np.nan),
        ("programmed_feed", 0.0),
        ("programmed_feed", -0.05),
        ("max_accel", np.nan),
    ):
        law.reset()
        _fill_static(law, env)
        good = law.buf.copy()
        for _ in range(3):  # a few good periods: the gate opens
            law.buf[:] = good
            law.step()
        assert law.out.bad_input == 0
        bad = law.buf.copy()
        sl = law.slices[name]
        bad[sl.start] = value
        law.buf[:] = bad
        res, applied = law.step()
        assert law.out.bad_input == 1, name
        assert law.out.status & 1
        assert np.all(res == 0.0), name
        assert law.out.gate == 0.0
        expect = np.clip(np.nan_to_num(bad[law.slices["base_command"]], nan=0.0), -1, 1)
        assert np.array_equal(applied, expect), name
        # the next good period acts again (after a warm-up period if the encoder was lost)
        law.buf[:] = good
        law.step()
        if name == "encoder_position":
            assert law.out.status == 2 and np.all(np.array(law.out.residual[:]) == 0.0)
            law.step()
        assert law.out.bad_input == 0 and law.out.decided == 1
        assert np.all(np.isfinite(law.out.applied[:]))


def test_kept_base_agent_exports_the_zero_law(ft_law):
    assert ResidualAgent(FT).is_base
    assert ft_law.iface["zero_law"] is True
    src = Path(ft_law.iface["files"][1]).read_text()
    assert "ZERO law" in src and "L0_W" not in src
    env = gym.make("contour_env/Contouring-v0", plant="friction-table",
                   path="G21 G90 G17 G61\nG01 X2 F1200\nG01 Y2\n")  # fmt: skip
    core = env.unwrapped.core
    agent = ResidualAgent(FT).bind(env)
    env.reset(seed=0)
    agent.reset(np.ones(1, dtype=bool))
    ft_law.reset()
    rng = np.random.default_rng(0)
    for n in range(core.n_steps - 1):
        sig = core.signals_batch()
        applied = agent.applied_action(sig)
        base = applied[0] + (rng.normal(0, 0.5, ft_law.n) if n % 7 == 0 else 0.0)
        ft_law.fill_from_core(core, np.ones(ft_law.n), base)
        res, applied_c = ft_law.step()
        assert np.all(res == 0.0)
        assert np.array_equal(applied_c, np.clip(base, -1, 1))
        assert ft_law.out.gate == 0.0
        _, _, te, tr, _ = env.step(applied[0])
        if te or tr:
            break
    ft_law.set("encoder_position", [np.nan] * ft_law.n)
    res, _ = ft_law.step()
    assert ft_law.out.bad_input == 1 and np.all(res == 0.0)
