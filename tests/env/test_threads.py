"""The step's thread policy (env option ``num_threads``): results independent of the thread
count, the option checked, the adaptive choice, and the benchmark's busy process cleaned up."""

import gymnasium as gym
import numpy as np
import pytest

import contour_env
from contour_env.env.core import PARALLEL_MIN_ENVS, StepThreads

# (case, env options): two axes with stick–slip (the literal two-axis body), three axes (the
# generic body: jee-triaxial, and the linear motor with its two-mass states and a tight
# contour guard, so that its envs end too), and the friction table with encoder noise, a
# random force and a random disturbance phase (the noise streams)
CASES = [
    ("hsm2-circle-II", {}),
    ("jee-circle3d", {}),
    ("lm-circle3d", {"structural_mode": True, "abort_contour_error_m": 2e-5}),
    (
        "sharp-corner",
        {
            "measurement_noise_std_m": 2e-7,
            "disturbance_force_N": 5.0,
            "disturbance_phase": "random",
        },
    ),
]


def _rollout(num_threads, case="hsm2-circle-II", options=None, n_envs=512, steps=300):
    """Every array a vector env returns over ``steps`` seeded random steps (guard terminations
    and autoresets included), and its state at the end. ``num_threads="alternate"``: 1 and 2
    threads in turns, step by step (the serial and the parallel driver within one episode)."""
    alternate = num_threads == "alternate"
    venv = gym.make_vec(
        contour_env.ENV_ID,
        num_envs=n_envs,
        vectorization_mode="vector_entry_point",
        case=case,
        num_threads=1 if alternate else num_threads,
        **(options or {}),
    )
    core = venv.unwrapped.core
    assert core.num_threads == (1 if alternate else num_threads)
    rng = np.random.default_rng(3)
    obs, _ = venv.reset(seed=7)
    out = [obs.copy()]
    dim = venv.single_action_space.shape[0]
    n_ended = 0
    for t in range(steps):
        if alternate:
            core.num_threads = 1 + t % 2
        # large random actions in the first and the third quarter (guard terminations and
        # autoresets), small ones between (a random walk around standstill: stick–slip)
        amp = 1.0 if (4 * t // steps) % 2 == 0 else 0.01
        a = rng.uniform(-amp, amp, (n_envs, dim))
        obs, reward, term, trunc, info = venv.step(a.astype(np.float32))
        out += [obs.copy(), reward.copy(), term.copy(), trunc.copy()]
        out += [np.asarray(v).copy() for _, v in sorted(info.items()) if not _.startswith("_")]
        n_ended += int(np.sum(term | trunc))
    out += [core.z.copy(), core.k.copy(), np.array([n_ended])]
    venv.close()
    return out


@pytest.mark.parametrize(("case", "options"), CASES, ids=[c for c, _ in CASES])
def test_results_are_bit_identical_for_any_thread_count(case, options):
    one = _rollout(1, case, options)
    # some envs ended and were reset: the autoreset path is in the comparison
    assert one[-1][0] > 0
    for other in ("alternate", 2, "auto"):
        two = _rollout(other, case, options)
        assert len(one) == len(two)
        for x, y in zip(one, two, strict=True):
            np.testing.assert_array_equal(x, y, err_msg=f"num_threads={other!r}")


@pytest.mark.parametrize("bad", [0, -1, 1.5, True, "two", [2]])
def test_num_threads_must_be_a_positive_integer_or_auto(bad):
    with pytest.raises(ValueError, match="num_threads"):
        gym.make_vec(
            contour_env.ENV_ID, num_envs=2, vectorization_mode="vector_entry_point", num_threads=bad
        )


def test_default_is_auto_and_small_batches_step_serially():
    venv = gym.make_vec(contour_env.ENV_ID, num_envs=4, vectorization_mode="vector_entry_point")
    core = venv.unwrapped.core
    assert core.num_threads == "auto" and core.threads.candidates == (1,)
    assert StepThreads(None, PARALLEL_MIN_ENVS - 1).candidates == (1,)
    assert StepThreads(3, 10).current in (1, 2, 3)  # capped at numba's thread count
    core.num_threads = 1
    assert core.num_threads == 1 and core.threads.candidates == (1,)
    env = gym.make(contour_env.ENV_ID, num_threads=1)
    assert env.unwrapped.core.num_threads == 1


def _policy(candidates):
    pol = StepThreads("auto", 4096)
    pol.candidates = candidates
    pol._start_probe()
    return pol


def _feed(pol, cost, now, n, counts=None):
    # n steps, each taking cost[threads] seconds; returns the time after them
    for _ in range(n):
        dt = cost[pol.current]
        if counts is not None:
            counts[pol.current] = counts.get(pol.current, 0) + 1
        now += dt
        pol._record(dt, now)
    return now


def test_auto_keeps_the_fastest_count_and_moves_when_the_machine_changes():
    pol = _policy((1, 2, 4))
    quiet = {1: 4e-3, 2: 2e-3, 4: 1.2e-3}
    now = _feed(pol, quiet, 0.0, 20)
    assert pol._probe is None and pol.current == 4
    # another process takes cores: 4 threads collapse; the slowdown triggers a probe at once
    busy = {1: 5e-3, 2: 3e-3, 4: 40e-3}
    probes = pol.n_probes
    counts = {}
    now = _feed(pol, busy, now, 40, counts)
    assert pol.n_probes == probes + 1 and pol.current == 2
    # the collapsed count: the step that showed it, then two in the probe (the untimed one,
    # which never decides, and the first timed one, far slower than 2 threads)
    assert counts[4] == 3
    # quiet again: the next periodic probe goes back to 4 threads
    now = _feed(pol, quiet, now, int(pol.MAX_HOLD_S / 2e-3) + 50)
    assert pol.current == 4
    # a steady machine: the hold between probes grows to MAX_HOLD_S
    _feed(pol, quiet, now, int(4 * pol.MAX_HOLD_S / 1.2e-3))
    assert pol._hold_s == pol.MAX_HOLD_S


def test_bench_kills_its_busy_process_even_on_interrupt(monkeypatch):
    from contour_env.app import speed as bench

    started = []
    real_start = bench.start_busy_process

    def start():
        started.append(real_start())
        return started[-1]

    def interrupted(_s):
        raise KeyboardInterrupt

    monkeypatch.setattr(bench, "start_busy_process", start)
    monkeypatch.setattr(bench.time, "sleep", interrupted)
    with pytest.raises(KeyboardInterrupt):
        bench.run_bench(quick=True, sizes=(), extra_envs=64, controllers=False)
    assert len(started) == 1 and started[0].poll() is not None


def test_a_slow_first_call_does_not_drop_a_thread_team():
    """The first call of a team includes starting its pool (28-89 ms measured against a 1.4 ms
    serial step at 4,096 envs, issue 35): the probe does not judge it on that call."""
    pol = _policy((1, 2))
    fast = {1: 1.4e-3, 2: 0.8e-3}
    calls = {1: 0, 2: 0}
    now = 0.0
    for _ in range(20):
        n = pol.current
        calls[n] += 1
        dt = 60e-3 if (n == 2 and calls[2] == 1) else fast[n]
        now += dt
        pol._record(dt, now)
    assert pol._probe is None and pol.current == 2


def test_the_serial_winner_is_probed_again_at_the_shortest_hold():
    pol = _policy((1, 2))
    busy = {1: 1.4e-3, 2: 10e-3}  # two threads lose: another process holds a core
    now = 0.0
    for _ in range(3):  # probe after probe, the serial driver keeps winning
        now = _feed(pol, busy, now, int(1.5 * pol.HOLD_S / 1.4e-3))
        assert pol.current == 1 and pol._hold_s == pol.HOLD_S
    # the machine gets quiet: within about a second the team is back
    now = _feed(pol, {1: 1.4e-3, 2: 0.8e-3}, now, int(1.2 * pol.HOLD_S / 0.8e-3))
    assert pol.current == 2
