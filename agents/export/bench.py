"""Latency of an exported law on this CPU: the C law (compiled with the system compiler, timed
in C, one ``clock_gettime`` pair per call) and the ONNX graph in ONNX Runtime (timed from
Python, one ``InferenceSession.run`` per call: what a Python host pays).

Each is called on the inputs of a sample in motion, as a servo loop calls it: every
``action_repeat``-th call evaluates the network, the others hold its action, so the median is
a holding call and the p99 a deciding one; the deciding calls are also reported alone.
"""

from __future__ import annotations

import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

HARNESS = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <string.h>
#include <time.h>
#include "residual.h"

static const double INPUTS[] = {%(inputs)s};

static double now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e9 + (double)ts.tv_nsec;
}

int main(void)
{
    static double t[%(calls)d];
    residual_inputs in;
    residual_state st;
    residual_outputs out;
    double sink = 0.0;
    int i;
    memcpy(&in, INPUTS, sizeof(in));
    residual_reset(&st);
    for (i = 0; i < 1000; ++i) residual_step(&in, &st, &out);  /* warm the caches */
    for (i = 0; i < %(calls)d; ++i) {
        double t0 = now_ns();
        residual_step(&in, &st, &out);
        t[i] = now_ns() - t0;
        sink += out.residual[0];
    }
    for (i = 0; i < %(calls)d; ++i) printf("%%.1f\n", t[i]);
    fprintf(stderr, "%%g\n", sink);
    return 0;
}
"""


def compiler() -> str | None:
    """The system's C compiler (cc, gcc or clang), or None."""
    return shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")


def _summary(ns: np.ndarray, repeat: int) -> dict:
    us = np.asarray(ns, dtype=np.float64) / 1e3
    deciding = us[::repeat] if repeat > 1 else us
    return {
        "calls": int(len(us)),
        "median_us": float(np.median(us)),
        "p99_us": float(np.percentile(us, 99)),
        "deciding_median_us": float(np.median(deciding)),
        "deciding_p99_us": float(np.percentile(deciding, 99)),
    }


def bench_c(c_dir, inputs: dict, order, repeat: int, calls: int = 100_000) -> dict:
    """µs per ``residual_step`` call of the C law in ``c_dir`` (median, p99, and those of the
    deciding calls), compiled ``-O2``; ``inputs`` {name: array} in the header's ``order``."""
    cc = compiler()
    if cc is None:
        raise ValueError("--bench: no C compiler (cc, gcc or clang) on this machine")
    flat = np.concatenate([np.asarray(inputs[k], dtype=np.float64).reshape(-1) for k in order])
    with tempfile.TemporaryDirectory(prefix="residual-bench-") as tmp:
        tmp = Path(tmp)
        for name in ("residual.h", "residual.c"):
            shutil.copyfile(Path(c_dir) / name, tmp / name)
        values = ", ".join(repr(float(v)) for v in flat)
        (tmp / "bench.c").write_text(HARNESS % {"inputs": values, "calls": int(calls)})
        exe = tmp / "bench"
        cmd = [cc, "-O2", "-std=c99", "-o", str(exe), str(tmp / "bench.c"),
               str(tmp / "residual.c"), "-lm"]  # fmt: skip
        done = subprocess.run(cmd, capture_output=True, text=True, check=False)
        if done.returncode != 0:
            raise ValueError(f"--bench: the C law does not compile: {done.stderr.strip()}")
        run = subprocess.run([str(exe)], capture_output=True, text=True, check=True)
    ns = np.array([float(x) for x in run.stdout.split()])
    return {**_summary(ns, repeat), "compiler": Path(cc).name, "flags": "-O2 -std=c99"}


def bench_onnx(path, inputs: dict, state: dict, repeat: int, calls: int = 20_000) -> dict:
    """µs per ``InferenceSession.run`` of the ONNX graph at ``path`` (one thread, default
    optimisations), the state carried between calls as a servo loop would."""
    import onnxruntime as ort

    so = ort.SessionOptions()
    so.intra_op_num_threads = 1
    so.inter_op_num_threads = 1
    sess = ort.InferenceSession(str(path), so, providers=["CPUExecutionProvider"])
    names = [o.name for o in sess.get_outputs()]
    wanted = [i.name for i in sess.get_inputs()]
    feed = {k: np.asarray(v, dtype=np.float64) for k, v in {**inputs, **state}.items()}
    ns = np.empty(calls)
    for i in range(-200, calls):
        t0 = time.perf_counter_ns()
        out = sess.run(None, {k: feed[k] for k in wanted})
        dt = time.perf_counter_ns() - t0
        o = dict(zip(names, out, strict=True))
        for k in state:
            feed[k] = o[f"next_{k}"]
        if i >= 0:
            ns[i] = dt
    return {**_summary(ns, repeat), "onnxruntime": ort.__version__}
