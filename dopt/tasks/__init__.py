"""The tasks of the two papers, in two wings, registered by name here.

``push`` (state-vector reduction, iLQR-SVR): a Franka Panda pushes rigid cylinders and soft
bodies on a table. ``PUSH_TASKS[name]`` (or ``get_task(name)``) is the task's ``PushTaskSpec``:
its horizon, dt, timeout, slowdown and nv, read without building anything; called with an
explicit ``numpy.random.Generator`` it builds a fresh instance, a ``TaskModel``: the compiled
MuJoCo model, its initial state and the declarative facts a cost needs; the costs are in
``dopt.tasks.push.costs`` (which imports torch, so it is not re-exported here).

    clutter     Panda pushes a goal cylinder among 7 distractor cylinders (nv 55, nu 7)
    soft        Panda pushes a 36-vertex 3D soft body to a goal (nv 115, nu 7)
    soft_rigid  Panda pushes a 47-vertex soft body into a goal cylinder (nv 154, nu 7)

The same three tasks on the paper authors' own scenes (``dopt.tasks.push.authors``) are in
``AUTHORS_PUSH_TASKS``; ``build_push_task(name, problem, seed, layouts)`` builds either problem,
"ours" or "authors", from a seed:

    clutter     build_clutter_authors(layout file): one of their 100 scenes (their goal
                cylinder, 6 cylinders and a box; nv 55), the file ``layouts / f"{seed}.csv"``
    soft        build_soft_authors(rng): their 3 x 4 x 3 block, 1 kg, 4e3 Pa (nv 115)
    soft_rigid  build_soft_rigid_authors(rng): their 3 x 4 x 4 block, 2 kg, touching their
                cylinder on 3 slide joints (nv 7 + 144 + 3 = 154)

``pick`` (key particles + CEM): a one-point picker moves a rope or a cloth lying on a floor.
``PICK_SCENES[name](config, picker, pickable)`` builds a ``DeformableScene``; a
``PickPlaceTask`` (scene, goal shape) turns a population of pick-and-place action sequences
into Eq. 2 costs with one batched rollout.

    cloth       make_cloth(ClothSceneConfig, PickerConfig): a 2D flexcomp grid (16 x 16)
    rope        make_rope(RopeSceneConfig, PickerConfig): a 1D flexcomp rod (40 particles)

Both wings build scenes only: costs, planners and rollouts are built elsewhere from their
fields; this package knows no planner. The wings never import each other nor this front; the
Franka Panda both use (the push tasks' arm, the pick wing's executor) is the neutral
``dopt.tasks.panda`` (tests/test_layers.py checks the rooms). Shape letters (see ``dopt``): ns
the size of one ``mjSTATE_INTEGRATION`` state, nv the number of DoFs (``model.nv``).

Modules: this front (the registries ``PUSH_TASKS``, ``AUTHORS_PUSH_TASKS``, ``PICK_SCENES``);
``push/`` and ``pick/`` (the wings, each package's docstring lists its modules); ``panda.py``
and ``assets/`` (the arm).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

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
from dopt.tasks.push.authors import (
    build_clutter_authors,
    build_soft_authors,
    build_soft_rigid_authors,
)
from dopt.tasks.push.clutter import CLUTTER
from dopt.tasks.push.soft import SOFT, SOFT_RIGID
from dopt.tasks.push.task_model import PushTaskSpec, TaskModel, planar_dofs, require_generator
from dopt.validation import check_int

TaskBuilder = Callable[[np.random.Generator], TaskModel]
SceneBuilder = Callable[..., DeformableScene]

#: the push tasks by CLI name: each a ``PushTaskSpec``, whose constants (T, dt, Y, slowdown,
#: nv) read without compiling a model and which, called with a generator, builds an instance
PUSH_TASKS: dict[str, PushTaskSpec] = {spec.name: spec for spec in (CLUTTER, SOFT, SOFT_RIGID)}

#: the authors' scenes by task name: clutter's builder takes one of their layout files (a
#: path), the soft tasks' a ``numpy.random.Generator`` (see ``build_push_task``)
AUTHORS_PUSH_TASKS: dict[str, Callable[..., TaskModel]] = {
    "clutter": build_clutter_authors,
    "soft": build_soft_authors,
    "soft_rigid": build_soft_rigid_authors,
}
PUSH_PROBLEMS = ("ours", "authors")
#: their clutter scenes: ``{0..99}.csv`` in the folder ``build_push_task`` is given
N_AUTHORS_LAYOUTS = 100

PICK_SCENES: dict[str, SceneBuilder] = {
    "cloth": make_cloth,
    "rope": make_rope,
}


def build_push_task(name: str, problem: str, seed: int,
                    layouts: Path | None = None) -> TaskModel:
    """Build the push task ``name`` of ``problem`` for ``seed``.

    "ours": ``PUSH_TASKS[name](numpy.random.default_rng(seed))``. "authors":
    ``AUTHORS_PUSH_TASKS[name]`` (``dopt.tasks.push.authors``): for clutter their scene
    ``layouts / f"{seed}.csv"`` (seed 0-99; ``layouts`` is the folder of their 100 files,
    ``push_mcl_layouts``), for the soft tasks their bodies with a layout drawn from
    ``numpy.random.default_rng(seed)``. Only the authors' clutter reads ``layouts``.

    Raises:
        ValueError: an unknown name or problem; for the authors' clutter, a seed outside 0-99,
            or ``layouts`` None, not a folder, or without the seed's file.
        TypeError: ``seed`` is not an int.
    """
    builder = get_task(name)
    if problem not in PUSH_PROBLEMS:
        raise ValueError(f"unknown problem {problem!r}; choose from {', '.join(PUSH_PROBLEMS)}")
    seed = check_int(seed, "seed", minimum=0)
    if problem == "ours":
        return builder(np.random.default_rng(seed))
    if name != "clutter":
        return AUTHORS_PUSH_TASKS[name](np.random.default_rng(seed))
    if seed >= N_AUTHORS_LAYOUTS:
        raise ValueError(f"the authors' clutter has scenes 0-{N_AUTHORS_LAYOUTS - 1}; seed "
                         f"{seed} names none")
    if layouts is None:
        raise ValueError("the authors' clutter needs layouts: the folder of their scenes "
                         "(push_mcl_layouts/{0..99}.csv), got None")
    folder = Path(layouts)
    if not folder.is_dir():
        raise ValueError(f"layouts: no folder {folder} (the authors' push_mcl_layouts)")
    path = folder / f"{seed}.csv"
    if not path.is_file():
        raise ValueError(f"layouts: no scene file {path} (layouts must be the authors' "
                         f"push_mcl_layouts folder)")
    return AUTHORS_PUSH_TASKS[name](path)


def get_task(name: str) -> PushTaskSpec:
    """The push task registered under the CLI name ``name`` (a ``PushTaskSpec``: call it with
    a generator to build an instance); ValueError listing the known names."""
    try:
        return PUSH_TASKS[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown task {name!r}; known tasks: "
                         f"{', '.join(sorted(PUSH_TASKS))}") from None


__all__ = ["AUTHORS_PUSH_TASKS", "ClothSceneConfig", "DeformableScene", "NONE",
           "N_AUTHORS_LAYOUTS", "PICK_SCENES", "PUSH_PROBLEMS", "PUSH_TASKS", "PickPlaceTask",
           "PickerConfig", "PushTaskSpec", "RopeSceneConfig", "SceneBuilder", "TaskBuilder",
           "TaskModel", "build_push_task", "end_to_end", "get_task", "make_cloth", "make_rope",
           "matching_distance", "mean_distance", "planar_dofs", "require_generator"]
