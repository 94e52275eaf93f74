"""Asynchronous and synchronous MPC."""

import threading
import time

import mujoco
import numpy as np
import pytest

from dopt import RolloutService
from dopt.costs import QuadraticCost
from dopt.mpc import MPC, MPCConfig, Plan, mpc_cost
from planners.ilqr import ILQR
from planners.svr import DofSelector, SelectionConfig, SVROptimiser


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


class BusyOptimiser:
    """Burns ``cpu`` s of process CPU time, then returns the plan with the DoF set (0..c-1)."""

    def __init__(self, cpu, c=1):
        self.cpu, self.c = cpu, c

    def optimise(self, state, plan):
        t0 = time.process_time()
        while time.process_time() - t0 < self.cpu:
            pass
        return Plan(controls=plan.controls, dofs=np.arange(self.c))


def test_virtual_clock_lag_is_the_cpu_time_over_the_threads(slider):
    """Each optimisation lets the agent take the steps that fall in its CPU time / threads:
    optimisation i ends at virtual time T_i = sum_{j<=i} cpu_j / threads, and its lag is the
    number of steps k < timeout with k dt slowdown < T_i not taken before it (the last one is
    cut short by the timeout); all steps are accounted for."""
    scene, x0 = slider
    cfg = MPCConfig(timeout=120, slowdown=2.0, clock="virtual", threads=2.0)
    res = MPC(scene, BusyOptimiser(0.05), cfg, np.random.default_rng(0)).run(
        x0, Plan(np.zeros((20, 1))))
    period = scene.model.opt.timestep * cfg.slowdown
    assert len(res.controls) == 120 and len(res.cpu_seconds) == len(res.lag_steps)
    clock, taken = 0.0, 0
    for cpu, lag, seconds in zip(res.cpu_seconds, res.lag_steps, res.opt_seconds, strict=True):
        assert seconds == pytest.approx(cpu / 2.0)
        end = sum(1 for k in range(120) if k * period < clock + seconds)
        assert lag == end - taken
        assert lag <= cpu / 2.0 / period + 1
        clock, taken = clock + seconds, end
    assert sum(res.lag_steps) == 120
    assert np.mean(res.lag_steps) == pytest.approx(0.05 / 2 / period, abs=1)


def test_model_clock_is_deterministic_and_follows_the_cost_model(slider):
    """ms = a + b |C|: the lag is that over dt x slowdown (within a step), and two runs with
    the same seed and control noise give the same episode bit for bit, whatever the CPU
    time."""
    scene, x0 = slider
    cfg = MPCConfig(timeout=90, clock="model", model_ms=(4.0, 3.0), control_noise=0.1)
    runs = [MPC(scene, BusyOptimiser(cpu, c=2), cfg, np.random.default_rng(7)).run(
        x0, Plan(np.full((20, 1), 5.0))) for cpu in (0.0, 0.02)]
    period = scene.model.opt.timestep
    for res in runs:
        assert all(abs(lag - 0.010 / period) <= 1 for lag in res.lag_steps)
        assert res.opt_seconds == pytest.approx([0.010] * len(res.opt_seconds))
    np.testing.assert_array_equal(runs[0].states, runs[1].states)
    np.testing.assert_array_equal(runs[0].lag_steps, runs[1].lag_steps)


class Idle:
    """Returns the plan it is given, at once."""

    def __init__(self):
        self.calls = 0

    def optimise(self, state, plan):
        self.calls += 1
        return Plan(plan.controls)


@pytest.mark.parametrize("cfg", [dict(clock="virtual"), dict(clock="model", model_ms=(1e-3, 0.0)),
                                 dict(slowdown=1.0)], ids=["virtual", "model", "real"])
def test_an_optimiser_faster_than_a_step_waits_for_the_next_state(slider, cfg):
    """An optimisation that ends before the agent's next step does not start again from the
    same state: the starts are distinct agent steps (at most one per step, not thousands),
    and the executed controls are the unchanged plan, padded with its last control."""
    scene, x0 = slider
    opt = Idle()
    plan = Plan(np.linspace(-1.0, 1.0, 12)[:, None])
    res = MPC(scene, opt, MPCConfig(timeout=40, **cfg), np.random.default_rng(0)).run(x0, plan)
    starts = np.asarray(res.opt_step)
    assert opt.calls == len(starts) and 1 <= len(starts) <= 40
    assert (np.diff(starts) >= 1).all()
    expected = plan.controls[np.minimum(np.arange(40), 11), 0]
    np.testing.assert_array_equal(res.controls[:, 0], expected)


@pytest.mark.parametrize("kwargs, match", [
    ({"clock": "wall"}, "clock must be one of"),
    ({"clock": "model"}, "model_ms"),
    ({"clock": "model", "model_ms": (0.0, 0.0)}, "model_ms"),
    ({"clock": "model", "model_ms": (1.0, float("nan"))}, "model_ms"),
    ({"clock": "virtual", "synchronous": True}, "synchronous"),
    ({"clock": "virtual", "threads": 0}, "threads"),
])
def test_clock_config_errors(kwargs, match):
    with pytest.raises(ValueError, match=match):
        MPCConfig(timeout=10, **kwargs)
