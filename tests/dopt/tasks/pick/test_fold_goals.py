"""dopt.tasks.pick.fold_goals: cloth goals folded on the MuJoCo sheet by a line grasp."""
import numpy as np
import pytest

from deformables import ClothConfig
from deformables.cloth import cloth_key_particles
from deformables.goals import CLOTH_REFERENCE_KEYS, cloth_rest, grid_faces, make_goal
from dopt.tasks.pick.cloth_scene import ClothSceneConfig, make_cloth
from dopt.tasks.pick.fold_goals import Crease, _place, _turn_over, fold_goal, folds, ideal_folds

TASKS = tuple(CLOTH_REFERENCE_KEYS)


@pytest.mark.parametrize("n", [12, 21])
@pytest.mark.parametrize("task", TASKS)
def test_ideal_folds_give_the_reference_counts(task, n):
    """The creases' rigid folds are the paper's folds (the underneath one reflected): the
    reduction finds the paper's key count on them, on two triangulations."""
    rest = cloth_rest(n, 0.3)
    goal = ideal_folds(rest, folds(task, 0.3), 0.006)
    for triangulation in ("mujoco", "alternating"):
        keys = cloth_key_particles(goal, grid_faces(n, triangulation), rest_positions=rest)
        assert keys.n_keys == CLOTH_REFERENCE_KEYS[task], (triangulation, keys.n_keys)


def test_ideal_folds_preserve_lengths_away_from_creases_and_stack_layers():
    """Rigid turns: every edge away from a crease keeps its rest length, and the side fold's
    halves lie ``gap`` apart, the moving half on top."""
    n, side, gap = 16, 0.3, 0.006
    rest = cloth_rest(n, side)
    goal = ideal_folds(rest, folds("cloth_side", side), gap)
    faces = grid_faces(n, "mujoco")
    pairs = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [0, 2]]])
    same_side = (rest[pairs[:, 0], 0] > 0) == (rest[pairs[:, 1], 0] > 0)
    def length(p):
        return np.linalg.norm(p[pairs[:, 0]] - p[pairs[:, 1]], axis=1)

    np.testing.assert_allclose(length(goal)[same_side], length(rest)[same_side], atol=1e-12)
    top, bottom = rest[:, 0] > 0, rest[:, 0] < 0
    np.testing.assert_allclose(goal[top, 2], gap)
    np.testing.assert_allclose(goal[bottom, 2], 0.0)
    # the top half lands mirrored onto the bottom half
    np.testing.assert_allclose(np.sort(goal[top, 0]), np.sort(-rest[top, 0]), atol=1e-12)


def test_the_underneath_accordion_is_the_papers_underneath_fold_reflected():
    """Same layers in the same order: heights agree particle by particle with the paper's
    goal reflected in x about the stack's edge (x -> -side/2 - x); x differs only by the
    length the paper's rounded creases take (pi gap / 2 each)."""
    n, side, gap = 16, 0.3, 0.005
    mine = ideal_folds(cloth_rest(n, side), folds("cloth_underneath", side), gap)
    paper = make_goal("cloth_underneath", n=n, gap=gap).positions.copy()
    paper[:, 0] = -side / 2 - paper[:, 0]
    np.testing.assert_allclose(mine[:, 2], paper[:, 2], atol=0.05 * gap)
    assert np.abs(mine[:, 0] - paper[:, 0]).max() < 3 * np.pi * gap / 2
    np.testing.assert_allclose(mine[:, 1], paper[:, 1])


def test_a_turn_is_a_rotation_about_the_crease_line():
    rng = np.random.default_rng(3)
    p = rng.normal(size=(7, 3)) * 0.1
    crease = Crease((0.02, -0.01), (1.0, 2.0))
    turn = _place(crease, p, p, crease.distance(p) > 0, spacing=1.0)
    q = _turn_over(p, turn, 0.03, 0.7)
    d = np.linalg.norm(p[:, None] - p[None], axis=2)
    np.testing.assert_allclose(np.linalg.norm(q[:, None] - q[None], axis=2), d, atol=1e-12)
    # points on the turning line stay; a full turn is the identity; a half turn mirrors
    on_line = np.array([[*turn.point[:2], 0.03]]) + [[*(0.2 * turn.normal[1::-1] * [-1, 1]), 0]]
    np.testing.assert_allclose(_turn_over(on_line, turn, 0.03, 0.7), on_line, atol=1e-12)
    np.testing.assert_allclose(_turn_over(p, turn, 0.03, 2 * np.pi), p, atol=1e-12)
    half = _turn_over(p, turn, 0.03, np.pi)
    np.testing.assert_allclose(turn.distance(half), -turn.distance(p), atol=1e-12)
    np.testing.assert_allclose(half[:, 2], 0.06 - p[:, 2], atol=1e-12)


@pytest.fixture(scope="module")
def sheet16():
    return make_cloth(ClothSceneConfig(n=16, selfcollide=True))


@pytest.mark.parametrize("task", TASKS)
def test_simulated_folds_give_the_reference_counts(sheet16, task):
    """Issue #15's goals from physics, at 16 per side on the default sheet: each fold made by
    the line grasp lands within one grid spacing (mean) of its rigid fold, unflagged, and the
    reduction of the settled goal (flex triangles, settled flat start as rest) finds the
    paper's count under both panel modes."""
    scene = sheet16
    goal = fold_goal(scene, folds(task, 0.3))
    assert not goal.unstable, goal.reason
    rest = scene.positions(scene.initial_state)
    ideal = ideal_folds(rest, folds(task, 0.3), 2 * scene.radius)
    assert np.linalg.norm(goal.positions - ideal, axis=1).mean() < 0.3 / 15
    for config in (ClothConfig(), ClothConfig(panels="fold")):
        keys = cloth_key_particles(goal.positions, scene.elements, rest_positions=rest,
                                   config=config)
        assert keys.n_keys == CLOTH_REFERENCE_KEYS[task], (config.panels, keys.n_keys)
        assert keys.reached_threshold


def test_fold_goal_holds_the_far_edge(sheet16):
    held = fold_goal(sheet16, folds("cloth_side", 0.3), settle=0.0, speed=1.0).held
    rest = sheet16.positions(sheet16.initial_state)
    assert len(held) == 1
    np.testing.assert_allclose(np.sort(np.unique(np.round(rest[held[0], 0], 6))),
                               [0.13, 0.15], atol=1e-6)          # the last two rows


def test_bad_inputs(sheet16):
    with pytest.raises(ValueError, match="normal"):
        Crease((0, 0), (0, 0))
    with pytest.raises(ValueError, match="Crease.point"):
        Crease((0, np.nan), (1, 0))
    with pytest.raises(ValueError, match="no folds for task"):
        folds("cloth_twist", 0.3)
    with pytest.raises(ValueError, match="side"):
        folds("cloth_side", -1.0)
    with pytest.raises(TypeError, match="DeformableScene"):
        fold_goal(object(), folds("cloth_side", 0.3))
    with pytest.raises(TypeError, match="Crease"):
        fold_goal(sheet16, [])
    with pytest.raises(ValueError, match="speed"):
        fold_goal(sheet16, folds("cloth_side", 0.3), speed=0.0)
    with pytest.raises(ValueError, match="moves no particle"):
        fold_goal(sheet16, [Crease((1.0, 0.0), (1.0, 0.0))])
    with pytest.raises(ValueError, match="start"):
        fold_goal(sheet16, folds("cloth_side", 0.3), start=np.zeros(3))
    with pytest.raises(ValueError, match="MJCF"):
        fold_goal(replace_xml(sheet16), folds("cloth_side", 0.3))


def replace_xml(scene):
    """A shallow copy of ``scene`` without its MJCF."""
    import copy
    out = copy.copy(scene)
    out.xml = None
    return out

