"""Run an exported C law in the simulator, as the machine's controller would: compiled with the
system compiler into a shared library, called through ctypes once per servo period on top of
a base controller (:class:`CLawController`, a policy for
:func:`contour_env.evaluation.evaluate`). This is how the sim-to-real chain scores the law a
machine would run (``scripts/sim_to_real.py``)."""

from __future__ import annotations

import ctypes
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from .bench import compiler


class CLaw:
    """``residual.c`` of ``c_dir`` built and loaded; ``iface``: :func:`write_c`'s result."""

    def __init__(self, c_dir, iface: dict):
        cc = compiler()
        if cc is None:
            raise ValueError("C law: no C compiler (cc, gcc or clang) on this machine")
        self._tmp = tempfile.TemporaryDirectory(prefix="residual-law-")
        lib = Path(self._tmp.name) / "libresidual.so"
        cmd = [cc, "-O2", "-shared", "-fPIC", "-std=c99", "-o", str(lib),
               str(Path(c_dir) / "residual.c"), "-lm"]  # fmt: skip
        done = subprocess.run(cmd, capture_output=True, text=True, check=False)
        if done.returncode != 0:
            raise ValueError(f"C law: {c_dir}/residual.c does not compile: {done.stderr.strip()}")
        self.lib = ctypes.CDLL(str(lib))
        n = int(iface["n_axes"])
        self.n = n
        self.order = [(r["name"], int(np.prod(r["shape"])) if r["shape"] else 1)
                      for r in iface["inputs"]]  # fmt: skip
        self.buf = np.zeros(sum(k for _, k in self.order), dtype=np.float64)

        class State(ctypes.Structure):
            _fields_ = [("prev_encoder", ctypes.c_double * n),
                        ("prev_applied", ctypes.c_double * n),
                        ("held_action", ctypes.c_double * (n + 1)),
                        ("envelope_fade", ctypes.c_double), ("count", ctypes.c_int),
                        ("first", ctypes.c_int), ("prev_valid", ctypes.c_int)]  # fmt: skip

        class Outputs(ctypes.Structure):
            _fields_ = [("residual", ctypes.c_double * n), ("applied", ctypes.c_double * n),
                        ("gate", ctypes.c_double), ("envelope_fade", ctypes.c_double),
                        ("rest_fade", ctypes.c_double), ("bad_input", ctypes.c_int),
                        ("decided", ctypes.c_int), ("status", ctypes.c_int)]  # fmt: skip

        self.state, self.out = State(), Outputs()
        for name in ("residual_step", "residual_reset"):
            getattr(self.lib, name).restype = None
        self.lib.residual_step.argtypes = [ctypes.c_void_p] * 3
        self.lib.residual_reset.argtypes = [ctypes.c_void_p]
        self._ptrs = (self.buf.ctypes.data, ctypes.addressof(self.state),
                      ctypes.addressof(self.out))  # fmt: skip

    def reset(self) -> None:
        self.lib.residual_reset(self._ptrs[1])

    def step(self, inputs: dict) -> np.ndarray:
        """The applied command (n,) for ``inputs`` {name: array} (see ``describe_interface``)."""
        at = 0
        for name, size in self.order:
            self.buf[at : at + size] = np.asarray(inputs[name], dtype=np.float64).reshape(-1)
            at += size
        self.lib.residual_step(*self._ptrs)
        return np.array(self.out.applied[:])


class CLawController:
    """A base controller (a spec, as ``contour-env compare`` takes it) plus the C law, as a
    policy of :func:`contour_env.evaluation.evaluate`: each servo period the base's command
    and the interpolator's sample go into ``residual_step``, and its ``applied`` drives the
    env."""

    def __init__(self, law: CLaw, base_spec: str):
        self.law = law
        self.base_spec = base_spec

    def bind(self, env):
        from agents.registry import make_controller
        from agents.residual import path_axes_mask

        self.core = env.unwrapped.core
        self.base = make_controller(self.base_spec, env=env).bind(env)  # the env's family
        self.mask = path_axes_mask(self.core)
        self.law.reset()
        return self

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        from .replay import inputs_from_core

        if episode_start is not None and np.any(episode_start):
            self.base.reset()
            self.law.reset()
        base = np.asarray(self.base.action(self.core.signals_batch()), dtype=np.float64)[0]
        applied = self.law.step(inputs_from_core(self.core, self.mask, base))
        return applied, state
