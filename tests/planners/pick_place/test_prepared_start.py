"""The multi-layer folds from a prepared start (``PickPlaceSettings.fold_start``): the fold before
the last dropped in place as the paper's authors prepare it, and only the last planned; the
paper protocol's default, the chained start an option that keeps the committed trials' keys.

The prepared start is checked against the previous fold's goal as ``deformables.goals`` draws
it (the analytic shape, not the drop), within ``MEAN_TOLERANCE`` (measured on the paper
preset's 20 x 20 sheet: 1.9 mm from the side goal, 2.4 mm from the reflective goal; the
layers rest a contact gap, 2 radii = 7.9 mm, apart where the goal stacks them 5 mm apart) and
every particle within ``MAX_TOLERANCE`` (measured 9.0 and 8.7 mm, at the creases)."""

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from deformables.cloth import cloth_key_particles
from deformables.goals import ClothGoal, goal_sequence, lift_layers, make_goal
from dopt.errors import UnstableRolloutError
from dopt.lab.trialpack import stored_trials
from planners.cem import CEMConfig
from planners.pick_place import (
    GOALS,
    PREPARED_LIFT,
    PREPARED_SETTLE,
    PickPlaceSettings,
    legacy_trial_key,
    make_problem,
    solve,
    trial_key,
)

ROOT = Path(__file__).resolve().parents[3]
#: the prepared start's mean particle distance to the previous fold's goal (m)
MEAN_TOLERANCE = 0.003
#: its largest particle distance to that goal (m)
MAX_TOLERANCE = 0.012
MULTI = ("reflective", "underneath")


def _paper(goal: str, **fields) -> PickPlaceSettings:
    return replace(PickPlaceSettings.preset("cloth", goal, protocol="paper"), threads=1,
                   **fields)


@pytest.fixture(scope="module", params=MULTI)
def prepared(request):
    s = _paper(request.param)
    return s, make_problem(s, 0)


def test_the_prepared_start_reproduces_the_previous_folds_goal(prepared):
    s, problem = prepared
    sequence = goal_sequence(f"cloth_{s.goal}", n=s.n, side=s.side)
    lift = np.array([0.0, 0.0, problem.scene.radius])          # the cloth rests at z = radius
    previous = sequence[-2].positions + lift
    p = problem.scene.positions(problem.start_state)
    distance = np.linalg.norm(p - previous, axis=1)
    assert distance.mean() < MEAN_TOLERANCE, distance.mean()
    assert distance.max() < MAX_TOLERANCE, distance.max()
    # the layers land in their order: each one's mean height above the one below it
    layer = np.round(sequence[-2].positions[:, 2] / sequence[-2].layer_gap).astype(int)
    heights = [p[layer == k, 2].mean() for k in range(layer.max() + 1)]
    assert np.all(np.diff(heights) > problem.scene.radius), heights


def test_only_the_last_stage_is_planned_with_the_final_goals_keys(prepared):
    s, problem = prepared
    final = make_goal(f"cloth_{s.goal}", n=s.n, side=s.side)
    assert [st.name for st in problem.stages] == [f"cloth_{s.goal}"]
    keys = cloth_key_particles(final.positions, final.faces,
                               rest_positions=final.rest_positions).indices
    np.testing.assert_array_equal(problem.stages[0].keys, keys)
    np.testing.assert_allclose(problem.final_goal[:, :2], final.positions[:, :2])
    chained = make_problem(replace(s, fold_start="chained"), 0)
    assert [st.name for st in chained.stages] == [
        g.name for g in goal_sequence(f"cloth_{s.goal}", n=s.n, side=s.side)]
    np.testing.assert_array_equal(chained.start_state, problem.scene.initial_state)


def test_a_reflective_trial_plans_one_stage_from_the_prepared_start():
    """A whole (tiny) CEM trial: one stage's iterations, one stage's actions, its cost the
    final metric."""
    s = _paper("reflective", bound=0.02,
               cem=CEMConfig(horizon=1, iterations=2, population=2, elites=1))
    result = solve(s, "simple", 0)
    assert result.stage_of_iteration == [0, 0]
    assert [a["stage"] for a in result.actions] == ["cloth_reflective"]
    assert len(result.stage_costs) == 1
    assert result.metrics["final_cost"] == pytest.approx(result.stage_costs[0])
    assert not result.unstable


def test_the_paper_protocol_prepares_and_the_chained_start_keeps_its_trials():
    for goal in GOALS["cloth"]:
        paper = PickPlaceSettings.preset("cloth", goal, protocol="paper")
        assert paper.fold_start == ("prepared" if goal in MULTI else None)
        assert PickPlaceSettings.preset("cloth", goal).fold_start is None
        assert PickPlaceSettings.preset("cloth", goal, quick=True,
                                        protocol="paper").fold_start is None
        assert PickPlaceSettings.from_dict(paper.to_dict()) == paper
    reflective = PickPlaceSettings.preset("cloth", "reflective", protocol="paper")
    chained = replace(reflective, fold_start="chained")
    assert chained.fold_start is None and "fold_start" not in chained.to_dict()
    assert chained.departures("paper") == {"fold_start": "chained"}
    assert reflective.departures("paper") == {}
    assert trial_key("simple", 0, chained) != trial_key("simple", 0, reflective)
    assert "prepared_start" not in chained.identity()["resolved"]
    assert reflective.identity()["resolved"]["prepared_start"] == {"lift": PREPARED_LIFT,
                                                                   "settle": PREPARED_SETTLE}
    # a goal of one stage: "prepared" is its one start, the same trial
    diagonal = PickPlaceSettings.preset("cloth", "diagonal", protocol="paper")
    assert replace(diagonal, fold_start="prepared") == diagonal
    with pytest.raises(ValueError, match="fold_start"):
        replace(diagonal, fold_start="teleported")


@pytest.mark.parametrize("goal", MULTI)
def test_the_committed_trials_keep_their_keys(goal):
    """A chained trial (written before ``fold_start``) parses to ``fold_start=None`` and keeps
    its legacy name; a prepared-start trial of the same folder is named by ``trial_key``."""
    folder = ROOT / "docs" / "results" / "runs" / f"fig7-cloth-{goal}" / "trials"
    trials = stored_trials(folder)
    if not trials:
        pytest.skip(f"no committed trials under {folder}")
    for t in trials:
        record = json.loads(t.read_text())
        p = record["params"]
        settings = PickPlaceSettings.from_dict(p["settings"])
        assert settings.fold_start in (None, "prepared"), (t.name, settings.fold_start)
        name = legacy_trial_key if settings.fold_start is None else trial_key
        assert name(p["method"], p["seed"], settings) == record["key"], t.name


def test_lift_layers_raises_each_layer_its_lift_per_gap():
    """The side fold's top half (away from the crease) lies one gap up, so it rises one lift;
    the bottom half stays; the reflective fold's top layer rises two lifts."""
    side = make_goal("cloth_side", n=12)
    lifted = lift_layers(side, 0.01)
    rest = side.rest_positions
    far = rest[:, 0] > 0.05
    np.testing.assert_allclose(lifted[far, 2] - side.positions[far, 2], 0.01)
    np.testing.assert_allclose(lifted[rest[:, 0] < 0, 2], side.positions[rest[:, 0] < 0, 2])
    np.testing.assert_allclose(lifted[:, :2], side.positions[:, :2])
    reflective = make_goal("cloth_reflective", n=12)
    top = reflective.rest_positions[:, 0] > 0.3 / 4 + 0.02
    np.testing.assert_allclose(lift_layers(reflective, 0.01)[top, 2]
                               - reflective.positions[top, 2], 0.02)
    np.testing.assert_array_equal(lift_layers(side, 0.0), side.positions)
    with pytest.raises(TypeError, match="ClothGoal"):
        lift_layers(side.positions, 0.01)
    with pytest.raises(ValueError, match="lift"):
        lift_layers(side, -0.01)
    assert isinstance(side, ClothGoal)


def test_a_prepared_start_that_blows_up_is_an_error_not_a_start():
    """The quick preset's 8 x 8 sheet: its creases fall between rows 4 cm apart, and its drop
    breaks the strain bound (measured 0.65 > 0.5)."""
    s = _paper("underneath", n=8)
    with pytest.raises(UnstableRolloutError, match="prepared start"):
        make_problem(s, 0)
