"""The paper's pick-and-place metrics: bipartite-matching distance (rope folding) and the
straightening error, against their definitions."""

import itertools

import numpy as np
import pytest

from dopt.tasks.pick.scene import matching_distance, mean_distance


@pytest.mark.parametrize("seed", range(5))
def test_matching_distance_is_the_mean_under_identity_and_ignores_goal_order(seed):
    rng = np.random.default_rng(seed)
    goal = rng.uniform(-0.3, 0.3, (30, 3))
    near = goal + rng.normal(0, 1e-3, goal.shape)        # close: identity is the best matching
    assert matching_distance(near, goal) == pytest.approx(mean_distance(near, goal))
    perm = rng.permutation(len(goal))
    shuffled = goal[perm]
    # the plain mean pays for the wrong correspondence; the matching does not
    assert mean_distance(near, shuffled) > matching_distance(near, shuffled)
    assert matching_distance(near, shuffled) == pytest.approx(matching_distance(near, goal))


def test_matching_distance_is_the_best_over_all_matchings():
    rng = np.random.default_rng(7)
    p, g = rng.normal(size=(6, 3)), rng.normal(size=(6, 3))
    brute = min(np.linalg.norm(p - g[list(perm)], axis=1).mean()
                for perm in itertools.permutations(range(6)))
    assert matching_distance(p, g) == pytest.approx(brute)
    assert matching_distance(p, g) <= mean_distance(p, g) + 1e-15


def test_matching_distance_rejects_mismatched_shapes():
    with pytest.raises(ValueError, match=r"\(N, 3\)"):
        matching_distance(np.zeros((4, 3)), np.zeros((5, 3)))


def test_rope_problems_report_the_papers_metrics():
    from planners.pick_place import PickPlaceSettings, make_problem

    straight = make_problem(PickPlaceSettings.preset("rope", "straighten", quick=True))
    assert straight.metric_names == ("final_cost", "end_to_end_ratio", "straighten_error")
    m = straight.metrics(straight.scene.initial_state)
    length = straight.settings.length
    assert m["straighten_error"] == pytest.approx(abs(m["end_to_end_ratio"] - 1) * length)
    fold = make_problem(PickPlaceSettings.preset("rope", "fold", quick=True))
    assert fold.metric_names == ("final_cost", "matching_distance")
    m = fold.metrics(fold.scene.initial_state)
    assert m["matching_distance"] <= m["final_cost"] + 1e-12
    cloth = make_problem(PickPlaceSettings.preset("cloth", "diagonal", quick=True))
    assert cloth.metric_names == ("final_cost",)
