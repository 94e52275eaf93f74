"""The authors' executor (``MPCConfig(executor="authors")``) on constructed timelines: the arm
holds until a plan lands and once min(apply_limit, T) of its controls are used; a landed plan
goes on from the nominal row nearest the agent's state over the plan's DoFs, else from its lag
(capped at T - 1). The slider carries no gravity, so a hold (zero control) from rest stays
exactly at rest and the state at landing is known in advance."""

import numpy as np
import pytest

from dopt.mpc import MPC, NEAREST_MAX_L1, MPCConfig, Plan


class Scripted:
    """Returns ``plans[i]`` at its i-th call (the last one after), marked ``keep`` from call
    ``keep_from`` on (nothing lands)."""

    def __init__(self, plans, keep_from=None):
        self.plans, self.keep_from, self.calls = plans, keep_from, 0

    def optimise(self, state, plan):
        self.calls += 1
        p = self.plans[min(self.calls, len(self.plans)) - 1]
        keep = self.keep_from is not None and self.calls >= self.keep_from
        return Plan(p.controls, p.states, dofs=p.dofs, info={"keep": True} if keep else {})


def config(lag_steps, limit, timeout, period=0.005):
    """The model clock at a fixed ``lag_steps`` per optimisation (``period`` s a step)."""
    return MPCConfig(timeout=timeout, clock="model", model_ms=(lag_steps * period * 1e3, 0.0),
                     executor="authors", apply_limit=limit)


def run(scene, x0, opt, cfg, T=30):
    return MPC(scene, opt, cfg, np.random.default_rng(0)).run(x0, Plan(np.full((T, 1), -7.0)))


def test_the_arm_holds_until_a_plan_lands_and_after_the_apply_limit(slider):
    """First optimisation lasts 5 steps: 5 held steps (the initial plan is only its warm
    start), then rows 5..19 of the landed plan (limit 20 of T = 30), then a hold for ever
    (later optimisations land nothing)."""
    scene, x0 = slider
    T, lag, limit = 30, 5, 20
    plan = Plan(100.0 + np.arange(T, dtype=float)[:, None])
    res = run(scene, x0, Scripted([plan], keep_from=2), config(lag, limit, 60), T)
    u = res.controls[:, 0]
    expected = np.zeros(60)
    expected[lag:limit] = 100.0 + np.arange(lag, limit)
    np.testing.assert_array_equal(u, expected)
    assert res.held_steps == 60 - (limit - lag)
    assert res.landed_at[0] == lag and set(res.landed_at[1:]) == {-1}


def test_alg1_pads_where_the_authors_executor_holds(slider):
    """The same optimiser under Alg. 1: the initial plan runs from step 0, the landed plan
    goes on from its lag and, once spent, repeats its last control; nothing is held."""
    scene, x0 = slider
    T, lag = 30, 5
    plan = Plan(100.0 + np.arange(T, dtype=float)[:, None])
    cfg = MPCConfig(timeout=60, clock="model", model_ms=(lag * 5.0, 0.0))
    res = run(scene, x0, Scripted([plan], keep_from=2), cfg, T)
    u = res.controls[:, 0]
    np.testing.assert_array_equal(u[:lag], -7.0)
    np.testing.assert_array_equal(u[lag:], 100.0 + np.minimum(np.arange(lag, 60), T - 1))
    assert res.held_steps == 0


def nominal(x0, scene, offsets, dof=0):
    """States (len(offsets), ns): x0 with DoF ``dof``'s position moved by each offset."""
    q = np.arange(len(x0))[scene.layout["qpos"]]
    rows = np.repeat(x0[None], len(offsets), axis=0)
    rows[:, q[dof]] += offsets
    return rows


@pytest.mark.parametrize("lag", [2, 9, 25])
def test_a_plan_lands_at_the_nominal_row_nearest_the_state(slider, lag):
    """The agent holds at rest at x0 until the first plan lands; the nominal is x0 only at
    row 7, so the plan goes on from row 7 whatever its lag."""
    scene, x0 = slider
    T = 30
    states = nominal(x0, scene, 0.01 * np.abs(np.arange(T + 1) - 7.0))
    plan = Plan(100.0 + np.arange(T, dtype=float)[:, None], states=states, dofs=np.array([0]))
    res = run(scene, x0, Scripted([plan], keep_from=2), config(lag, 80, lag + 4), T)
    assert res.landed_at[0] == 7
    np.testing.assert_array_equal(res.controls[lag:lag + 4, 0], 100.0 + np.arange(7, 11))


def test_the_nearest_row_counts_only_the_plans_dofs(slider):
    """Row 3 matches DoF 0 exactly but is far off in DoF 1; with C = {0} it is the nearest,
    with every DoF another row is."""
    scene, x0 = slider
    T = 12
    states = nominal(x0, scene, 0.01 * np.abs(np.arange(T + 1) - 3.0))
    q1 = np.arange(len(x0))[scene.layout["qpos"]][1]
    states[:, q1] += np.where(np.arange(T + 1) == 3, 5.0, 0.0)
    for dofs, row in ((np.array([0]), 3), (None, 2)):
        plan = Plan(np.zeros((T, 1)), states=states, dofs=dofs)
        res = run(scene, x0, Scripted([plan], keep_from=2), config(4, 80, 6), T)
        assert res.landed_at[0] == row


@pytest.mark.parametrize("lag, row", [(6, 6), (40, 11)])
def test_without_a_near_row_a_plan_lands_at_its_lag_capped_at_T_minus_1(slider, lag, row):
    """Every nominal row at least NEAREST_MAX_L1 away: the plan goes on from min(lag, T-1)."""
    scene, x0 = slider
    T = 12
    states = nominal(x0, scene, np.full(T + 1, 2 * NEAREST_MAX_L1))
    plan = Plan(100.0 + np.arange(T, dtype=float)[:, None], states=states)
    res = run(scene, x0, Scripted([plan], keep_from=2), config(lag, 80, lag + 3), T)
    assert res.landed_at[0] == row
    assert res.controls[lag, 0] == 100.0 + row


def test_the_next_optimisation_starts_from_the_buffer_at_its_cursor(slider):
    """The warm start of an optimisation is the executing plan from its cursor, padded with
    its last control (the authors' erase-and-pad), and the initial plan before any landing."""
    scene, x0 = slider
    seen = []

    class Recording(Scripted):
        def optimise(self, state, plan):
            seen.append(plan.controls[:, 0].copy())
            return super().optimise(state, plan)

    T = 10
    plan = Plan(100.0 + np.arange(T, dtype=float)[:, None])
    run(scene, x0, Recording([plan]), config(3, 80, 9), T)
    np.testing.assert_array_equal(seen[0], -7.0)                 # the initial plan
    np.testing.assert_array_equal(seen[1], 100.0 + np.minimum(np.arange(3, 3 + T), T - 1))


def test_executor_config_errors():
    with pytest.raises(ValueError, match="executor must be one of"):
        MPCConfig(timeout=10, executor="paper")
    with pytest.raises(ValueError, match="apply_limit"):
        MPCConfig(timeout=10, executor="authors", apply_limit=0)
