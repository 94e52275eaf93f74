"""The one registry of dopt.tasks: push tasks and pick scenes by name, unknown names named."""

import pytest

from dopt.tasks import PICK_SCENES, PUSH_TASKS, get_task, make_cloth, make_rope


def test_push_tasks_and_unknown_names():
    assert sorted(PUSH_TASKS) == ["clutter", "soft", "soft_rigid"]
    assert get_task("soft") is PUSH_TASKS["soft"]
    with pytest.raises(ValueError, match="known tasks: clutter, soft, soft_rigid"):
        get_task("cloth")


def test_pick_scenes():
    assert PICK_SCENES == {"cloth": make_cloth, "rope": make_rope}
