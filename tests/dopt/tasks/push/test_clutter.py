"""Clutter layouts: non-overlapping, the goal cylinder between pusher and goal, built as drawn."""

import math

import mujoco
import numpy as np
import pytest

from dopt.tasks.panda import TOOL_RADIUS
from dopt.tasks.push.clutter import (
    CYLINDER_HALF_HEIGHT,
    CYLINDER_RADIUS,
    DISTRACTORS,
    GOAL_CYLINDER,
    MIN_GAP,
    STANDOFF,
    build_clutter,
    sample_layout,
)


@pytest.mark.parametrize("seed", range(20))
def test_layout_keeps_everything_apart_and_on_the_pushing_line(seed):
    layout = sample_layout(np.random.default_rng(seed))
    cylinders = np.vstack([layout.goal_cylinder, layout.distractors])
    assert cylinders.shape == (1 + len(DISTRACTORS), 2)
    gaps = np.linalg.norm(cylinders[:, None] - cylinders[None], axis=-1) + np.eye(len(cylinders))
    assert gaps.min() >= 2 * CYLINDER_RADIUS + MIN_GAP
    to_goal = np.linalg.norm(layout.distractors - layout.goal, axis=1)
    assert to_goal.min() >= 2 * CYLINDER_RADIUS + MIN_GAP
    tip = layout.ee_start[:2]
    to_tip = np.linalg.norm(layout.distractors - tip, axis=1)
    assert to_tip.min() >= CYLINDER_RADIUS + TOOL_RADIUS + MIN_GAP
    push = layout.goal - layout.goal_cylinder
    assert 0.15 <= np.linalg.norm(push) <= 0.25
    assert abs(math.atan2(push[1], push[0])) <= math.pi / 6
    behind = layout.goal_cylinder - tip
    assert np.linalg.norm(behind) == pytest.approx(CYLINDER_RADIUS + TOOL_RADIUS + STANDOFF)
    np.testing.assert_allclose(behind / np.linalg.norm(behind), push / np.linalg.norm(push),
                               atol=1e-12)


def test_sample_layout_demands_a_generator():
    with pytest.raises(TypeError, match="Generator"):
        sample_layout(np.random.RandomState(0))


def test_built_scene_follows_its_layout_with_upright_cylinders():
    layout = sample_layout(np.random.default_rng(3))
    task = build_clutter(np.random.default_rng(3))
    np.testing.assert_array_equal(task.goal_position[:2], layout.goal)
    assert task.goal_object == GOAL_CYLINDER and task.distractors == DISTRACTORS
    assert task.soft_body is None
    data = mujoco.MjData(task.model)
    mujoco.mj_setState(task.model, data, task.initial_state, mujoco.mjtState.mjSTATE_INTEGRATION)
    mujoco.mj_forward(task.model, data)
    for name, xy in zip((GOAL_CYLINDER, *DISTRACTORS), (layout.goal_cylinder, *layout.distractors),
                        strict=True):
        body = data.body(name)
        np.testing.assert_allclose(body.xpos, [*xy, CYLINDER_HALF_HEIGHT], atol=1e-3)
        assert body.xmat.reshape(3, 3)[2, 2] > 1 - 1e-6  # upright
    np.testing.assert_allclose(data.site(task.ee_site).xpos, layout.ee_start, atol=1e-5)
