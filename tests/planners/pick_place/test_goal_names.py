"""The one goal-name table (planners.pick_place.GOAL_NAMES): every registered pick goal has its
row, every row's shape is a deformables goal, and the panels are the ones the committed
key-particle page prints (docs/KEY-PARTICLES.md, generated from the results)."""

from pathlib import Path

import pytest

from deformables.goals import GOALS
from planners.pick_place import GOAL_NAMES, PICK_TASKS, goal_name

PAGE = Path(__file__).resolve().parents[3] / "docs" / "KEY-PARTICLES.md"


def test_every_registered_goal_has_one_row_and_every_shape_exists():
    registered = [(task, goal) for task, spec in PICK_TASKS.items() for goal in spec.goals]
    rows = [(r.task, r.goal) for r in GOAL_NAMES]
    assert len(set(rows)) == len(rows) and len({r.shape for r in GOAL_NAMES}) == len(rows)
    assert set(registered) <= set(rows)
    for row in GOAL_NAMES:
        assert row.shape in GOALS
        assert row.shape.startswith(f"{row.task}_")
        assert goal_name(row.task, row.goal) is row


def test_the_panels_are_fig7s_in_order_and_printed_on_the_page():
    assert [r.panel for r in GOAL_NAMES] == ["(a)", "(b)", "(c)", "(d)", "(e)", "(f)"]
    page = PAGE.read_text()
    for row in GOAL_NAMES:
        assert row.label == f"{row.panel} {row.title}"
        assert row.label in page, row.label


def test_an_unknown_goal_is_named():
    with pytest.raises(ValueError, match="no goal 'twist' of task 'cloth'.*cloth/diagonal"):
        goal_name("cloth", "twist")
