"""Rope and cloth scenes with the picker: particle numbering, action encoding, bad actions,
grasp tracking, batched == loop, and a scripted diagonal fold."""

import re

import mujoco
import numpy as np
import pytest

from deformables.goals import cloth_diagonal, cloth_rest, grid_faces
from dopt.errors import UnstableRolloutError
from dopt.rollout import RolloutConfig, RolloutService
from dopt.tasks.pick.cloth_scene import ClothSceneConfig, cloth_xml, make_cloth
from dopt.tasks.pick.picker import CONTROL_SPEC, NONE, PickerConfig
from dopt.tasks.pick.rope_scene import RopeSceneConfig, make_rope
from dopt.tasks.pick.scene import PickPlaceTask, end_to_end, mean_distance
from planners.scripted import scripted

N_SIDE = 8


@pytest.fixture(scope="module")
def cloth():
    return make_cloth(ClothSceneConfig(n=N_SIDE))


@pytest.fixture(scope="module")
def rope():
    return make_rope(RopeSceneConfig(n=12, length=0.2))


def _task(scene, goal=None):
    goal = scene.positions(scene.initial_state) if goal is None else goal
    return PickPlaceTask(scene, goal, rollout=RolloutService(scene.scene, RolloutConfig(threads=1)))


def _xpos(scene, state):
    m = scene.model
    d = mujoco.MjData(m)
    mujoco.mj_setState(m, d, state, scene.scene.layout.spec)
    mujoco.mj_forward(m, d)
    return d.flexvert_xpos.copy()


@pytest.mark.parametrize("which", ["cloth", "rope"])
def test_positions_match_flexvert_xpos(which, cloth, rope):
    scene = cloth if which == "cloth" else rope
    assert np.array_equal(scene.positions(scene.initial_state), _xpos(scene, scene.initial_state))
    assert scene.positions(np.stack([scene.initial_state] * 2)).shape == (2, scene.n_particles, 3)


def test_cloth_numbering_matches_deformables(cloth):
    """Vertex i = ix * n + iy at x = -side/2 + ix * spacing, as in deformables.goals."""
    p = cloth.positions(cloth.initial_state)
    assert np.allclose(p[:, :2], cloth_rest(N_SIDE, 0.3)[:, :2], atol=2e-3)
    assert np.allclose(p[:, 2], cloth.radius, atol=1e-3)


def test_elements_are_the_flex_triangles_and_segments(cloth, rope):
    """scene.elements: the cloth's triangles are those of deformables' triangulation of the
    same name (each a set of particle indices), the rope's segments join consecutive
    particles."""
    goal = cloth_diagonal(N_SIDE, triangulation=ClothSceneConfig().triangulation)
    assert cloth.elements.shape == goal.faces.shape
    assert {frozenset(f) for f in cloth.elements.tolist()} == \
        {frozenset(f) for f in goal.faces.tolist()}
    assert sorted(map(sorted, rope.elements.tolist())) == [[i, i + 1] for i in range(11)]


def test_rope_rests_straight_along_x(rope):
    p = rope.positions(rope.initial_state)
    assert np.allclose(p[:, 0], np.linspace(-0.1, 0.1, 12), atol=1e-3)
    assert end_to_end(p) == pytest.approx(0.2, abs=2e-3)


@pytest.mark.parametrize("P", [1, 3])
def test_action_encoding_round_trips(cloth, P):
    picker = cloth.picker
    rng = np.random.default_rng(P)
    H = 2
    particles = rng.integers(-1, cloth.n_particles, (P, H))
    particles[0, 0] = NONE
    disp = rng.uniform(-1, 1, (P, H, 3)) * picker.bound
    U = picker.encode(particles, disp)
    assert U.shape == (P, H * picker.steps_per_action, picker.ncontrol)
    back_p, back_d = picker.decode(U)
    assert np.array_equal(back_p, particles)
    expected = np.where((particles == NONE)[..., None], 0.0, disp)
    assert np.allclose(back_d, expected, atol=1e-12)


def test_encoding_keeps_rope_edge_equality_on(rope):
    """Control rows overwrite every eq_active entry: the flex's own equality stays 1."""
    U = rope.picker.encode([[3, NONE]], np.zeros((1, 2, 3)))
    flex_eq = [e for e in range(rope.model.neq)
               if rope.model.eq_type[e] == mujoco.mjtEq.mjEQ_FLEX]
    assert flex_eq
    col = rope.model.nu + flex_eq[0]
    assert np.all(U[0, :, col] == 1.0)


@pytest.mark.parametrize("particles, disp, match", [
    ([[64]], [[[0.0, 0.0, 0.0]]], "out of range"),
    ([[-2]], [[[0.0, 0.0, 0.0]]], "out of range"),
    ([[3]], [[[np.nan, 0.0, 0.0]]], "not finite"),
    ([[3]], [[[0.0, 0.31, 0.0]]], "beyond the bound"),
    ([[3, 4]], [[[0.0, 0.0, 0.0]]], "do not match"),
    ([[1.5]], [[[0.0, 0.0, 0.0]]], "integers"),
])
def test_bad_actions_raise(cloth, particles, disp, match):
    task = _task(cloth)
    with pytest.raises(ValueError, match=match):
        task.evaluate(np.array(particles), np.array(disp))


def test_unpickable_particle_raises():
    scene = make_cloth(ClothSceneConfig(n=4), pickable=[0, 15])
    assert scene.picker.pickable.tolist() == [0, 15]
    with pytest.raises(ValueError, match="no grasp equality"):
        scene.picker.encode([[5]], np.zeros((1, 1, 3)))


@pytest.mark.parametrize("make, config", [
    (make_cloth, ClothSceneConfig(n=N_SIDE, timestep=0.02)),
    (make_cloth, ClothSceneConfig(n=N_SIDE, timestep=0.01)),
    (make_cloth, ClothSceneConfig(n=N_SIDE, timestep=0.005)),
    (make_rope, RopeSceneConfig(n=12, length=0.2, timestep=0.02)),
    (make_rope, RopeSceneConfig(n=12, length=0.2, timestep=0.01)),
    (make_rope, RopeSceneConfig(n=12, length=0.2, timestep=0.005)),
])
def test_snap_brings_the_picker_to_the_particle_at_every_dt(make, config):
    """Snap and hold move the picker onto the grasped particle, not the particle up to the
    picker: at the end of the hold the particle is within 2 mm of where it rested."""
    scene = make(config)
    pk, i = scene.picker, scene.n_particles - 1
    U = pk.encode(np.array([[i]]), np.zeros((1, 1, 3)))[0]
    m = scene.model
    d = mujoco.MjData(m)
    mujoco.mj_setState(m, d, scene.initial_state, mujoco.mjtState.mjSTATE_INTEGRATION)
    for u in U[:pk.snap_steps + pk.hold_steps]:
        mujoco.mj_setState(m, d, u, CONTROL_SPEC)
        mujoco.mj_step(m, d)
    state = np.empty(mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_INTEGRATION))
    mujoco.mj_getState(m, d, state, mujoco.mjtState.mjSTATE_INTEGRATION)
    moved = scene.positions(state)[i] - scene.positions(scene.initial_state)[i]
    assert np.linalg.norm(moved) < 0.002, moved


def test_grasped_particle_follows_displacement():
    """An in-plane drag of a corner lands it at p0 + d (within the soft sheet's pull-back)."""
    cloth = make_cloth(ClothSceneConfig.physics("fast", n=N_SIDE))
    task = _task(cloth)
    corner = cloth.n_particles - 1
    d = np.array([-0.1, -0.05, 0.0])
    final = task.execute([corner], d[None]).state
    p0 = cloth.positions(cloth.initial_state)[corner]
    assert np.linalg.norm(cloth.positions(final)[corner] - (p0 + d)) < 0.01


def test_none_action_leaves_cloth_at_rest(cloth):
    task = _task(cloth)
    final = task.execute([NONE], np.zeros((1, 3))).state
    assert mean_distance(cloth.positions(final), cloth.positions(cloth.initial_state)) < 1e-3


def test_batched_rollout_equals_step_loop(rope):
    """One batched call == mj_setState(control row) + mj_step per step, bit for bit."""
    task = _task(rope)
    particles = np.array([[0, NONE], [11, 5]])
    disp = np.array([[[0.05, 0.02, 0.03], [0, 0, 0]], [[-0.1, 0.1, 0.0], [0.0, -0.05, 0.02]]])
    finals = task.rollout(particles, disp).final_states
    U = rope.picker.encode(particles, disp)
    m = rope.model
    for k in range(2):
        d = mujoco.MjData(m)
        mujoco.mj_setState(m, d, rope.initial_state, rope.scene.layout.spec)
        for row in U[k]:
            mujoco.mj_setState(m, d, row, CONTROL_SPEC)
            mujoco.mj_step(m, d)
        assert np.array_equal(rope.scene.state_of(d), finals[k])


def test_task_costs_eq2(cloth):
    task = _task(cloth)
    costs = task.evaluate(np.array([[NONE], [0]]), np.array([[[0, 0, 0]], [[0.1, 0, 0]]]))
    assert costs.shape == (2,)
    assert costs[0] < 1e-3 < costs[1]


def test_unstable_rollout_costs_inf_and_is_counted():
    """An absurd gravity blows the simulation up: +inf cost and a count, not NaN costs; with
    on_unstable="raise" the rollout service's error."""
    scene = make_rope(RopeSceneConfig(n=6, length=0.1))
    scene.model.opt.gravity[:] = (0.0, 0.0, -1e12)
    task = _task(scene)
    costs = task.evaluate(np.array([[2], [3]]), np.array([[[0.1, 0.1, 0.1]]] * 2))
    assert np.isposinf(costs).all() and task.n_unstable == 2 and task.n_evaluated == 2
    done = task.execute([2], [[0.1, 0.1, 0.1]])
    assert done.unstable and done.reason
    strict = PickPlaceTask(scene, task.goal, rollout=RolloutService(
        scene.scene, RolloutConfig(threads=1, on_unstable="raise")))
    with pytest.raises(UnstableRolloutError):
        strict.evaluate(np.array([[2]]), np.array([[[0.1, 0.1, 0.1]]]))


def test_scripted_diagonal_fold_reaches_goal():
    """Scripted fold (far corner above its goal, release) on the soft 10x10 sheet (fast preset):
    the mean particle distance to the ideal fold drops from 70 mm to below 25 mm."""
    n = 10
    scene = make_cloth(ClothSceneConfig.physics("fast", n=n), PickerConfig(bound=(0.3, 0.3, 0.3)))
    goal = cloth_diagonal(n=n).positions + np.array([0.0, 0.0, scene.radius])
    task = _task(scene, goal)
    assert task.cost(scene.initial_state) > 0.06
    res = scripted(task, [0, n - 1, n * n - n, n * n - 1])
    assert res.particles.tolist() == [n * n - 1]          # only the far corner moves
    assert res.cost < 0.025


@pytest.mark.parametrize("triangulation", ["mujoco", "anti", "alternating"])
def test_cloth_triangles_are_deformables_grid_faces(triangulation):
    """The scene's triangles are deformables.goals.grid_faces of the same name (the key
    particles' goals), counter-clockwise; "mujoco" compiles to MuJoCo's own grid flexcomp."""
    n = 5
    xml = cloth_xml(ClothSceneConfig(n=n, triangulation=triangulation))
    tri = mujoco.MjModel.from_xml_string(xml).flex_elem.reshape(-1, 3)
    assert {frozenset(f) for f in tri.tolist()} == \
        {frozenset(f) for f in grid_faces(n, triangulation).tolist()}
    p = np.stack(np.divmod(np.arange(n * n), n), axis=1).astype(float)     # (ix, iy)
    e1, e2 = p[tri[:, 1]] - p[tri[:, 0]], p[tri[:, 2]] - p[tri[:, 0]]
    np.testing.assert_allclose(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0], 1.0)  # 2 x area
    if triangulation == "mujoco":
        sp = ClothSceneConfig(n=n).spacing
        grid = re.sub(r'type="direct" dim="2"\s*point="[^"]*" element="[^"]*"',
                      f'type="grid" dim="2" count="{n} {n} 1" spacing="{sp} {sp} {sp}"', xml)
        assert grid != xml
        np.testing.assert_array_equal(mujoco.MjModel.from_xml_string(grid).flex_elem,
                                      tri.ravel())


def test_a_sheet_without_bending_keeps_its_stretch_stiffness():
    """``bending=False`` (elastic2d "stretch", the ``fast`` preset): MuJoCo compiles no bending
    coefficients and the same membrane stiffness as the bending sheet."""
    both, stretch = (mujoco.MjModel.from_xml_string(cloth_xml(ClothSceneConfig(n=6, bending=b)))
                     for b in (True, False))
    assert np.abs(both.flex_bending).sum() > 0
    assert np.abs(stretch.flex_bending).sum() == 0
    np.testing.assert_array_equal(stretch.flex_stiffness, both.flex_stiffness)
    assert ClothSceneConfig.physics("fast").bending is False
    assert ClothSceneConfig.physics("default").bending is True


@pytest.mark.parametrize("scene", [lambda mode: make_cloth(ClothSceneConfig(n=4, selfcollide=mode)),
                                   lambda mode: make_rope(RopeSceneConfig(n=4, selfcollide=mode))],
                         ids=["cloth", "rope"])
@pytest.mark.parametrize("mode", [False, True, "none", "narrow", "bvh", "sap", "auto"])
def test_selfcollide_compiles_to_mujocos_midphase(scene, mode):
    """False / True are MuJoCo's "none" / "auto"; a name is MuJoCo's own midphase."""
    name = {False: "none", True: "auto"}.get(mode, mode)
    expected = getattr(mujoco.mjtFlexSelf, f"mjFLEXSELF_{name.upper()}")
    assert scene(mode).model.flex_selfcollide[0] == int(expected)


def test_passive_contact_takes_the_floor_off_the_solver():
    """With passive flex contact the settled sheet rests on the floor by MuJoCo's penalty
    force: its floor contacts are found but have no constraint rows; without it every floor
    contact is a constraint. Either way no particle sinks below the floor."""
    for passive in (False, True):
        scene = make_cloth(ClothSceneConfig(n=6, passive=passive))
        assert scene.model.flex_passive[0] == passive
        d = mujoco.MjData(scene.model)
        mujoco.mj_setState(scene.model, d, scene.initial_state, scene.scene.layout.spec)
        mujoco.mj_forward(scene.model, d)
        assert d.ncon > 0
        rows = d.contact.efc_address[:d.ncon]
        assert (rows == -1).all() if passive else (rows >= 0).all()
        assert scene.positions(scene.initial_state)[:, 2].min() > 0
