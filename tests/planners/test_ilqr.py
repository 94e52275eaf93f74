"""Reduced iLQR against independent references: cvxpy on an LQ problem, and a plain numpy
iLQR iteration built on mujoco.mjd_transitionFD."""

from dataclasses import replace

import cvxpy as cp
import mujoco
import numpy as np
import pytest
import torch

from dopt import RolloutConfig, RolloutService, Scene
from dopt.costs import QuadraticCost
from planners.ilqr import ILQR, Derivatives, ILQRConfig, backward_pass
from tests.dopt.models import ACTUATED_ARENA, MIXED_JOINTS

# two damped point masses on slides, no gravity, no contacts: linear dynamics under Euler
LINEAR = """<mujoco><option timestep="0.02" gravity="0 0 0"/><worldbody>
  <body name="a"><joint name="ax" type="slide" axis="1 0 0" damping=".3"/>
    <geom size=".05" mass="1" contype="0" conaffinity="0"/></body>
  <body name="b" pos="0 1 0"><joint name="bx" type="slide" axis="1 0 0" damping=".1"/>
    <joint name="by" type="slide" axis="0 1 0"/><geom size=".05" mass="2" contype="0"
    conaffinity="0"/></body></worldbody>
  <actuator><motor joint="ax"/><motor joint="by" ctrllimited="false"/></actuator></mujoco>"""


def lq_reference(A, B, x0, xref, w, w_f, r, T):
    """Solve the LQ problem as a QP with cvxpy: the optimal (T, nu) controls."""
    n, nu = B.shape
    X, U = cp.Variable((T + 1, n)), cp.Variable((T, nu))
    cost = sum(cp.sum(cp.multiply(w, cp.square(X[t] - xref))) +
               cp.sum(cp.multiply(r, cp.square(U[t]))) for t in range(T))
    cost += cp.sum(cp.multiply(w_f, cp.square(X[T] - xref)))
    cons = [X[0] == x0] + [X[t + 1] == A @ X[t] + B @ U[t] for t in range(T)]
    cp.Problem(cp.Minimize(cost), cons).solve(solver=cp.CLARABEL)
    return U.value


def test_lq_converges_in_one_iteration_to_the_qp_solution():
    scene = Scene.from_xml(LINEAR)
    m = scene.model
    d = mujoco.MjData(m)
    d.qvel[:] = [0.3, -0.2, 0.1]
    mujoco.mj_forward(m, d)
    x0 = scene.state_of(d)
    T = 30
    q_ref = np.array([0.5, -0.2, 0.3])
    w = np.array([1.0, 0.5, 2.0, 0.1, 0.1, 0.1])
    w_f = 20 * w
    r = np.array([1e-2, 5e-3])
    cost = QuadraticCost(scene, q_ref, w, w_f, r)
    svc = RolloutService(scene)
    ilqr = ILQR(svc, cost, ILQRConfig(Derivatives("central"), mu_init=0.0,
                                      mu_min=0.0))
    step = ilqr.iterate(x0, np.zeros((T, m.nu)))
    assert step.alpha == 1.0

    A, B = np.zeros((6, 6)), np.zeros((6, 2))
    mujoco.mjd_transitionFD(m, d, 1e-6, True, A, B, None, None)
    xs = np.concatenate([d.qpos, d.qvel])
    U_ref = lq_reference(A, B, xs, np.concatenate([q_ref, np.zeros(3)]), w, w_f, r, T)
    np.testing.assert_allclose(step.controls, U_ref, rtol=1e-4, atol=1e-5 * np.abs(U_ref).max())
    # a second iteration cannot improve on the optimum
    again = ilqr.iterate(x0, step.controls)
    assert again.cost_after >= step.cost_after * (1 - 1e-7)


def numpy_ilqr_gains(scene, X, U, cost, eps, mu):
    """Independent full-state iLQR backward pass on mjd_transitionFD (numpy)."""
    m = scene.model
    d = mujoco.MjData(m)
    n = 2 * m.nv
    T = len(U)
    As, Bs = np.zeros((T, n, n)), np.zeros((T, n, m.nu))
    for t in range(T):
        mujoco.mj_setState(m, d, X[t], mujoco.mjtState.mjSTATE_INTEGRATION)
        mujoco.mjd_transitionFD(m, d, eps, False, As[t], Bs[t], None, None)
    e = cost.errors(X).numpy()
    w = np.vstack([np.tile(cost.w.numpy(), (T, 1)), cost.w_f.numpy()])
    r = cost.r.numpy()
    Vx, Vxx = 2 * w[T] * e[T], np.diag(2 * w[T])
    K, k = np.zeros((T, m.nu, n)), np.zeros((T, m.nu))
    for t in range(T - 1, -1, -1):
        A, B = As[t], Bs[t]
        Qx, Qu = 2 * w[t] * e[t] + A.T @ Vx, 2 * r * U[t] + B.T @ Vx
        Qxx = np.diag(2 * w[t]) + A.T @ Vxx @ A
        Quu = np.diag(2 * r) + B.T @ Vxx @ B
        Qux = B.T @ Vxx @ A
        Qi = np.linalg.inv(Quu + mu * np.eye(m.nu))
        k[t], K[t] = -Qi @ Qu, -Qi @ Qux
        Vx = Qx + K[t].T @ Quu @ k[t] + K[t].T @ Qu + Qux.T @ k[t]
        Vxx = Qxx + K[t].T @ Quu @ K[t] + K[t].T @ Qux + Qux.T @ K[t]
        Vxx = 0.5 * (Vxx + Vxx.T)
    return K, k


def mixed_problem():
    scene = Scene.from_xml(MIXED_JOINTS)
    m = scene.model
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    q_ref = m.qpos0.copy()
    q_ref[0] = 0.2
    box = m.jnt_qposadr[m.joint("box_free").id]
    q_ref[box] = 0.3
    w = np.zeros(2 * m.nv)
    w[[0, 5]] = [5.0, 10.0]
    w[m.nv:m.nv + 5] = 0.01
    cost = QuadraticCost(scene, q_ref, w, 10 * w, np.full(m.nu, 1e-3))
    return scene, scene.state_of(d), cost


def test_all_dofs_equal_plain_ilqr_on_transitionFD():
    scene, x0, cost = mixed_problem()
    T = 15
    rng = np.random.default_rng(0)
    U = rng.uniform(-0.3, 0.3, (T, scene.nu))
    svc = RolloutService(scene)
    ilqr = ILQR(svc, cost, ILQRConfig(Derivatives(fd_eps=1e-6), mu_init=0.1))
    step = ilqr.iterate(x0, U)
    X = svc.trajectory(x0, U).states
    K_ref, k_ref = numpy_ilqr_gains(scene, X, U, cost, 1e-6, 0.1)
    scale = np.abs(K_ref).max()
    np.testing.assert_allclose(step.K.numpy(), K_ref, atol=1e-6 * scale, rtol=0)
    np.testing.assert_allclose(step.k.numpy(), k_ref, atol=1e-6 * np.abs(k_ref).max(), rtol=0)
    assert step.accepted and step.cost_after < step.cost_before
    assert set(step.seconds) == {"derivatives", "backward", "forward"}


def test_reduced_gains_match_subset_problem_and_solve_descends():
    scene, x0, cost = mixed_problem()
    T = 15
    U = np.zeros((T, scene.nu))
    svc = RolloutService(scene)
    C = scene.dofs("robot", "object:box")
    step = ILQR(svc, cost).iterate(x0, U, C)
    assert step.K.shape == (T, scene.nu, 2 * len(C))
    # the same backward pass fed the rows/columns of the full derivatives gives the same gains
    X = svc.trajectory(x0, U).states
    full = svc.derivatives(X[:-1], None, ILQRConfig().derivatives.fd_config)
    idx = scene.tangent_indices(C)
    cd = cost.derivatives(X, U, C)
    F = np.concatenate([full.A[:, idx][:, :, idx], full.B[:, idx]], axis=2)
    K, k = backward_pass(torch.from_numpy(F), cd.lx, cd.lxx, cd.lu, cd.luu, 0.1)
    torch.testing.assert_close(step.K, K, rtol=0, atol=0)
    res = ILQR(svc, cost).solve(x0, U, C, max_iterations=6)
    assert res.costs[-1] < res.costs[0]
    assert all(b >= a for a, b in zip(res.costs[1:], res.costs[:-1], strict=True))


def test_line_search_scores_an_alpha_mujoco_raises_on_as_unstable(c_kernels):
    """models.ACTUATED_ARENA: the cost pulls the slider 30 cm onto the free box; the three
    largest alphas drive it there and MuJoCo raises (arena overflow). Those are flagged and
    scored +inf, the next alpha is accepted, and both routes agree."""
    scene = Scene.from_xml(ACTUATED_ARENA)
    m = scene.model
    d = mujoco.MjData(m)
    x0, T = scene.state_of(d), 45
    q_ref = d.qpos.copy()
    q_ref[7] = -0.3
    w = np.zeros(2 * m.nv)
    w[6] = 1.0
    cost = QuadraticCost(scene, q_ref, w, 100 * w, np.array([1e-4]))
    svc = RolloutService(scene, RolloutConfig(c_kernels=c_kernels))
    ilqr = ILQR(svc, cost)
    U = np.zeros((T, 1))
    step = ilqr.iterate(x0, U, [6])
    alphas = np.asarray(ILQRConfig().alphas)
    assert step.accepted and step.cost_after < step.cost_before
    assert step.n_unstable == 3 and step.alpha == alphas[3]
    X = svc.trajectory(x0, U).states[:-1]
    ff = U[None] + alphas[:4, None, None] * step.k.numpy()[None]
    trial = svc.rollout_feedback(x0, ff, X, step.K.numpy(), [6])
    assert all(r.startswith("MuJoCo error") for r in trial.stability.reason[:3])
    assert not trial.stability.unstable[3]
    np.testing.assert_array_equal(trial.states[3], step.states)


class _FlaggedNominal:
    """A rollout service whose nominal trajectories (``trajectory``) the verdict flags, as a
    nominal that broke a stability bound in its last step is; every other call is the real
    service's."""

    def __init__(self, svc):
        self._svc, self.scene = svc, svc.scene

    def __getattr__(self, name):
        return getattr(self._svc, name)

    def trajectory(self, x0, U):
        t = self._svc.trajectory(x0, U)
        flagged = replace(t.stability, unstable=np.array([True]), step=np.array([len(U) - 1]),
                          reason=("flagged by the test",))
        return replace(t, stability=flagged)


class _CheapNominal(QuadraticCost):
    """The LINEAR problem's cost, except that the first trajectory scored (the nominal) reads
    1e3 lower, as the cost of a simulation that broke down can (a blown-up state may sit on
    the goal)."""

    calls = 0

    def total(self, X, U):
        out = super().total(X, U)
        self.calls += 1
        return out - 1e3 if self.calls == 1 else out


@pytest.mark.parametrize("flagged", [False, True])
def test_a_nominal_the_verdict_flags_sets_no_bar_for_the_line_search(flagged):
    """From the same nominal, scored below every candidate: judged sound, no alpha beats it and
    the step is rejected; flagged, its cost is no bar and the cheapest stable alpha is taken
    (the one plain iLQR takes when the nominal reads its true cost)."""
    scene = Scene.from_xml(LINEAR)
    m = scene.model
    x0, T = scene.state_of(mujoco.MjData(m)), 20
    w = np.array([1.0, 0.5, 2.0, 0.1, 0.1, 0.1])
    args = (scene, np.array([0.5, -0.2, 0.3]), w, 20 * w, np.array([1e-2, 5e-3]))
    svc = RolloutService(scene)
    U = np.zeros((T, m.nu))
    true = ILQR(svc, QuadraticCost(*args)).iterate(x0, U)
    step = ILQR(_FlaggedNominal(svc) if flagged else svc, _CheapNominal(*args)).iterate(x0, U)
    assert step.nominal_unstable is flagged
    assert true.accepted and not true.nominal_unstable
    if flagged:
        assert step.accepted and step.alpha == true.alpha
        assert step.cost_after == true.cost_after > step.cost_before
        np.testing.assert_array_equal(step.controls, true.controls)
    else:
        assert not step.accepted and step.cost_after == step.cost_before
        np.testing.assert_array_equal(step.controls, U)


def test_bad_config():
    with pytest.raises(ValueError):
        ILQRConfig(alphas=(0.0,))
    with pytest.raises(ValueError):
        ILQRConfig(mu_init=100.0)
