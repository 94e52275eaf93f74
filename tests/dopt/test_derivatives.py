"""Reduced FD derivatives against MuJoCo's own mjd_transitionFD."""

import mujoco
import numpy as np
import pytest

from dopt.rollout import FDConfig, RolloutService

# |A_ours - A_mujoco|: both are FD quotients of identical perturbed steps; they differ only in
# how the quaternion difference of the next states is rounded (1e-16 / eps)
TOL = 1e-8


@pytest.fixture(scope="module")
def trajectory(scene):
    m = scene.model
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    rng = np.random.default_rng(0)
    T = 25
    u = rng.uniform(-0.8, 0.8, (T, m.nu))
    u[:, 1] = 1.0            # hinge motor sits at its upper limit: backward difference only
    u[10:, 0] = 5.0 - 5e-7   # slide motor within eps of its limit: forward nudge not allowed
    return RolloutService(scene).trajectory(scene.state_of(d), u)


def reference(scene, states, eps, centered):
    m = scene.model
    d = mujoco.MjData(m)
    n = 2 * m.nv + m.na
    out_a, out_b = [], []
    for row in states:
        mujoco.mj_setState(m, d, row, mujoco.mjtState.mjSTATE_INTEGRATION)
        A, B = np.zeros((n, n)), np.zeros((n, m.nu))
        mujoco.mjd_transitionFD(m, d, eps, centered, A, B, None, None)
        out_a.append(A)
        out_b.append(B)
    return np.array(out_a), np.array(out_b)


@pytest.mark.parametrize("centered", [False, True])
def test_all_dofs_equal_transitionFD(scene, trajectory, centered):
    states = trajectory.states[:-1]
    fd = FDConfig(eps=1e-6, centered=centered)
    got = RolloutService(scene).derivatives(states, None, fd)
    A, B = reference(scene, states, fd.eps, centered)
    assert got.A.shape == A.shape and got.B.shape == B.shape
    assert np.abs(A).max() > 0.5 and np.abs(B).max() > 1e-3  # non-trivial dynamics
    np.testing.assert_allclose(got.A, A, rtol=0, atol=TOL)
    np.testing.assert_allclose(got.B, B, rtol=0, atol=TOL)
    # at the limit a naive forward nudge is clamped away and gives a zero column; the inward
    # nudge sees the motor
    assert np.all(np.abs(B[:, :, 1]).max(axis=1) > 1e-4)
    assert np.all(np.abs(got.B[10:, :, 0]).max(axis=1) > 1e-4)


@pytest.mark.parametrize("centered", [False, True])
@pytest.mark.parametrize("dofs", [[1], ["object:box"], ["robot", "object:ball_obj"], [0, 4, 9]])
def test_subset_equals_rows_and_columns_of_full(scene, trajectory, centered, dofs):
    states = trajectory.states[:-1]
    fd = FDConfig(eps=1e-6, centered=centered)
    svc = RolloutService(scene)
    full = svc.derivatives(states, None, fd)
    sub = svc.derivatives(states, dofs, fd)
    idx = scene.tangent_indices(sub.dofs)
    assert sub.A.shape == (len(states), len(idx), len(idx))
    np.testing.assert_array_equal(sub.A, full.A[:, idx][:, :, idx])
    np.testing.assert_array_equal(sub.B, full.B[:, idx])


def test_batch_of_one_timestep_and_two_threads(scene, trajectory):
    from dopt.rollout import RolloutConfig
    states = trajectory.states[3:4]
    one = RolloutService(scene, RolloutConfig(threads=1)).derivatives(states, "robot")
    two = RolloutService(scene, RolloutConfig(threads=2)).derivatives(states, "robot")
    np.testing.assert_array_equal(one.A, two.A)
    np.testing.assert_array_equal(one.B, two.B)
    A, B = reference(scene, states, 1e-6, False)
    idx = scene.tangent_indices("robot")
    np.testing.assert_allclose(one.A[0], A[0][idx][:, idx], atol=TOL, rtol=0)


def test_bad_inputs(scene, trajectory):
    svc = RolloutService(scene)
    states = trajectory.states[:-1]
    with pytest.raises(ValueError, match="unknown DoF group"):
        svc.derivatives(states, "object:nope")
    with pytest.raises(ValueError, match="out of range"):
        svc.derivatives(states, [0, scene.nv])
    with pytest.raises(ValueError, match="shape"):
        svc.derivatives(states[:, :-1])
    with pytest.raises(ValueError, match="shape"):
        svc.derivatives(states[0])
    bad = states.copy()
    bad[2, 5] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        svc.derivatives(bad)
    with pytest.raises(ValueError, match="eps"):
        FDConfig(eps=0.0)
    with pytest.raises(TypeError, match="integers"):
        svc.derivatives(states, [0.5, 1.0])
