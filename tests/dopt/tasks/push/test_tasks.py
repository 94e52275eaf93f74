"""Every registered push task: the paper's sizes and constants, a clean start, stability,
determinism, and that pushing with the arm actually moves the goal object toward the goal."""

import mujoco
import numpy as np
import pytest

from dopt.tasks import PUSH_TASKS, TaskModel
from dopt.tasks.panda import BODY_NAMES, JOINT_NAMES, TAU_MAX

# nv, T, Y, slowdown, iLQR-Naive DoFs (paper Sec. 5.1 and Table 1); nu = 7 and dt = 0.004 for all
PAPER = {
    "clutter": (55, 80, 2000, 1, 23),
    "soft": (115, 50, 1000, 3, 79),
    "soft_rigid": (154, 100, 1000, 5, 9),
}
INTEGRATOR = {
    "clutter": mujoco.mjtIntegrator.mjINT_EULER,
    "soft": mujoco.mjtIntegrator.mjINT_DISCRETE,
    "soft_rigid": mujoco.mjtIntegrator.mjINT_DISCRETE,
}
INTEGRATION = mujoco.mjtState.mjSTATE_INTEGRATION


@pytest.fixture(scope="module", params=sorted(PAPER))
def task(request) -> TaskModel:
    return PUSH_TASKS[request.param](np.random.default_rng(0))


def start_data(task: TaskModel) -> mujoco.MjData:
    data = mujoco.MjData(task.model)
    mujoco.mj_setState(task.model, data, task.initial_state, INTEGRATION)
    mujoco.mj_forward(task.model, data)
    return data


def goal_object_xy(task: TaskModel, data: mujoco.MjData) -> np.ndarray:
    if task.goal_object == task.soft_body:
        flex = mujoco.mj_name2id(task.model, mujoco.mjtObj.mjOBJ_FLEX, task.soft_body)
        start = task.model.flex_vertadr[flex]
        return data.flexvert_xpos[start : start + task.model.flex_vertnum[flex], :2].mean(axis=0)
    return data.body(task.goal_object).xpos[:2].copy()


def assert_healthy(task: TaskModel, data: mujoco.MjData, steps: int) -> None:
    """No NaN, no MuJoCo warning, and no silent reset (time went on for every step)."""
    assert np.all(np.isfinite(data.qpos)) and np.all(np.isfinite(data.qvel))
    assert [w.number for w in data.warning] == [0] * len(data.warning)
    assert data.time == pytest.approx(steps * task.dt)


@pytest.mark.parametrize("name", sorted(PAPER))
@pytest.mark.parametrize("rng", [0, None, np.random.RandomState(0)])
def test_builders_demand_a_generator(name, rng):
    with pytest.raises(TypeError, match="numpy.random.Generator"):
        PUSH_TASKS[name](rng)


def test_sizes_and_constants_match_the_paper(task):
    nv, horizon, timeout, slowdown, naive = PAPER[task.name]
    model = task.model
    assert (model.nv, model.nu) == (nv, 7)
    assert (task.horizon, task.timeout, task.slowdown) == (horizon, timeout, slowdown)
    assert task.dt == model.opt.timestep == 0.004
    assert model.opt.integrator == INTEGRATOR[task.name]
    assert len(task.robot_dofs) + len(task.cost_dofs) == naive
    assert task.initial_state.shape == (mujoco.mj_stateSize(model, INTEGRATION),)
    assert task.goal_position.shape == (3,)


def test_push_cost_reads_exactly_the_naive_dofs(task):
    """iLQR-Naive takes the DoFs 'in the cost' (cost.costed_dofs): the robot plus the task's
    cost DoFs, the paper's counts 23 / 79 / 9 (the end-effector term reads the goal object)."""
    from dopt.scene import Scene
    from dopt.tasks.push.costs import push_cost
    cost = push_cost(task, Scene(task.model))
    want = np.union1d(task.robot_dofs, task.cost_dofs)
    np.testing.assert_array_equal(cost.costed_dofs, want)
    assert len(want) == PAPER[task.name][4]


def test_actuators_drive_the_robot_joints_in_order(task):
    model = task.model
    assert task.robot_joints == JOINT_NAMES and task.robot_bodies == BODY_NAMES
    joints = [model.joint(model.actuator_trnid[i, 0]).name for i in range(model.nu)]
    assert tuple(joints) == task.robot_joints
    np.testing.assert_array_equal(model.actuator_ctrlrange[:, 1], TAU_MAX)
    assert model.actuator_ctrllimited.all()
    np.testing.assert_array_equal(task.robot_dofs, [model.joint(n).dofadr[0] for n in JOINT_NAMES])


def test_cost_dofs_are_world_xy_translations_of_the_cost_objects(task):
    """Moving along one cost DoF moves exactly one cost body, along world x or y only."""
    model, data = task.model, start_data(task)
    cost_bodies = {model.body(n).id for n in (task.goal_object, *task.distractors)
                   if n != task.soft_body}
    if task.goal_object == task.soft_body:
        flex = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_FLEX, task.soft_body)
        start = model.flex_vertadr[flex]
        cost_bodies |= set(model.flex_vertbodyid[start : start + model.flex_vertnum[flex]])
    moved_bodies = set()
    moved = mujoco.MjData(model)
    for dof in task.cost_dofs:
        qvel = np.zeros(model.nv)
        qvel[dof] = 1.0
        moved.qpos[:] = data.qpos
        mujoco.mj_integratePos(model, moved.qpos, qvel, 1e-3)
        mujoco.mj_kinematics(model, moved)
        shift = moved.xpos - data.xpos
        body = int(np.argmax(np.abs(shift).sum(axis=1)))
        assert body in cost_bodies
        np.testing.assert_allclose(np.sort(np.abs(shift[body])), [0.0, 0.0, 1e-3], atol=1e-12)
        assert np.abs(np.delete(shift, body, axis=0)).max() < 1e-12
        moved_bodies.add(body)
    assert moved_bodies == cost_bodies


def test_start_is_at_rest_without_penetration_or_arm_contact(task):
    model, data = task.model, start_data(task)
    assert np.abs(data.qvel).max() < 1e-3
    arm_bodies = {model.body(n).id for n in task.robot_bodies}
    assert data.ncon > 0  # the objects rest on the table
    for contact in data.contact[: data.ncon]:
        assert contact.dist > -1e-3
        bodies = {model.geom_bodyid[g] for g in contact.geom if g >= 0}
        assert not bodies & arm_bodies, "the arm touches something at the start"


def test_pusher_starts_just_above_the_table_behind_the_goal_object(task):
    data = start_data(task)
    ee = data.site(task.ee_site)
    assert 0.02 < ee.xpos[2] < 0.06
    np.testing.assert_allclose(ee.xmat.reshape(3, 3)[:, 2], [0, 0, -1], atol=1e-5)
    obj, goal = goal_object_xy(task, data), task.goal_position[:2]
    to_obj, to_goal = obj - ee.xpos[:2], goal - obj
    # the object lies between the pusher and the goal, all on a line
    assert np.dot(to_obj, to_goal) > 0.95 * np.linalg.norm(to_obj) * np.linalg.norm(to_goal)
    assert 0.1 < np.linalg.norm(to_goal) < 0.35


@pytest.mark.parametrize("controls", ["zero", "random"])
def test_stable_under_zero_and_random_torques(task, controls):
    model, data = task.model, start_data(task)
    rng = np.random.default_rng(1)
    low, high = model.actuator_ctrlrange.T
    steps = 200
    for _ in range(steps):
        data.ctrl[:] = 0.0 if controls == "zero" else rng.uniform(low, high)
        mujoco.mj_step(model, data)
    assert_healthy(task, data, steps)


def test_pushing_moves_the_goal_object_toward_the_goal(task):
    """A Cartesian PD pushes the tip 0.25 m along the line to the goal (a reference made without
    any planner): the goal object must travel at least 0.1 m toward the goal."""
    model, data = task.model, start_data(task)
    site, dofs = model.site(task.ee_site).id, task.robot_dofs
    start_tip = data.site_xpos[site].copy()
    before = goal_object_xy(task, data)
    direction = np.append(task.goal_position[:2] - before, 0.0)
    direction /= np.linalg.norm(direction)
    jac_pos, jac_rot = np.zeros((3, model.nv)), np.zeros((3, model.nv))
    low, high = model.actuator_ctrlrange.T
    steps = 300
    for _ in range(steps):
        reference = start_tip + min(0.2 * data.time, 0.25) * direction
        mujoco.mj_jacSite(model, data, jac_pos, jac_rot, site)
        jp, jr, qvel = jac_pos[:, dofs], jac_rot[:, dofs], data.qvel[dofs]
        force = 400.0 * (reference - data.site_xpos[site]) - 40.0 * jp @ qvel
        axis = data.site_xmat[site].reshape(3, 3)[:, 2]
        torque = 20.0 * np.cross(axis, [0.0, 0.0, -1.0]) - 2.0 * jr @ qvel
        # cancel the arm's heavy joint damping down to 1 N m s/rad, so the PD acts on a light arm
        damping = (model.dof_damping[dofs] - 1.0) * qvel
        data.ctrl[:] = np.clip(jp.T @ force + jr.T @ torque + damping, low, high)
        mujoco.mj_step(model, data)
    assert_healthy(task, data, steps)
    assert np.dot(goal_object_xy(task, data) - before, direction[:2]) > 0.1


@pytest.mark.parametrize("name", sorted(PAPER))
def test_same_seed_same_instance_other_seed_other_instance(name):
    first, again, other = (PUSH_TASKS[name](np.random.default_rng(seed)) for seed in (7, 7, 8))
    np.testing.assert_array_equal(first.initial_state, again.initial_state)
    np.testing.assert_array_equal(first.goal_position, again.goal_position)
    assert not np.allclose(first.goal_position, other.goal_position)
    size = min(first.initial_state.size, other.initial_state.size)
    assert not np.allclose(first.initial_state[:size], other.initial_state[:size])
