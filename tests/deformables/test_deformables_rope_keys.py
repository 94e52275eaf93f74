"""Rope key particles against the paper's reference counts (Sec. IV-C.1, Fig. 4a-b)."""
import logging

import numpy as np
import pytest

from deformables import RopeConfig, goals, rope_key_particles
from deformables.rope import correspondence


def _assert_corners(result, corners, tolerance=1):
    assert len(result.indices) == len(corners)
    assert np.all(np.abs(result.indices - corners) <= tolerance), (result.indices, corners)


def test_straight_rope_gives_its_two_ends():
    result = rope_key_particles(goals.rope_straight().positions)
    np.testing.assert_array_equal(result.indices, [0, 39])
    assert result.n_elements == 1
    np.testing.assert_array_equal(result.sizes, [2])
    assert result.errors[0] < 1e-9
    assert result.vertices.shape == (2, 3)


@pytest.mark.parametrize("legs", [(1.0, 1.0, 1.0), (1.0, 1.3, 1.6), (1.4, 1.0, 1.2)])
def test_crossed_triangle_gives_its_four_corners(legs):
    goal = goals.rope_crossed_triangle(legs=legs)
    result = rope_key_particles(goal.positions)
    _assert_corners(result, goal.corners)
    assert result.n_elements == 3
    np.testing.assert_array_equal(result.sizes, [2, 3, 4])
    assert result.errors[-1] < result.threshold <= result.errors[-2]


def test_fixed_parametrisation_misses_unequal_corners_that_breakpoints_find():
    equal = goals.rope_crossed_triangle()
    unequal = goals.rope_crossed_triangle(legs=(1.0, 1.3, 1.6))
    fixed = RopeConfig(fit="fixed")
    _assert_corners(rope_key_particles(equal.positions, config=fixed), equal.corners)
    miss = rope_key_particles(unequal.positions, config=fixed)
    assert miss.n_elements > 3                 # needs more segments and lands off the corners
    assert not (len(miss.indices) == 4 and np.all(np.abs(miss.indices - unequal.corners) <= 1))
    _assert_corners(rope_key_particles(unequal.positions), unequal.corners)


def test_qp_matches_the_least_squares_solution():
    goal = goals.rope_crumpled(np.random.default_rng(0))
    result = rope_key_particles(goal.positions, threshold=0.02, config=RopeConfig(fit="fixed"))
    p = goal.positions
    arc = np.concatenate([[0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
    t = np.linspace(0, arc[-1], 100)
    q = np.stack([np.interp(t, arc, p[:, d]) for d in range(3)], axis=1)
    a = correspondence(t, np.linspace(0, arc[-1], len(result.vertices)))
    reference = np.linalg.lstsq(a, q, rcond=None)[0]
    np.testing.assert_allclose(result.vertices, reference, atol=1e-6)
    assert np.isclose(result.error, np.mean(np.linalg.norm(a @ reference - q, axis=1)), atol=1e-7)


@pytest.mark.parametrize("n", [20, 40, 80])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_counts_hold_under_2mm_noise_at_any_resolution(n, seed):
    rng = np.random.default_rng(seed)
    for goal in [goals.rope_straight(n=n), goals.rope_crossed_triangle(n=n),
                 goals.rope_crossed_triangle(n=n, legs=(1.0, 1.3, 1.6))]:
        noisy = goal.positions + rng.normal(0.0, 0.002, goal.positions.shape)
        _assert_corners(rope_key_particles(noisy), goal.corners)


def test_threshold_in_metres_or_spacings():
    goal = goals.rope_crumpled(np.random.default_rng(1))
    spacing = np.median(np.linalg.norm(np.diff(goal.positions, axis=0), axis=1))
    by_metres = rope_key_particles(goal.positions, threshold=0.5 * spacing)
    by_spacing = rope_key_particles(goal.positions)
    assert np.isclose(by_metres.threshold, by_spacing.threshold)
    np.testing.assert_array_equal(by_metres.indices, by_spacing.indices)
    tighter = rope_key_particles(goal.positions, threshold=0.1 * spacing)
    assert tighter.n_elements > by_spacing.n_elements


@pytest.mark.parametrize("positions, message", [
    (np.full((40, 3), np.nan), "NaN"),
    (np.array([[0, 0, 0], [1, 0, np.inf], [2, 0, 0]], float), "NaN or inf"),
    (np.zeros((2, 3)), "at least 3"),
    (np.zeros((40, 3)), "zero extent"),
    (np.zeros((40, 2)), "shape"),
])
def test_bad_rope_input_raises(positions, message):
    with pytest.raises(ValueError, match=message):
        rope_key_particles(positions)


def test_unreachable_threshold_gives_the_best_model_flagged_or_raises_when_strict(caplog):
    goal = goals.rope_crumpled(np.random.default_rng(0))
    with caplog.at_level(logging.WARNING, logger="deformables.reduction"):
        best = rope_key_particles(goal.positions, threshold=1e-6,
                                  config=RopeConfig(fit="fixed", max_vertices=6))
    assert "never fell below the threshold 1e-06" in caplog.text
    assert not best.reached_threshold
    assert best.error == best.errors.min() > best.threshold
    assert best.n_elements + 1 == best.sizes[best.errors.argmin()]
    assert len(best.vertices) == best.n_elements + 1
    with pytest.raises(ValueError, match="never fell below"):
        rope_key_particles(goal.positions, threshold=1e-6,
                           config=RopeConfig(fit="fixed", max_vertices=6, strict=True))
    assert rope_key_particles(goal.positions).reached_threshold


def test_bad_options_raise():
    goal = goals.rope_crumpled(np.random.default_rng(0))
    with pytest.raises(ValueError, match="positive"):
        rope_key_particles(goal.positions, threshold=0.0)
    with pytest.raises(ValueError, match="unknown rope fit"):
        RopeConfig(fit="spline")


def test_rope_reports_no_layer_gap():
    from deformables import rope_key_particles
    from deformables.goals import make_goal

    g = make_goal("rope_fold", n=40)
    assert rope_key_particles(g.positions).layer_gap is None
