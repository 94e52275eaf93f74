"""The tasks of the two papers, in two wings, registered by name here.

``push`` (state-vector reduction, iLQR-SVR): a Franka Panda pushes rigid cylinders and soft
bodies on a table. ``PUSH_TASKS[name](rng)`` (or ``get_task(name)(rng)``) builds a fresh task
instance from an explicit ``numpy.random.Generator`` and returns a ``TaskModel``: the compiled
MuJoCo model, its initial state and the declarative facts a cost needs; the costs are in
``dopt.tasks.push.costs`` (which imports torch, so it is not re-exported here).

    clutter     Panda pushes a goal cylinder among 7 distractor cylinders (nv 55, nu 7)
    soft        Panda pushes a 36-vertex 3D soft body to a goal (nv 115, nu 7)
    soft_rigid  Panda pushes a 47-vertex soft body into a goal cylinder (nv 154, nu 7)

``pick`` (key particles + CEM): a one-point picker moves a rope or a cloth lying on a floor.
``PICK_SCENES[name](config, picker, pickable)`` builds a ``DeformableScene``; a
``PickPlaceTask`` (scene, goal shape) turns a population of pick-and-place action sequences
into Eq. 2 costs with one batched rollout.

    cloth       make_cloth(ClothSceneConfig, PickerConfig): a 2D flexcomp grid (16 x 16)
    rope        make_rope(RopeSceneConfig, PickerConfig): a 1D flexcomp rod (40 particles)

Both wings build scenes only: costs, planners and rollouts are built elsewhere from their
fields; this package knows no planner. Shape letters (see ``dopt``): ns the size of one
``mjSTATE_INTEGRATION`` state, nv the number of DoFs (``model.nv``).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from dopt.tasks.pick.cloth_scene import ClothSceneConfig, make_cloth
from dopt.tasks.pick.picker import NONE, PickerConfig
from dopt.tasks.pick.rope_scene import RopeSceneConfig, make_rope
from dopt.tasks.pick.scene import (
    DeformableScene,
    PickPlaceTask,
    end_to_end,
    matching_distance,
    mean_distance,
)
from dopt.tasks.push.clutter import build_clutter
from dopt.tasks.push.soft import build_soft, build_soft_rigid
from dopt.tasks.push.task_model import TaskModel, planar_dofs, require_generator

TaskBuilder = Callable[[np.random.Generator], TaskModel]
SceneBuilder = Callable[..., DeformableScene]

PUSH_TASKS: dict[str, TaskBuilder] = {
    "clutter": build_clutter,
    "soft": build_soft,
    "soft_rigid": build_soft_rigid,
}

PICK_SCENES: dict[str, SceneBuilder] = {
    "cloth": make_cloth,
    "rope": make_rope,
}


def get_task(name: str) -> TaskBuilder:
    """The push-task builder registered under the CLI name ``name``; ValueError listing the
    known names."""
    try:
        return PUSH_TASKS[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown task {name!r}; known tasks: "
                         f"{', '.join(sorted(PUSH_TASKS))}") from None


__all__ = ["NONE", "PICK_SCENES", "PUSH_TASKS", "ClothSceneConfig", "DeformableScene",
           "PickPlaceTask", "PickerConfig", "RopeSceneConfig", "SceneBuilder", "TaskBuilder",
           "TaskModel", "end_to_end", "get_task", "make_cloth", "make_rope", "matching_distance",
           "mean_distance", "planar_dofs", "require_generator"]
