"""Borrowed array views (contour_env.env.borrow): same data, shape and strides, writes reach
the original, and the drivers that use them give what the plain code gives."""

import numpy as np
import pytest
from numba import njit
from numba.core.errors import TypingError

from contour_env.env.borrow import borrowed


@njit
def _fill_through_view(a, value):
    v = borrowed(a)
    for i in range(v.shape[0]):
        for j in range(v.shape[1]):
            v[i, j] = value * (i + 1) + j
    return v.shape[0], v.shape[1], v.strides[0], v.strides[1]


@njit
def _sum_view(a):
    v = borrowed(a)
    return v.sum()


def test_writes_through_a_borrowed_view_reach_the_array():
    a = np.zeros((3, 4))
    shape0, shape1, s0, s1 = _fill_through_view(a, 10.0)
    assert (shape0, shape1) == a.shape and (s0, s1) == a.strides
    np.testing.assert_array_equal(a, 10.0 * np.arange(1, 4)[:, None] + np.arange(4)[None, :])


def test_a_strided_view_keeps_its_strides():
    rng = np.random.default_rng(0)
    base = rng.normal(size=(6, 8))
    view = base[::2, 1::3]  # non-contiguous
    assert _sum_view(view) == pytest.approx(view.sum(), rel=1e-15)
    out = np.zeros((6, 8))
    _fill_through_view(out[::2, 1::3], 1.0)
    expected = np.zeros((6, 8))
    expected[::2, 1::3] = np.arange(1, 4)[:, None] + np.arange(3)[None, :]
    np.testing.assert_array_equal(out, expected)


def test_borrowed_refuses_what_is_not_an_array():
    @njit
    def f(x):
        return borrowed(x)

    with pytest.raises(TypingError):
        f(1.0)


def test_the_serial_driver_equals_the_parallel_driver_bit_for_bit():
    import gymnasium as gym

    import contour_env  # noqa: F401

    rng = np.random.default_rng(7)
    acts = rng.uniform(-0.3, 0.3, (60, 64, 2))
    runs = []
    for threads in (1, 2):
        venv = gym.make_vec(
            "contour_env/Contouring-v0",
            num_envs=64,
            vectorization_mode="vector_entry_point",
            case="hsm2-circle-II",
            num_threads=threads,
        )
        venv.reset(seed=3)
        out = [venv.step(a)[:2] for a in acts]
        obs = np.array([o[0] for o in out])
        rewards = np.array([o[1] for o in out])
        runs.append((obs, rewards, venv.core.z.copy()))
        venv.close()
    for x, y in zip(runs[0], runs[1], strict=True):
        np.testing.assert_array_equal(x, y)


def test_stores_through_a_borrowed_view_stay_in_a_parallel_loop():
    # the parfor pass removes stores into an array that nothing reads afterwards unless it
    # aliases an argument: borrowed() is registered as such an alias (without it: all zeros)
    from numba import prange

    @njit(parallel=True)
    def fill(a, b):
        va = borrowed(a)
        vb = borrowed(b)
        for i in prange(va.shape[0]):
            va[i] = i + 1.0
            vb[i, 1] = 2.0 * i
        return 0

    a = np.zeros(1000)
    b = np.zeros((1000, 3))
    fill(a, b)
    np.testing.assert_array_equal(a, np.arange(1, 1001))
    np.testing.assert_array_equal(b[:, 1], 2.0 * np.arange(1000))
    assert not b[:, 0].any() and not b[:, 2].any()
