"""The vectorised env gives exactly the single env's trajectories for the same actions."""

import gymnasium as gym
import numpy as np
import pytest

import contour_env  # noqa: F401
from contour_env import ENV_ID


def _tight_guard_venv(n):
    # hsm2-circle-I with a 0.1 mm crash guard: a full-force action ends an episode quickly
    return gym.make_vec(
        ENV_ID,
        num_envs=n,
        vectorization_mode="vector_entry_point",
        case="hsm2-circle-I",
        abort_contour_error_m=1e-4,
    )


@pytest.mark.parametrize(
    "kw",
    [
        # a tracking guard the small random actions cannot reach: no episode ends in the window
        dict(case="hsm2-circle-II", abort_tracking_error_m=1.0),
        dict(case="jee-circle3d", abort_tracking_error_m=1.0),
        dict(case="sharp-corner", measurement_noise_std_m=1e-6, disturbance_force_N=3.0),
    ],
)
def test_vector_env_equals_single_envs(kw):
    n, steps, seed = 4, 400, 11
    rng = np.random.default_rng(5)
    venv = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point", **kw)
    dim = venv.single_action_space.shape[0]
    actions = rng.uniform(-0.05, 0.05, (steps, n, dim)).astype(np.float32)
    vobs, vinfo = venv.reset(seed=seed)
    singles = [gym.make(ENV_ID, **kw) for _ in range(n)]
    sobs = [e.reset(seed=seed + i)[0] for i, e in enumerate(singles)]
    np.testing.assert_array_equal(vobs, np.stack(sobs))
    for t in range(steps):
        vobs, vr, vterm, vtrunc, vinfo = venv.step(actions[t])
        for i, e in enumerate(singles):
            obs, r, term, trunc, info = e.step(actions[t, i])
            assert np.array_equal(vobs[i], obs)
            assert vr[i] == r
            assert vterm[i] == term and vtrunc[i] == trunc
            assert np.array_equal(vinfo["position"][i], info["position"])
            assert vinfo["contour_error"][i] == info["contour_error"]
            for key in ("measured_position", "velocity", "reference", "force", "saturated"):
                assert np.array_equal(vinfo[key][i], info[key]), key
            assert vinfo["time"][i] == info["time"] and vinfo["step"][i] == info["step"]
            np.testing.assert_array_equal(
                vinfo["contour_error_estimate"][i], info["contour_error_estimate"]
            )
            np.testing.assert_array_equal(vinfo["tracking_error"][i], info["tracking_error"])


def test_step_info_equals_the_state_after_every_step_including_autoresets():
    # the kernel writes the batched info while stepping; envs reset after the step get theirs
    # from the reset state: both must equal a fresh readout of the state
    venv = _tight_guard_venv(3)
    venv.reset(seed=2)
    actions = np.array([[1.0, 1.0], [0.0, 0.0], [-0.3, 0.2]], dtype=np.float32)
    resets = 0
    for _ in range(400):
        _, _, term, trunc, info = venv.step(actions)
        expected = venv.core.batch_info()
        assert set(info) == set(expected)
        for key, value in expected.items():
            np.testing.assert_array_equal(info[key], value, err_msg=key)
        resets += int(info["step"][0] == 0)
    assert resets >= 2  # env 0 hits the crash guard and is reset, repeatedly


def test_vector_env_autoresets_next_step():
    venv = _tight_guard_venv(2)
    venv.reset(seed=0)
    actions = np.array([[1.0, 1.0], [0.0, 0.0]], dtype=np.float32)
    for _ in range(2000):
        _, _, term, trunc, info = venv.step(actions)
        if term[0]:
            break
    assert term[0] and info["termination_reason"][0] == "contour_error_limit"
    obs, r, term, trunc, info = venv.step(actions)
    assert r[0] == 0.0 and not term[0] and info["step"][0] == 0


def test_vector_env_rejects_bad_actions():
    venv = gym.make_vec(
        ENV_ID, num_envs=3, vectorization_mode="vector_entry_point", case="hsm2-circle-I"
    )
    venv.reset(seed=0)
    a = np.zeros((3, 2))
    a[1, 0] = np.nan
    with pytest.raises(ValueError, match=r"action: must be finite.*env 1"):
        venv.step(a)
    with pytest.raises(ValueError, match="actions: expected shape"):
        venv.step(np.zeros((2, 2)))


def test_core_batch_calls_reject_bad_indices_seeds_and_info_arrays():
    from contour_env.env.factory import make_core

    core = make_core("hsm2-circle-I", n_envs=3)
    with pytest.raises(ValueError, match=r"envs: indices must be in \[0, 3\)"):
        core.reset_envs([0, 3], [1, 2])
    with pytest.raises(ValueError, match="noise_seeds: one per env"):
        core.reset_envs([0, 1], [1])
    good = core.new_info_arrays()
    with pytest.raises(ValueError, match="info_arrays"):
        core.step(np.zeros((3, 2)), np.ones(3, bool), good[:3])
    wrong = (np.empty((7, 2, 2)),) + good[1:]
    with pytest.raises(ValueError, match="info_arrays"):
        core.fill_info(wrong, [0])
    with pytest.raises(ValueError, match="envs: indices"):
        core.fill_info(good, [-1])
    core.reset_envs([0, 1, 2], [5, 6, 7])
    core.step(np.zeros((3, 2)), np.ones(3, bool), good)
    np.testing.assert_array_equal(core.info_dict(good)["position"], core.batch_info()["position"])


def test_reset_seeds_as_an_integer_array_equal_the_same_seeds_as_a_list():
    # the autoreset hands the draws over as an int64 array (no Python list); any integers are
    # taken mod 2**64 either way, negative ones included
    from contour_env.env.factory import make_core

    seeds = [5, 2**62 + 3, -7]
    by_list = make_core("hsm2-circle-I", n_envs=3)
    by_list.reset_envs([0, 1, 2], seeds)
    for arr in (np.array(seeds, dtype=np.int64), np.array(seeds[:2] + [2**64 - 7], np.uint64)):
        core = make_core("hsm2-circle-I", n_envs=3)
        core.reset_envs([0, 1, 2], arr)
        np.testing.assert_array_equal(core.seed, by_list.seed)
    assert by_list.seed[2] == 2**64 - 7
    with pytest.raises(ValueError, match=r"noise_seeds: one per env \(3\), got 2"):
        core.reset_envs([0, 1, 2], np.array([1, 2], dtype=np.int64))


def test_returned_arrays_are_never_written_again():
    # the vector env hands out the kernel's output arrays without copying them: later steps,
    # autoresets and reset() must leave every array it returned as it was
    venv = _tight_guard_venv(2)
    kept = [venv.reset(seed=3)[0]]
    copies = [kept[0].copy()]
    actions = np.array([[1.0, 1.0], [0.0, 0.0]], dtype=np.float32)
    ended = 0
    for _ in range(300):
        out = venv.step(actions)
        kept.extend(out[:4])
        copies.extend(x.copy() for x in out[:4])
        ended += int(out[2][0])
    kept.append(venv.reset(seed=4)[0])
    copies.append(kept[-1].copy())
    for _ in range(50):
        venv.step(actions)
    venv.reset(seed=5)
    assert ended >= 1  # env 0 hit the crash guard, so autoresets happened in between
    for k, c in zip(kept, copies, strict=True):
        np.testing.assert_array_equal(k, c)


def test_core_step_fresh_outputs_equals_stepping_in_place():
    from contour_env.env.factory import make_core

    rng = np.random.default_rng(8)
    a, b = (make_core("hsm2-circle-II", n_envs=4) for _ in range(2))
    for core in (a, b):
        core.reset_envs(range(4), [1, 2, 3, 4])
    for t in range(60):
        action = rng.uniform(-0.2, 0.2, (4, 2))
        # every env, then a partial mask: inactive rows must be carried into the new arrays
        active = a.all_active if t % 3 else np.array([True, False, True, False])
        old_obs = b.obs.copy()
        held = b.obs
        n_a = a.step(action, active if active is a.all_active else active.copy())
        n_b = b.step(action, b.all_active if active is a.all_active else active, None, True)
        assert n_a == n_b == int(np.count_nonzero(a.terminated | a.truncated))
        assert b.obs is not held
        np.testing.assert_array_equal(held, old_obs)  # the replaced array is left alone
        for key in ("obs", "reward", "terminated", "truncated", "z"):
            np.testing.assert_array_equal(getattr(a, key), getattr(b, key), err_msg=key)


def test_termination_reason_kept_for_an_env_left_out_of_a_step():
    # the "no env ended" shortcut of the reasons applies only when every env was stepped
    from contour_env.env.factory import make_core

    core = make_core("hsm2-circle-I", n_envs=3, abort_contour_error_m=1e-4)
    core.reset_envs(range(3), [0, 1, 2])
    push = np.array([[1.0, 1.0], [0.0, 0.0], [0.0, 0.0]])
    for _ in range(2000):
        core.step(push, core.all_active)
        if core.terminated[0]:
            break
    assert core.terminated[0]
    info = core.new_info_arrays()
    core.step(np.zeros((3, 2)), np.array([False, True, True]), info)
    reasons = core.info_dict(info)["termination_reason"]
    assert reasons[0] == "contour_error_limit" and reasons[1] == "" and reasons[2] == ""


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_vector_env_refuses_a_nonfinite_action_of_an_env_being_autoreset(bad):
    # issue 36 item 8: the step after env 0's episode ended resets env 0 and ignores its
    # action (NEXT_STEP autoreset); a NaN/inf action there is refused all the same, as it is
    # at any other step, and the refused step changes nothing
    venv = _tight_guard_venv(2)
    venv.reset(seed=0)
    actions = np.array([[1.0, 1.0], [0.0, 0.0]])
    for _ in range(2000):
        _, _, term, trunc, info = venv.step(actions)
        if term[0]:
            break
    assert term[0] and not (term[1] or trunc[1])
    step_1 = info["step"][1]
    a = actions.copy()
    a[0, 1] = bad
    with pytest.raises(ValueError, match=r"action: must be finite, got \[1\.0, .*\] \(env 0\)"):
        venv.step(a)
    # still due for its reset: the next (finite) step resets env 0 and steps env 1 once
    _, r, term, _, info = venv.step(actions)
    assert r[0] == 0.0 and not term[0] and info["step"][0] == 0
    assert info["step"][1] == step_1 + 1


def test_five_axis_vector_env_refuses_a_nonfinite_action_of_an_env_being_autoreset():
    venv = gym.make_vec(
        ENV_ID,
        num_envs=2,
        vectorization_mode="vector_entry_point",
        case="five-axis-line",
        abort_contour_error_m=1e-5,
    )
    venv.reset(seed=0)
    actions = np.zeros((2, 5))
    actions[0] = 1.0
    for _ in range(5000):
        _, _, term, trunc, _ = venv.step(actions)
        if term[0] or trunc[0]:
            break
    assert term[0] or trunc[0]
    a = actions.copy()
    a[0, 3] = np.nan
    with pytest.raises(ValueError, match=r"action: must be finite.*\(env 0\)"):
        venv.step(a)
