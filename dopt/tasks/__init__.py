"""Scene builders of the state-vector-reduction paper's tasks, registered by their CLI names.

``TASKS[name](rng)`` (or ``get_task(name)(rng)``) builds a fresh task instance from an explicit
``numpy.random.Generator`` and returns a ``TaskModel``: the compiled MuJoCo model, its initial
state and the declarative facts a cost needs. Costs, planners and rollouts are built elsewhere
from these fields; this package knows no planner.

    clutter     Panda pushes a goal cylinder among 7 distractor cylinders (nv 55, nu 7)
    soft        Panda pushes a 36-vertex 3D soft body to a goal (nv 115, nu 7)
    soft_rigid  Panda pushes a 47-vertex soft body into a goal cylinder (nv 154, nu 7)

Shape letters (see ``dopt``): ns the size of one ``mjSTATE_INTEGRATION`` state, nv the number of
DoFs (``model.nv``).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from dopt.tasks.base import TaskModel, planar_dofs, require_generator
from dopt.tasks.clutter import build_clutter
from dopt.tasks.soft import build_soft, build_soft_rigid

TaskBuilder = Callable[[np.random.Generator], TaskModel]

TASKS: dict[str, TaskBuilder] = {
    "clutter": build_clutter,
    "soft": build_soft,
    "soft_rigid": build_soft_rigid,
}


def get_task(name: str) -> TaskBuilder:
    """The builder registered under the CLI name ``name``; ValueError listing the known names."""
    try:
        return TASKS[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown task {name!r}; known tasks: {', '.join(sorted(TASKS))}") from None


__all__ = ["TASKS", "TaskBuilder", "TaskModel", "get_task", "planar_dofs",
           "require_generator"]
