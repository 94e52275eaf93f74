"""Costs: values against hand computation, derivatives against finite differences."""

import mujoco
import numpy as np
import pytest
import torch

from dopt import RolloutService, Scene
from dopt.costs import EEDistanceTerm, QuadraticCost

ARM = """<mujoco><option timestep="0.01"/><worldbody>
  <body name="l1"><joint name="j1" type="hinge" axis="0 0 1"/>
    <geom type="capsule" fromto="0 0 0 .3 0 0" size=".02"/>
    <body name="l2" pos=".3 0 0"><joint name="j2" type="hinge" axis="0 0 1"/>
      <geom type="capsule" fromto="0 0 0 .2 0 0" size=".02"/><site name="ee" pos=".2 0 0"/>
    </body></body>
  <body name="obj" pos=".4 .2 0"><freejoint/><geom type="box" size=".03 .03 .03"/></body>
</worldbody><actuator><motor joint="j1"/><motor joint="j2"/></actuator></mujoco>"""


def planar_fk(q):
    """(B, 2) -> (B, 3) tip of the 2-link arm above."""
    a, b = q[:, 0], q[:, 0] + q[:, 1]
    x = 0.3 * torch.cos(a) + 0.2 * torch.cos(b)
    y = 0.3 * torch.sin(a) + 0.2 * torch.sin(b)
    return torch.stack([x, y, torch.zeros_like(x)], dim=1)


@pytest.fixture
def problem():
    scene = Scene.from_xml(ARM)
    m = scene.model
    d = mujoco.MjData(m)
    d.qpos[:2] = [0.3, -0.5]
    mujoco.mj_forward(m, d)
    np.testing.assert_allclose(planar_fk(torch.tensor(d.qpos[None, :2])).numpy()[0],
                               d.site("ee").xpos, atol=1e-12)
    obj = scene.dofs("object:obj")
    term = EEDistanceTerm(scene, planar_fk, [0, 1], obj[:3], np.eye(3), [0.0, 0.0, 0.0],
                          axes=(0, 1), weight=2.0, terminal_weight=5.0)
    q_ref = m.qpos0.copy()
    q_ref[2:5] = [0.5, 0.1, 0.03]
    w = np.zeros(2 * m.nv)
    w[2:4] = 3.0
    w[m.nv:m.nv + 2] = 0.1
    cost = QuadraticCost(scene, q_ref, w, 4 * w, [0.01, 0.02], terms=[term])
    rng = np.random.default_rng(0)
    U = rng.uniform(-0.2, 0.2, (6, 2))
    X = RolloutService(scene).trajectory(scene.state_of(d), U).states
    return scene, cost, term, X, U


def test_total_by_hand(problem):
    scene, cost, term, X, U = problem
    lay = scene.layout
    want = 0.0
    for t in range(len(X)):
        q, v = X[t, lay["qpos"]], X[t, lay["qvel"]]
        e = np.concatenate([q[2:4] - [0.5, 0.1], v[:2]])
        w = np.array([3.0, 3.0, 0.1, 0.1]) * (4 if t == len(U) else 1)
        want += (w * e ** 2).sum()
        ee = planar_fk(torch.tensor(q[None, :2])).numpy()[0]
        want += (5.0 if t == len(U) else 2.0) * ((ee[:2] - q[2:4]) ** 2).sum()
        if t < len(U):
            want += 0.01 * U[t, 0] ** 2 + 0.02 * U[t, 1] ** 2
    assert float(cost.total(X, U)) == pytest.approx(want, rel=1e-12)
    assert cost.costed_dofs.tolist() == [0, 1, 2, 3, 4]


def test_gradient_matches_finite_differences(problem):
    scene, cost, term, X, U = problem
    C = np.array([0, 1, 2, 3, 6])            # arm, object x y, and a rotational DoF
    D = cost.derivatives(X, U, C)
    assert D.lx.shape == (7, 10) and D.lxx.shape == (7, 10, 10)
    lay, eps = scene.layout, 1e-6

    def row_cost(t, dof, delta):             # the total with state t moved by delta along dof
        Y = X.copy()
        q = Y[t, lay["qpos"]]
        dv = np.zeros(scene.nv)
        dv[dof] = delta
        mujoco.mj_integratePos(scene.model, q, dv, 1.0)
        Y[t, lay["qpos"]] = q
        return float(cost.total(Y, U))

    for t in (0, 3, 6):
        for i, dof in enumerate(C):
            fd = (row_cost(t, dof, eps) - row_cost(t, dof, -eps)) / (2 * eps)
            assert D.lx[t, i].item() == pytest.approx(fd, rel=1e-5, abs=1e-7)
    # Gauss-Newton Hessian of the term: symmetric, positive semi-definite
    assert torch.allclose(D.lxx, D.lxx.transpose(1, 2))
    assert torch.linalg.eigvalsh(D.lxx).min() > -1e-12


def test_bad_terms(problem):
    scene, cost, term, X, U = problem
    with pytest.raises(ValueError, match="rotational"):
        EEDistanceTerm(scene, planar_fk, [0, 1], [6], np.ones((3, 1)), np.zeros(3))
    with pytest.raises(ValueError, match="overlap"):
        EEDistanceTerm(scene, planar_fk, [0, 1], [1], np.ones((3, 1)), np.zeros(3))
    with pytest.raises(ValueError, match="w must have shape"):
        QuadraticCost(scene, scene.model.qpos0, np.ones(3), np.ones(3), np.ones(2))


def test_a_distance_to_keep_is_the_norm_less_the_distance_and_its_gradient_is_exact(problem):
    """distance r: the residual is |ee - target| - r (by hand), and the cost's gradient with
    that term matches central differences of the total."""
    scene, _, _, X, U = problem
    obj = scene.dofs("object:obj")
    term = EEDistanceTerm(scene, planar_fk, [0, 1], obj[:3], np.eye(3), [0.0, 0.0, 0.0],
                          weight=0.0, terminal_weight=7.0, distance=0.05)
    lay = scene.layout
    q = X[-1, lay["qpos"]]
    ee = planar_fk(torch.tensor(q[None, :2])).numpy()[0]
    want = np.linalg.norm(ee - q[2:5]) - 0.05
    assert term.residual(torch.tensor(q[None])).numpy()[0, 0] == pytest.approx(want, rel=1e-12)
    cost = QuadraticCost(scene, scene.model.qpos0, np.zeros(2 * scene.nv),
                         np.zeros(2 * scene.nv), [0.0, 0.0], terms=[term])
    assert float(cost.total(X, U)) == pytest.approx(7.0 * want ** 2, rel=1e-12)
    C = np.array([0, 1, 2, 3, 4])
    D = cost.derivatives(X, U, C)
    eps = 1e-6
    for i, dof in enumerate(C):
        Y = [X.copy(), X.copy()]
        for sign, Yk in zip((1, -1), Y, strict=True):
            qk = Yk[-1, lay["qpos"]]
            dv = np.zeros(scene.nv)
            dv[dof] = sign * eps
            mujoco.mj_integratePos(scene.model, qk, dv, 1.0)
            Yk[-1, lay["qpos"]] = qk
        fd = (float(cost.total(Y[0], U)) - float(cost.total(Y[1], U))) / (2 * eps)
        assert D.lx[-1, i].item() == pytest.approx(fd, rel=1e-6, abs=1e-9)
    assert not D.lx[:-1].any()                     # running weight 0: only the last row
    with pytest.raises(ValueError, match="distance"):
        EEDistanceTerm(scene, planar_fk, [0, 1], obj[:3], np.eye(3), np.zeros(3), distance=-1)
