"""dopt.tasks.push.warm_start (the authors' set-up motion and initial push plan, our
controller) and the paper's cost without the end-effector term."""

import mujoco
import numpy as np
import pytest

from dopt.costs import EEDistanceTerm
from dopt.scene import Scene
from dopt.state import INTEGRATION
from dopt.tasks import PUSH_TASKS
from dopt.tasks.panda import TOOL_RADIUS, arm_qpos_index, ik_pointing_down
from dopt.tasks.push import warm_start as ws
from dopt.tasks.push.costs import COST_PRESETS, PushWeights, push_cost


@pytest.fixture(scope="module", params=sorted(PUSH_TASKS))
def task(request):
    return PUSH_TASKS[request.param](np.random.default_rng(5))


def ee_of(task, state):
    m = task.model
    d = mujoco.MjData(m)
    mujoco.mj_setState(m, d, state, INTEGRATION)
    mujoco.mj_forward(m, d)
    return d.site_xpos[m.site(task.ee_site).id].copy()


def arm_elsewhere(task, offset):
    """The task's start with the arm's tip moved by ``offset`` (m), tool down (IK)."""
    m = task.model
    d = mujoco.MjData(m)
    mujoco.mj_setState(m, d, task.initial_state, INTEGRATION)
    mujoco.mj_forward(m, d)
    d.qpos[arm_qpos_index(m)] = ik_pointing_down(ee_of(task, task.initial_state) + offset)
    x = np.empty(mujoco.mj_stateSize(m, INTEGRATION))
    mujoco.mj_getState(m, d, x, INTEGRATION)
    return x


def object_xy(task, state):
    """The pushed object's xy points in ``state``, read from MuJoCo directly."""
    m = task.model
    d = mujoco.MjData(m)
    mujoco.mj_setState(m, d, state, INTEGRATION)
    mujoco.mj_forward(m, d)
    flex = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_FLEX, task.pushed_object)
    if flex >= 0:
        a, n = m.flex_vertadr[flex], m.flex_vertnum[flex]
        return d.flexvert_xpos[a:a + n, :2].copy()
    return d.body(task.pushed_object).xpos[None, :2].copy()


@pytest.mark.parametrize("offset", [(0.0, 0.0, 0.0), (-0.05, 0.1, 0.15), (0.0, -0.12, 0.1)])
def test_setup_puts_the_pusher_behind_the_pushed_object(task, offset):
    """From the task's start or from an arm moved 15-19 cm away, the set-up motion ends with
    the tip within 2 cm of the set-up point, behind the object's back face on the line from the
    goal through its centre, without moving the object."""
    start = arm_elsewhere(task, np.array(offset)) if any(offset) else task.initial_state
    plan = ws.setup(task, start)
    end = plan.final_state
    ee = ee_of(task, end)
    assert np.linalg.norm(ee - ws.setup_point(task, end)) < 0.02
    pts = object_xy(task, end)
    centre = pts.mean(axis=0)
    along = task.goal_position[:2] - centre
    along /= np.linalg.norm(along)
    rel = ee[:2] - centre
    back = np.max((centre - pts) @ along)                   # vertex centres' back face
    assert rel @ along < -(back + TOOL_RADIUS)               # behind the object
    assert abs(rel @ np.array([-along[1], along[0]])) < 0.02  # on the pushing line
    assert abs(ee[2] - task.push_height) < 0.02              # the task's push height
    moved = np.abs(object_xy(task, end) - object_xy(task, start)).max()
    assert moved < 0.005
    assert plan.controls.shape == (ws.WarmStartConfig().setup_steps
                                   + ws.WarmStartConfig().hold_steps, task.model.nu)


def roll(task, start, controls):
    """The end effector's position after ``controls`` from ``start``, stepped by MuJoCo."""
    m = task.model
    d = mujoco.MjData(m)
    mujoco.mj_setState(m, d, start, INTEGRATION)
    for u in controls:
        d.ctrl[:] = u
        mujoco.mj_step(m, d)
    mujoco.mj_forward(m, d)
    return d.site_xpos[m.site(task.ee_site).id].copy()


def push_direction(task, state):
    pts = object_xy(task, state)
    along = task.goal_position[:2] - pts.mean(axis=0)
    return pts.mean(axis=0), along / np.linalg.norm(along)


def test_push_plan_moves_the_pusher_toward_the_authors_end_point(task):
    """The push plan's controls, rolled out by MuJoCo, move the tip along the line to the
    goal toward the authors' end point (the object's centre moved toward the goal by speed x
    5/6 x T dt, or the goal), without passing it; they stay within the torque limits."""
    start = ws.setup(task).final_state
    cfg = ws.WarmStartConfig()
    plan = ws.push(task, start, task.horizon)
    assert plan.controls.shape == (task.horizon, task.model.nu)
    lo, hi = task.model.actuator_ctrlrange.T
    assert np.all(plan.controls >= lo) and np.all(plan.controls <= hi)
    ee0, ee1 = ee_of(task, start), roll(task, start, plan.controls)
    centre, along = push_direction(task, start)
    reach = cfg.speed * cfg.fraction * task.horizon * task.dt
    dist = np.linalg.norm(task.goal_position[:2] - centre)
    target = (centre - ee0[:2]) @ along + min(reach, dist)      # tip travel to the end point
    np.testing.assert_allclose(ws.push_end(task, start, task.horizon)[:2],
                               centre + min(reach, dist) * along, atol=1e-12)
    travelled = (ee1 - ee0)[:2] @ along
    assert 0.6 * target < travelled < target + 0.005


def test_the_plans_last_control_does_not_pull_back(task):
    """Padding a plan with its last control (what MPC does as it shifts a plan): with the
    moving tail the tip stays at the object or moves on toward the goal over another horizon;
    the last control of a plan whose path ends at its end point (``moving_tail=False``) brakes,
    and repeated it pulls the tip back, at least 1 cm behind the tail's."""
    start = ws.setup(task).final_state
    _, along = push_direction(task, start)
    travel = {}
    for tail in (True, False):
        plan = ws.push(task, start, task.horizon, ws.WarmStartConfig(moving_tail=tail))
        ee1 = roll(task, plan.final_state, [])
        ee2 = roll(task, plan.final_state, np.repeat(plan.controls[-1:], task.horizon, axis=0))
        travel[tail] = (ee2 - ee1)[:2] @ along
    assert travel[True] > -0.005
    assert travel[True] > travel[False] + 0.01


def test_warm_start_rejects_bad_inputs(task):
    with pytest.raises(ValueError, match="state must have shape"):
        ws.setup(task, np.zeros(3))
    with pytest.raises(ValueError, match=r"path must have shape \(S, 3\)"):
        ws.track(task, task.initial_state, np.zeros((4, 2)))
    with pytest.raises(ValueError, match="horizon"):
        ws.push(task, task.initial_state, 0)
    with pytest.raises(ValueError, match="setup_steps"):
        ws.WarmStartConfig(setup_steps=0)
    with pytest.raises(ValueError, match="depth_from"):
        ws.WarmStartConfig(depth_from="middle")


def test_paper_cost_has_no_end_effector_term(task):
    """The paper's cost (Eq. 2) has no residual term, and moving the arm (at rest) does not
    change its value; ours has the end-effector term, which does."""
    scene = Scene(task.model)
    paper = push_cost(task, scene, COST_PRESETS["paper"])
    ours = push_cost(task, scene, COST_PRESETS["ee"])
    assert paper.terms == () and COST_PRESETS["paper"] == PushWeights.paper()
    assert [type(t) for t in ours.terms] == [EEDistanceTerm]
    moved = arm_elsewhere(task, np.array([0.0, 0.1, 0.1]))
    u = np.zeros((1, task.model.nu))

    def cost(c, x):
        return float(c.total(np.stack([x, x]), u))

    assert cost(paper, moved) == pytest.approx(cost(paper, task.initial_state), rel=1e-12)
    assert cost(ours, moved) != pytest.approx(cost(ours, task.initial_state), rel=1e-3)


def test_paper_reach_is_eq2_plus_the_authors_terminal_reach_residual():
    """paper-reach on the soft task: Eq. 2's weights and one terminal-only term, the pusher
    tip's 3D distance to the block's centroid at table height less the contact distance: at
    the start (tip STANDOFF behind the block) its residual is below STANDOFF and positive; an
    arm 10 cm farther away costs 1e5 (d - r)^2 more, only at the last row."""
    import torch

    from dopt.tasks.push.clutter import STANDOFF

    task = PUSH_TASKS["soft"](np.random.default_rng(0))
    scene = Scene(task.model)
    reach = push_cost(task, scene, COST_PRESETS["paper-reach"])
    paper = push_cost(task, scene, COST_PRESETS["paper"])
    (term,) = reach.terms
    assert (term.weight, term.terminal_weight, term.axes) == (0.0, 1e5, [0, 1, 2])
    q0 = task.initial_state[scene.layout["qpos"]]
    r0 = float(term.residual(torch.as_tensor(q0)[None])[0, 0])
    assert 0 < r0 < STANDOFF
    u = np.zeros((1, task.model.nu))
    x0 = task.initial_state
    assert float(reach.total(np.stack([x0, x0]), u)) == pytest.approx(
        float(paper.total(np.stack([x0, x0]), u)) + 1e5 * r0 ** 2, rel=1e-9)
    moved = arm_elsewhere(task, np.array([-0.1, 0.0, 0.0]))
    qm = moved[scene.layout["qpos"]]
    rm = float(term.residual(torch.as_tensor(qm)[None])[0, 0])
    assert rm > r0 + 0.05
    assert float(reach.total(np.stack([moved, x0]), u)) == pytest.approx(
        float(paper.total(np.stack([moved, x0]), u)) + 1e5 * r0 ** 2, rel=1e-9)

