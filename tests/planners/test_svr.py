"""DoF importance from K and the selection methods."""

import mujoco
import numpy as np
import pytest
import torch

from dopt import RolloutService, Scene
from dopt.costs import QuadraticCost
from planners.ilqr import ILQR
from planners.svr import DofSelector, SelectionConfig, importance_sum, importance_svd

# the actuated slider pushes a puck along x (contact); a second puck sits far away on its own
# rail and cannot be reached: it cannot influence the cost
PUSH = """<mujoco><option timestep="0.01" gravity="0 0 0"/><worldbody>
  <body name="pusher"><joint name="px" type="slide" axis="1 0 0" damping="1"/>
    <geom type="sphere" size=".05" mass="1"/></body>
  <body name="puck" pos=".11 0 0"><joint name="kx" type="slide" axis="1 0 0" damping=".5"/>
    <geom type="sphere" size=".05" mass=".5"/></body>
  <body name="far" pos="0 2 0"><joint name="fx" type="slide" axis="1 0 0" damping=".5"/>
    <geom type="sphere" size=".05" mass=".5"/></body>
</worldbody><actuator><motor joint="px" ctrlrange="-20 20" ctrllimited="true"/></actuator>
</mujoco>"""


@pytest.fixture(scope="module")
def push_gains():
    scene = Scene.from_xml(PUSH)
    m = scene.model
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    x0 = scene.state_of(d)
    q_ref = np.array([0.0, 0.4, 0.0])   # the puck should reach x = 0.4
    w = np.zeros(6)
    w[1] = 10.0
    cost = QuadraticCost(scene, q_ref, w, 100 * w, np.full(1, 1e-3))
    U = np.full((40, 1), 3.0)           # push forward: the pusher meets the puck
    step = ILQR(RolloutService(scene), cost).iterate(x0, U)
    return scene, step


@pytest.mark.parametrize("importance", [importance_sum, importance_svd])
def test_importance_keeps_the_driving_dof_and_drops_the_unreachable_one(push_gains,
                                                                         importance):
    scene, step = push_gains
    imp = importance(step.K).numpy()
    px, kx, fx = 0, 1, 2
    assert imp[kx] > 1e-3 and imp[px] > 1e-3
    assert imp[fx] == 0.0                  # no path from the far puck to the controls
    sel = DofSelector(scene.nv, scene.dofs("robot"), [], SelectionConfig("svr-sum", rho=1e-6,
                                                                        theta=0),
                      np.random.default_rng(0))
    kept = sel.after(step.K, np.arange(scene.nv))
    assert kept.tolist() == [px, kx]


def test_importance_formulas_on_a_hand_made_K():
    K = torch.zeros(2, 2, 6, dtype=torch.float64)   # T=2, nu=2, c=3
    K[0, 0, 0], K[0, 1, 3] = 1.0, -2.0              # DoF 0: position and velocity columns
    K[1, 1, 1] = 4.0                                # DoF 1
    np.testing.assert_allclose(importance_sum(K).numpy(), [1.5, 2.0, 0.0])
    # rank-1 K_t: sigma * |v| sums; K_0 has singular values sqrt(1), 2 with v on cols 0 and 3
    np.testing.assert_allclose(importance_svd(K, g=3).numpy(), [1.5, 2.0, 0.0], atol=1e-12)


def test_selection_methods():
    rng = np.random.default_rng(1)
    robot, nv = np.arange(3), 12
    base = DofSelector(nv, robot, [5], SelectionConfig("baseline"), rng)
    assert base.before().tolist() == list(range(nv))
    naive = DofSelector(nv, robot, [5, 7], SelectionConfig("naive"), rng)
    assert naive.before().tolist() == [0, 1, 2, 5, 7]
    rand = DofSelector(nv, robot, [], SelectionConfig("rand", theta=4), rng)
    a, b = rand.before().copy(), rand.before().copy()
    assert len(a) == len(b) == 7 and set(robot) <= set(a)
    svr = DofSelector(nv, robot, [], SelectionConfig("svr-sum", rho=0.5, theta=2), rng)
    C = svr.before()
    assert len(C) == nv                     # starts from all DoFs
    K = torch.zeros(5, 2, 2 * nv, dtype=torch.float64)
    K[:, :, 6] = 1.0                        # only DoF 6 matters
    assert svr.after(K, C).tolist() == [0, 1, 2, 6]   # robot kept regardless
    assert len(svr.before()) == 6           # theta = 2 re-added at random
    same = DofSelector(nv, robot, [], SelectionConfig("rand", theta=4),
                       np.random.default_rng(1))
    assert same.before().tolist() == a.tolist()  # same seed, same draw


def test_bad_selection_inputs():
    with pytest.raises(ValueError, match="unknown method"):
        SelectionConfig("svr")
    with pytest.raises(ValueError, match="rho"):
        SelectionConfig(rho=-1)
    with pytest.raises(ValueError, match="theta"):
        SelectionConfig(theta=-2)
    with pytest.raises(TypeError, match="Generator"):
        DofSelector(3, [0], [], SelectionConfig(), rng=0)
