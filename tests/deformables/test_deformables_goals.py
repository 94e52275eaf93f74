"""Goal generators: shapes, isometry of the folds, MuJoCo's grid numbering, the registry."""
import numpy as np
import pytest

from deformables import goals

CLOTH_TASKS = ["cloth_flat", "cloth_diagonal", "cloth_side", "cloth_reflective",
               "cloth_underneath"]


def _edge_lengths(positions, faces):
    e = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    return np.linalg.norm(positions[e[:, 0]] - positions[e[:, 1]], axis=1)


def test_grid_faces_match_mujoco_flexcomp_numbering():
    # faces printed by MuJoCo 4 for <flexcomp type="grid" dim="2" count="4 4 1">
    mujoco_faces = np.array([[0, 4, 5], [0, 5, 1], [1, 5, 6], [1, 6, 2], [2, 6, 7], [2, 7, 3],
                             [4, 8, 9], [4, 9, 5], [5, 9, 10], [5, 10, 6], [6, 10, 11],
                             [6, 11, 7], [8, 12, 13], [8, 13, 9], [9, 13, 14], [9, 14, 10],
                             [10, 14, 15], [10, 15, 11]])
    np.testing.assert_array_equal(goals.grid_faces(4, "mujoco"), mujoco_faces)
    rest = goals.cloth_rest(4, 0.3)
    np.testing.assert_allclose(rest[1], [-0.15, -0.05, 0.0])      # y fastest
    np.testing.assert_allclose(rest[4], [-0.05, -0.15, 0.0])


@pytest.mark.parametrize("triangulation", goals.TRIANGULATIONS)
def test_triangulations_cover_the_square_counter_clockwise(triangulation):
    n = 6
    faces = goals.grid_faces(n, triangulation, np.random.default_rng(0))
    rest = goals.cloth_rest(n, 0.3)
    a, b, c = (rest[faces[:, k]] for k in range(3))
    signed = 0.5 * np.cross(b - a, c - a)[:, 2]
    assert faces.shape == (2 * (n - 1) ** 2, 3)
    assert np.all(signed > 0)
    assert np.isclose(signed.sum(), 0.3 * 0.3)


@pytest.mark.parametrize("name", CLOTH_TASKS)
def test_cloth_folds_are_isometric_away_from_creases_and_layers_do_not_touch(name):
    g = goals.make_goal(name, n=21)
    rest_len = _edge_lengths(g.rest_positions, g.faces)
    goal_len = _edge_lengths(g.positions, g.faces)
    assert np.all(goal_len <= rest_len + 1e-12)          # folding never stretches an edge
    kept = np.isclose(goal_len, rest_len, rtol=1e-9).mean()
    assert kept > 0.85                                    # only edges across a crease shorten
    # distinct particles never coincide: layers sit a gap apart
    d = np.linalg.norm(g.positions[:, None] - g.positions[None], axis=2)
    np.fill_diagonal(d, np.inf)
    assert d.min() > 0.25 * goals.CLOTH_LAYER_GAP


@pytest.mark.parametrize("name, layers", [("cloth_flat", 1), ("cloth_diagonal", 2),
                                          ("cloth_side", 2), ("cloth_reflective", 3),
                                          ("cloth_underneath", 4)])
def test_cloth_fold_layer_count(name, layers):
    g = goals.make_goal(name, n=21)
    z_levels = np.unique(np.round(g.positions[:, 2] / g.layer_gap, 6))
    flat_levels = [z for z in z_levels if np.isclose(z, np.round(z))]
    assert len(flat_levels) == layers


def test_rope_goals_have_even_spacing_and_corner_indices():
    for name in ["rope_straighten", "rope_fold", "rope_fold_unequal"]:
        g = goals.make_goal(name)
        steps = np.linalg.norm(np.diff(g.positions[:, :2], axis=0), axis=1)
        assert g.positions.shape == (goals.ROPE_PARTICLES, 3)
        assert np.isclose(steps.sum(), goals.ROPE_LENGTH, rtol=0.02)
        assert g.corners[0] == 0 and g.corners[-1] == goals.ROPE_PARTICLES - 1
    fold = goals.make_goal("rope_fold")
    np.testing.assert_array_equal(fold.corners, [0, 13, 26, 39])
    # the last leg crosses over the first one: lifted by a rope diameter there
    assert fold.positions[:, 2].max() > goals.ROPE_RADIUS * 2.5


def test_rope_crumpled_uses_the_generator():
    a = goals.rope_crumpled(np.random.default_rng(3))
    b = goals.rope_crumpled(np.random.default_rng(3))
    c = goals.rope_crumpled(np.random.default_rng(4))
    np.testing.assert_array_equal(a.positions, b.positions)
    assert not np.allclose(a.positions, c.positions)


def test_goal_sequences_end_with_the_task():
    seq = goals.goal_sequence("cloth_underneath", n=9)
    assert [g.name for g in seq] == ["cloth_side", "cloth_reflective", "cloth_underneath"]
    assert [g.name for g in goals.goal_sequence("cloth_diagonal", n=9)] == ["cloth_diagonal"]


def test_bad_goal_arguments_raise():
    with pytest.raises(ValueError, match="unknown goal"):
        goals.make_goal("cloth_origami")
    with pytest.raises(ValueError, match="triangulation"):
        goals.grid_faces(5, "zigzag")
    with pytest.raises(ValueError, match="rng"):
        goals.grid_faces(5, "random")
    with pytest.raises(ValueError, match="at least 3"):
        goals.rope_straight(n=2)
    with pytest.raises(ValueError, match="crossed triangle"):
        goals.rope_crossed_triangle(legs=(1.0, 5.0, 0.2))
