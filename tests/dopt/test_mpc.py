"""Asynchronous and synchronous MPC."""

import threading
import time

import mujoco
import numpy as np
import pytest

from dopt import RolloutService, Scene
from dopt.costs import QuadraticCost
from dopt.mpc import MPC, MPCConfig, Plan, mpc_cost
from planners.ilqr import ILQR
from planners.svr import DofSelector, SelectionConfig, SVROptimiser

SLIDER = """<mujoco><option timestep="0.005" gravity="0 0 0"/><worldbody>
  <body name="a"><joint name="ax" type="slide" axis="1 0 0" damping=".5"/>
  <geom size=".05" mass="1"/></body>
  <body name="b" pos=".11 0 0"><joint name="bx" type="slide" axis="1 0 0" damping=".5"/>
  <geom size=".05" mass=".5"/></body></worldbody>
  <actuator><motor joint="ax" ctrlrange="-100000 100000" ctrllimited="true"/></actuator>
</mujoco>"""


@pytest.fixture(scope="module")
def slider():
    scene = Scene.from_xml(SLIDER)
    d = mujoco.MjData(scene.model)
    mujoco.mj_forward(scene.model, d)
    return scene, scene.state_of(d)


class StampingOptimiser:
    """Returns a plan whose control j is the agent step it is meant for (start + j), after a
    delay, so that the executed control at step i must equal i."""

    def __init__(self, scene, delay):
        self.scene, self.delay, self.calls = scene, delay, 0

    def optimise(self, state, plan):
        self.calls += 1
        start = int(round(state[0] / self.scene.model.opt.timestep))   # row time -> step
        time.sleep(self.delay)
        T = len(plan.controls)
        return Plan(controls=(start + np.arange(T, dtype=float))[:, None])


def test_plan_applied_from_the_index_it_was_computed_for(slider):
    scene, x0 = slider
    opt = StampingOptimiser(scene, delay=0.012)
    cfg = MPCConfig(timeout=60, slowdown=1.0)            # 5 ms per step: 2-3 steps of lag
    res = MPC(scene, opt, cfg, np.random.default_rng(0)).run(x0, Plan(np.full((20, 1), -1.0)))
    u = res.controls[:, 0]
    first = int(np.argmax(u >= 0))                       # first step under an optimised plan
    assert opt.calls >= 3 and first > 0
    np.testing.assert_array_equal(u[first:], np.arange(first, len(u)))
    assert max(res.lag_steps) >= 1                       # the optimiser really lagged


def test_agent_runs_at_the_configured_rate(slider):
    scene, x0 = slider
    cfg = MPCConfig(timeout=50, slowdown=2.0)            # 10 ms per step
    opt = StampingOptimiser(scene, delay=0.02)
    t0 = time.perf_counter()
    res = MPC(scene, opt, cfg, np.random.default_rng(0)).run(x0, Plan(np.zeros((10, 1))))
    wall = time.perf_counter() - t0
    assert len(res.controls) == 50
    assert wall >= 49 * 0.010                            # never faster than real time x 2
    assert res.late_steps < 25                           # and mostly on schedule


def make_svr_optimiser(scene, seed):
    q_ref = np.array([0.0, 0.3])
    w = np.array([0.0, 50.0, 0.0, 0.0])
    cost = QuadraticCost(scene, q_ref, w, 10 * w, np.array([1e-4]))
    sel = DofSelector(scene.nv, scene.dofs("robot"), cost.costed_dofs,
                      SelectionConfig("svr-sum", rho=1e-3, theta=1),
                      np.random.default_rng(seed))
    return cost, SVROptimiser(ILQR(RolloutService(scene), cost), sel)


def test_synchronous_equals_optimiser_then_agent(slider):
    scene, x0 = slider
    m = scene.model
    T, k, Y = 20, 3, 12
    cost, opt = make_svr_optimiser(scene, seed=5)
    plan0 = Plan(np.full((T, 1), 2.0))
    cfg = MPCConfig(timeout=Y, synchronous=True, steps_per_plan=k)
    res = MPC(scene, opt, cfg, np.random.default_rng(0)).run(x0, plan0)

    _, ref_opt = make_svr_optimiser(scene, seed=5)          # same seed, fresh state
    d = mujoco.MjData(m)
    mujoco.mj_setState(m, d, x0, mujoco.mjtState.mjSTATE_INTEGRATION)
    plan, executed = plan0, []
    while len(executed) < Y:
        plan = ref_opt.optimise(scene.state_of(d), plan)
        for _ in range(k):
            if len(executed) == Y:
                break
            d.ctrl[:] = plan.controls[0]
            executed.append(d.ctrl.copy())
            mujoco.mj_step(m, d)
            plan = plan.shifted(1)
    np.testing.assert_array_equal(res.controls, np.array(executed))
    np.testing.assert_array_equal(res.states[-1], scene.state_of(d))
    assert res.n_dofs[0] == 2 and len(res.opt_seconds) == 4
    assert mpc_cost(cost, res) < mpc_cost(cost, MPC(
        scene, _ConstantOptimiser(), cfg, np.random.default_rng(0)).run(x0, plan0))


class _ConstantOptimiser:
    def optimise(self, state, plan):
        return plan


def test_optimiser_error_surfaces(slider):
    scene, x0 = slider

    class Broken:
        def optimise(self, state, plan):
            raise RuntimeError("boom")

    with pytest.raises(RuntimeError, match="boom"):
        MPC(scene, Broken(), MPCConfig(timeout=1000), np.random.default_rng(0)).run(
            x0, Plan(np.zeros((5, 1))))
    assert threading.active_count() < 10


def test_bad_config(slider):
    scene, x0 = slider
    for kw in [dict(timeout=0), dict(timeout=5, slowdown=0), dict(timeout=5, control_noise=-1)]:
        with pytest.raises(ValueError):
            MPCConfig(**kw)
    with pytest.raises(ValueError, match="plan.controls"):
        MPC(scene, _ConstantOptimiser(), MPCConfig(timeout=3), np.random.default_rng(0)).run(
            x0, Plan(np.zeros((5, 2))))
