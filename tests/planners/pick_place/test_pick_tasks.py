"""planners.pick_place.tasks: the pick tasks and goals are registered records, a goal is one
registration, and nothing in planners/ branches on a task's name."""

import re
from pathlib import Path

import numpy as np
import pytest

from planners.pick_place import (
    GOALS,
    PAPER_CHANGES,
    PAPER_PRESETS,
    PICK_TASKS,
    PRESETS,
    QUICK_CHANGES,
    PickGoal,
    PickPlaceSettings,
    Preset,
    cloth_sequence,
    make_problem,
    metric_names,
    pick_task,
    register_goal,
)

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture
def registry():
    """Registers into copies: the registries are as they were after the test."""
    goals = {name: dict(spec.goals) for name, spec in PICK_TASKS.items()}
    ours, paper = dict(PRESETS), dict(PAPER_PRESETS)
    yield
    for name, spec in PICK_TASKS.items():
        spec.goals.clear()
        spec.goals.update(goals[name])
    PRESETS.clear()
    PRESETS.update(ours)
    PAPER_PRESETS.clear()
    PAPER_PRESETS.update(paper)


def test_every_goal_has_its_presets_and_every_task_its_protocol_rows():
    assert dict(GOALS) == {"cloth": ("diagonal", "side", "reflective", "underneath"),
                           "rope": ("straighten", "fold")}
    assert set(PRESETS) == set(PAPER_PRESETS) == {(t, g) for t in GOALS for g in GOALS[t]}
    assert set(PAPER_CHANGES) == set(QUICK_CHANGES) == set(PICK_TASKS)
    assert [PICK_TASKS[t].n_particles(10) for t in ("cloth", "rope")] == [100, 10]
    assert metric_names("rope", "straighten") == ("final_cost", "end_to_end_ratio",
                                                  "straighten_error")
    assert metric_names("cloth", "side") == ("final_cost",)


def test_a_goal_is_one_registration(registry):
    register_goal("cloth", PickGoal("diagonal again", cloth_sequence("cloth_diagonal")),
                  Preset(8, 0.3, 2, 2, 8, 2))
    assert "diagonal again" in GOALS["cloth"]
    s = PickPlaceSettings.preset("cloth", "diagonal again")
    assert (s.n, s.cem.iterations) == (8, 2)
    paper = PickPlaceSettings.preset("cloth", "diagonal again", protocol="paper")
    assert (paper.n, paper.cem.iterations) == (20, 30)
    mine = make_problem(s)
    theirs = make_problem(PickPlaceSettings.preset("cloth", "diagonal", quick=True))
    assert [st.keys.tolist() for st in mine.stages] == [st.keys.tolist() for st in theirs.stages]
    np.testing.assert_array_equal(mine.final_goal, theirs.final_goal)
    with pytest.raises(ValueError, match="registered already"):
        register_goal("cloth", PickGoal("side", cloth_sequence("cloth_side")),
                      Preset(8, 0.3, 2, 2, 8, 2))
    with pytest.raises(ValueError, match="unknown task 'sheet'"):
        register_goal("sheet", PickGoal("x", cloth_sequence("cloth_side")),
                      Preset(8, 0.3, 2, 2, 8, 2))
    with pytest.raises(TypeError, match="preset must be a Preset"):
        register_goal("cloth", PickGoal("y", cloth_sequence("cloth_side")), {"n": 8})


@pytest.mark.parametrize("kwargs, error, match", [
    (dict(name="", stages=print), ValueError, "non-empty str"),
    (dict(name="x", stages=None), TypeError, "stages must be callable"),
    (dict(name="x", stages=print, start=3), TypeError, "start must be callable"),
    (dict(name="x", stages=print, metrics=("matching_distance",)), ValueError, "final_cost"),
    (dict(name="x", stages=print, metrics=("final_cost", "speed")), ValueError, "final_cost"),
])
def test_pick_goal_checks_its_fields(kwargs, error, match):
    with pytest.raises(error, match=match):
        PickGoal(**kwargs)


def test_unknown_names_are_value_errors():
    with pytest.raises(ValueError, match="unknown task 'Rope'; choose from cloth, rope"):
        pick_task("Rope")
    with pytest.raises(ValueError, match="unknown rope goal 'side'"):
        pick_task("rope").goal("side")


def test_no_module_of_planners_branches_on_a_pick_task_name():
    branch = re.compile(r"""\btask\s*[!=]=\s*["'](cloth|rope)["']""")
    hits = [f"{p.relative_to(ROOT)}:{i}" for p in sorted((ROOT / "planners").rglob("*.py"))
            for i, line in enumerate(p.read_text().splitlines(), 1) if branch.search(line)]
    assert hits == []
