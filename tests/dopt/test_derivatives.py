"""Reduced FD derivatives against MuJoCo's own mjd_transitionFD."""

import mujoco
import numpy as np
import pytest

from dopt.errors import UnstableRolloutError
from dopt.rollout import FDConfig, RolloutConfig, RolloutService
from tests.dopt.models import TINY_ARENA

# |A_ours - A_mujoco|: both are FD quotients of identical perturbed steps; they differ only in
# how the quaternion difference of the next states is rounded (1e-16 / eps)
TOL = 1e-8


def service(scene, c_kernels, threads=0):
    svc = RolloutService(scene, RolloutConfig(threads=threads, c_kernels=c_kernels))
    assert svc.uses_c_kernels == c_kernels
    return svc


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
def test_all_dofs_equal_transitionFD(scene, trajectory, centered, c_kernels):
    states = trajectory.states[:-1]
    fd = FDConfig(eps=1e-6, centered=centered)
    got = service(scene, c_kernels).derivatives(states, None, fd)
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
def test_subset_equals_rows_and_columns_of_full(scene, trajectory, centered, dofs, c_kernels):
    states = trajectory.states[:-1]
    fd = FDConfig(eps=1e-6, centered=centered)
    svc = service(scene, c_kernels)
    full = svc.derivatives(states, None, fd)
    sub = svc.derivatives(states, dofs, fd)
    idx = scene.tangent_indices(sub.dofs)
    assert sub.A.shape == (len(states), len(idx), len(idx))
    np.testing.assert_array_equal(sub.A, full.A[:, idx][:, :, idx])
    np.testing.assert_array_equal(sub.B, full.B[:, idx])


def test_batch_of_one_timestep_and_two_threads(scene, trajectory, c_kernels):
    states = trajectory.states[3:4]
    fd = FDConfig(eps=1e-6)
    one = service(scene, c_kernels, threads=1).derivatives(states, "robot", fd)
    two = service(scene, c_kernels, threads=2).derivatives(states, "robot", fd)
    np.testing.assert_array_equal(one.A, two.A)
    np.testing.assert_array_equal(one.B, two.B)
    A, B = reference(scene, states, 1e-6, False)
    idx = scene.tangent_indices("robot")
    np.testing.assert_allclose(one.A[0], A[0][idx][:, idx], atol=TOL, rtol=0)


@pytest.mark.parametrize("task", ["clutter", "soft"])
def test_routes_agree_on_a_pushing_task(task):
    """Clutter (a Panda among cylinders, ~25 contacts) and soft (a 3D flex under the discrete
    integrator): the skip-stage C loop reuses the nominal state's position and velocity
    stages; the Batch route recomputes them for every perturbation."""
    from dopt import kernels
    from dopt.scene import Scene
    from dopt.tasks import get_task
    if kernels.load() is None:
        pytest.skip(f"C kernels not built: {kernels.load_error()}")
    tm = get_task(task)(np.random.default_rng(0))
    scene = Scene(tm.model)
    u = np.random.default_rng(1).normal(0, 20, (8, scene.nu))
    states = service(scene, False).trajectory(tm.initial_state, u).states[:-1]
    C = np.r_[tm.robot_dofs, 7 + np.arange(12)]
    for centered in (False, True):
        fd = FDConfig(eps=1e-3, centered=centered)
        a = service(scene, True, threads=2).derivatives(states, C, fd)
        b = service(scene, False, threads=2).derivatives(states, C, fd)
        assert np.abs(b.A).max() > 1
        np.testing.assert_allclose(a.A, b.A, rtol=0, atol=1e-9)
        np.testing.assert_allclose(a.B, b.B, rtol=0, atol=1e-9)


def test_unstable_derivatives_name_the_timestep(scene, trajectory, c_kernels):
    states = trajectory.states[:-1].copy()
    states[7, scene.layout["qvel"].start + 2] = 1e200   # the hinge spins absurdly at t = 7
    with pytest.raises(UnstableRolloutError, match="derivatives t=7"):
        service(scene, c_kernels).derivatives(states, "robot")


# two boxes, one on the floor: their contacts overflow a 3 kB arena (mju_error), in the air
# there is no contact and the arena suffices
def test_mujoco_error_raises_and_the_service_recovers(c_kernels):
    """mju_error (here: arena overflow) inside a call is a RolloutError, not a process exit,
    and the same service serves the next call."""
    from dopt.errors import RolloutError
    from dopt.scene import Scene
    scene = Scene.from_xml(TINY_ARENA)
    d = mujoco.MjData(scene.model)
    on_floor = np.repeat(scene.state_of(d)[None], 3, axis=0)
    svc = service(scene, c_kernels, threads=2)
    with pytest.raises(RolloutError, match="out of memory"):
        svc.derivatives(on_floor)
    d.qpos[2], d.qpos[9] = 1.0, 2.0                    # both boxes high in the air, apart
    in_air = np.repeat(scene.state_of(d)[None], 3, axis=0)
    got = svc.derivatives(in_air, None, FDConfig(eps=1e-6))
    roomy = Scene.from_xml(TINY_ARENA.replace("3K", "1M"))   # transitionFD needs more arena
    np.testing.assert_allclose(got.A, reference(roomy, in_air, 1e-6, False)[0], atol=TOL, rtol=0)


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


def test_a_step_that_cannot_move_the_state_is_refused(scene, trajectory):
    """eps 1e-20 would give B == 0 exactly (x + eps == x in double precision): FDConfig
    refuses it; an eps that is fine near the origin is refused for states 1e8 away from it,
    and accepted again once it can move them."""
    with pytest.raises(ValueError, match="FDConfig.eps must be >="):
        FDConfig(eps=1e-20)
    states = trajectory.states[:-1].copy()
    states[:, scene.layout["qpos"].start] = 1e8          # the slide joint 1e8 m out
    svc = RolloutService(scene)
    with pytest.raises(ValueError, match="too small for states of magnitude 1e"):
        svc.derivatives(states, "robot", FDConfig(eps=1e-6))
    d = svc.derivatives(states, "robot", FDConfig(eps=1e-3))
    assert np.isfinite(d.F).all()


def test_derivatives_judge_their_nominal_states(scene, trajectory):
    """A nominal row with the box at 1e3 m/s (finite, no MuJoCo warning, so A and B
    come out finite) is flagged by the same speed bound a rollout applies, at its row; the
    unchanged trajectory is not flagged."""
    svc = RolloutService(scene)
    clean = svc.derivatives(trajectory.states[:-1], "robot")
    assert clean.stability is not None and not clean.stability.unstable[0]
    states = trajectory.states[:-1].copy()
    box = scene.model.joint("box_free").dofadr[0]
    states[12, scene.layout["qvel"].start + box] = 1e3
    d = svc.derivatives(states, "robot")
    assert np.isfinite(d.F).all()
    assert d.stability.unstable[0] and d.stability.step[0] == 12
    assert "speed" in d.stability.reason[0]
    rollout = svc.rollout(states[12], np.zeros((1, scene.nu)))
    assert rollout.stability.unstable[0]                 # the same state, the same verdict
