"""C(a_t), the action constraint: the signed distance of the place point outside the workspace
box (against a brute-force reference), its projection, the picker's joint limits that enforce
it in simulation, the stretch limit, and bad inputs."""

from dataclasses import replace

import mujoco
import numpy as np
import pytest

from dopt.rollout import RolloutConfig, RolloutService
from dopt.tasks.pick.cloth_scene import ClothSceneConfig, make_cloth
from dopt.tasks.pick.constraints import ActionConstraint
from dopt.tasks.pick.picker import CONTROL_SPEC, NONE, PickerConfig
from dopt.tasks.pick.scene import PickPlaceTask
from planners.pick_place import PickPlaceSettings
from planners.scripted import ScriptedConfig, scripted


def _box_distance(q, low, high):
    """Reference: the signed distance to the box, by cases (outside: the largest excess over
    the axes; inside: minus the distance to the nearest face)."""
    q, low, high = (np.asarray(v, float) for v in (q, low, high))
    if np.all(q >= low) and np.all(q <= high):
        return -min(min(q[a] - low[a], high[a] - q[a]) for a in range(3))
    return max(max(low[a] - q[a], q[a] - high[a], 0.0) for a in range(3))


@pytest.mark.parametrize("seed", range(10))
def test_value_is_the_signed_box_distance_of_the_place_point(seed):
    rng = np.random.default_rng(seed)
    low = rng.uniform(-1, 0, 3)
    c = ActionConstraint(tuple(low), tuple(low + rng.uniform(0.1, 2, 3)))
    x = rng.uniform(-1.5, 1.5, (30, 3))
    idx = rng.integers(0, 30, 50)
    d = rng.uniform(-0.5, 0.5, (50, 3))
    got = c.value(x, idx, d)
    want = [_box_distance(x[i] + di, c.low, c.high) for i, di in zip(idx, d, strict=True)]
    np.testing.assert_allclose(got, want, atol=1e-12)
    assert np.array_equal(c.feasible(x, idx, d), np.asarray(want) < 0)


@pytest.mark.parametrize("seed", range(10))
def test_projection_is_the_nearest_place_point_in_the_box(seed):
    rng = np.random.default_rng(seed)
    c = ActionConstraint.table(0.3)
    x = rng.uniform(-0.4, 0.4, (20, 3))
    idx = rng.integers(0, 20, 40)
    d = rng.uniform(-0.3, 0.3, (40, 3))
    p = c.project(x, idx, d)
    q = x[idx] + p
    assert np.all(c.value(x, idx, p) <= 1e-12)                   # inside (faces included)
    inside = c.feasible(x, idx, d)
    np.testing.assert_array_equal(p[inside], d[inside])          # feasible: unchanged
    others = rng.uniform(c.low, c.high, (500, 3))                # no box point is nearer
    for k in np.flatnonzero(~inside):
        target = x[idx[k]] + d[k]
        assert np.linalg.norm(q[k] - target) <= np.linalg.norm(others - target, axis=1).min()


def test_none_action_is_feasible_and_not_moved():
    c = ActionConstraint.table(0.1)
    x = np.zeros((3, 3))
    assert c.value(x, np.array([NONE]), np.array([[5.0, 0, 0]]))[0] == -np.inf
    assert np.array_equal(c.project(x, np.array([NONE]), np.array([[5.0, 0, 0]])),
                          np.zeros((1, 3)))


@pytest.mark.parametrize("kwargs, error, match", [
    ({"low": (0, 0, 0), "high": (1, 0, 1)}, ValueError, "low < high"),
    ({"low": (0, 0), "high": (1, 1, 1)}, ValueError, "3 entries"),
    ({"low": (0, 0, 0), "high": (1, 1, 1), "max_stretch": 0.0}, ValueError, "max_stretch"),
    ({"low": (0, 0, "a"), "high": (1, 1, 1)}, TypeError, "low"),
])
def test_bad_constraints_raise(kwargs, error, match):
    with pytest.raises(error, match=match):
        ActionConstraint(**kwargs)


def test_bad_actions_and_pickers_raise():
    c = ActionConstraint.table(0.3)
    with pytest.raises(TypeError, match="integer"):
        c.value(np.zeros((4, 3)), np.array([1.0]), np.zeros((1, 3)))
    with pytest.raises(ValueError, match="shape"):
        c.value(np.zeros((4, 3)), np.array([1, 2]), np.zeros((1, 3)))
    with pytest.raises(ValueError, match="-1..3"):
        c.value(np.zeros((4, 3)), np.array([4]), np.zeros((1, 3)))
    with pytest.raises(TypeError, match="ActionConstraint"):
        PickerConfig(workspace=((0, 0, 0), (1, 1, 1)))
    with pytest.raises(ValueError, match="outside the workspace"):
        PickerConfig(workspace=ActionConstraint.table(0.3, height=0.2))   # start at 0.3 m


# ------------------------------------------------------------------------- simulation
N = 8
CORNER = N * N - 1          # at (+side/2, +side/2)


def _task(workspace=None, max_stretch=None):
    if workspace is not None and max_stretch is not None:
        workspace = ActionConstraint(workspace.low, workspace.high, max_stretch)
    scene = make_cloth(ClothSceneConfig.physics("fast", n=N),     # a sheet that stretches
                       PickerConfig(bound=(0.3,) * 3, workspace=workspace))
    return PickPlaceTask(scene, scene.positions(scene.initial_state),
                         rollout=RolloutService(scene.scene, RolloutConfig(threads=1)))


def _picker_path(task, particle, d) -> np.ndarray:
    """(T, 3) world positions of the picker (so of the held particle) over one action."""
    m = task.scene.model
    adr = [m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, f"picker_{a}")]
           for a in "xyz"]
    U = task.picker.encode(np.array([[particle]]), np.asarray(d, float)[None, None])
    res = task.service.rollout(task.start_state, U, control_spec=CONTROL_SPEC,
                               record=("qpos",))
    return np.asarray(task.picker.config.start) + res.records["qpos"][0][:, adr]


@pytest.mark.parametrize("d", [(0.15, 0.0, 0.0), (0.15, 0.1, 0.05), (0.1, 0.1, 0.3)])
def test_the_picker_keeps_an_infeasible_action_in_the_workspace(d):
    """Corner drags whose place point lies beyond the box (C > 0): the picker, and the
    particle it holds, stay inside the box at every step (its joint limits act as SoftGym's
    clip; MuJoCo's limits are soft: a few mm over at the servo's push) and reach the projected
    place point; without the box they go beyond."""
    box = ActionConstraint.table(0.2, height=0.35)
    task = _task(box)
    x0 = task.positions(task.start_state)
    assert box.value(x0, np.int64(CORNER), np.array(d)) > 0.04
    path = _picker_path(task, CORNER, d)
    assert np.all(path <= np.array(box.high) + 0.005)     # a joint limit is a soft constraint
    want = x0[CORNER] + box.project(x0, np.int64(CORNER), np.array(d))
    pk = task.picker
    release = path[pk.snap_steps + pk.hold_steps + pk.move_steps - 1]
    assert np.linalg.norm(release - want) < 0.01
    free = _picker_path(_task(), CORNER, d)
    assert np.any(free.max(axis=0) > np.array(box.high) + 0.04)


def test_a_feasible_action_is_executed_as_without_the_box():
    box = ActionConstraint.table(0.2)
    d = np.array([[-0.1, -0.05, 0.0]])
    x0 = _task(box).positions(_task(box).start_state)
    assert box.value(x0, np.int64(CORNER), d[0]) < 0
    a, b = _task(box), _task()
    ea = a.positions(a.execute([CORNER], d).state)
    eb = b.positions(b.execute([CORNER], d).state)
    np.testing.assert_allclose(ea, eb, atol=1e-9)


def test_the_stretch_limit_rejects_exactly_the_rollouts_that_stretch_beyond_it():
    """A population of a None action, lifts and drags: with max_stretch 0.2 (SoftGym's 1.2 x
    rest length) a stable rollout costs +inf and counts as infeasible iff its strain away from
    the grasp passed 0.2; without the limit only the verdict's unstable rollouts cost +inf."""
    box = ActionConstraint.table(0.3)
    particles = np.array([[NONE], [CORNER], [CORNER], [0], [0]])
    disp = np.array([[[0, 0, 0]], [[-0.02, 0.0, 0.01]], [[-0.3, -0.3, 0.0]], [[0.3, 0.3, 0.3]],
                     [[0.05, 0.0, 0.1]]])
    plain = _task(box)
    st = plain.rollout(particles, disp).stability
    stretched = (st.max_strain > 0.2) & ~st.unstable
    feasible_moves = (st.max_strain <= 0.2) & ~st.unstable & (particles[:, 0] != NONE)
    assert stretched.any() and feasible_moves.any()          # both kinds are in the population
    costs = plain.evaluate(particles, disp)
    assert np.array_equal(np.isinf(costs), st.unstable) and plain.n_infeasible == 0
    limited = _task(box, max_stretch=0.2)
    costs = limited.evaluate(particles, disp)
    assert np.array_equal(np.isinf(costs), st.unstable | stretched)
    assert limited.n_infeasible == int(stretched.sum())
    assert np.isfinite(costs[0])                               # holding nothing: feasible


def test_scripted_policy_places_inside_the_workspace():
    """A goal beyond the box: the scripted policy commands the projected displacement, so
    every action it takes is feasible from the state it was taken in."""
    box = ActionConstraint.table(0.2)
    task = _task(box)
    goal = task.positions(task.start_state).copy()
    goal[CORNER, 0] += 0.2                               # x 0.35: outside
    task.goal = goal
    res = scripted(task, [CORNER], ScriptedConfig(per_particle=1))
    x0 = task.positions(task.start_state)
    assert len(res.particles) == 1
    assert box.value(x0, res.particles[:1], res.displacements[:1])[0] <= 1e-12
    np.testing.assert_allclose(res.displacements[0, 0], box.high[0] - x0[CORNER, 0])


def test_settings_give_softgyms_workspace():
    s = PickPlaceSettings.preset("cloth", "diagonal")
    c = s.constraint()
    assert c.low == (-s.side, -s.side, 0.0) and c.high == (s.side, s.side, 0.5)
    assert PickPlaceSettings.preset("rope", "fold").constraint().high[0] == 0.5
    assert s.picker().workspace == c and s.picker().bound == (s.bound,) * 3


def test_a_trial_counts_the_rollouts_beyond_the_stretch_limit():
    """solve() with SoftGym's stretch limit: the rollouts CEM sampled beyond it are counted
    apart from the unstable ones; without a limit none is."""
    from planners.pick_place import solve

    s = replace(PickPlaceSettings.preset("cloth", "diagonal", quick=True),
                physics="fast")                                  # a sheet that stretches
    assert solve(s, "simple", seed=0).n_infeasible_rollouts == 0
    tight = solve(replace(s, max_stretch=0.2), "simple", seed=0)
    assert 0 < tight.n_infeasible_rollouts
    assert tight.n_infeasible_rollouts + tight.n_unstable_rollouts < tight.n_rollouts
