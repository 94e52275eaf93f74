"""What a trial plans on: ``Problem`` (the scene, the start state, the stages) and
``make_problem``, which builds it from the settings through the task's and goal's
registrations (``planners.pick_place.tasks``).

Shapes: N particles, ns state row.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from dopt.tasks import DeformableScene
from planners.pick_place.settings import PickPlaceSettings, check_seed, check_settings
from planners.pick_place.tasks import PICK_METRICS, PICK_TASKS, Stage


@dataclass(frozen=True)
class Problem:
    """What a trial plans on: the scene, the start state (ns,), the stages in order; the last
    stage's goal is what ``metrics`` measures against. planning_scene: the cheaper model CEM's
    samples run on (``PickPlaceSettings.planning_physics``), or None."""

    settings: PickPlaceSettings
    scene: DeformableScene
    start_state: np.ndarray
    stages: Sequence[Stage]
    planning_scene: DeformableScene | None = None

    @property
    def final_goal(self) -> np.ndarray:
        """(N, 3) the last stage's goal."""
        return self.stages[-1].goal

    @property
    def metric_names(self) -> tuple[str, ...]:
        """The keys of ``metrics``, the goal's (``PickGoal.metrics``): final_cost; rope
        straightening also end_to_end_ratio and straighten_error, rope folding also
        matching_distance (the paper's Sec. IV-B metrics)."""
        s = self.settings
        return PICK_TASKS[s.task].goal(s.goal).metrics

    def metrics(self, state: np.ndarray) -> dict:
        """Metrics of a final state (ns,), by ``metric_names`` (``tasks.PICK_METRICS``):
        ``final_cost`` the mean particle distance to the final goal (m, Eq. 2; the paper's
        cloth metric); rope straightening also ``end_to_end_ratio`` (end-to-end distance over
        the rope's length) and ``straighten_error`` = |end-to-end distance - length| (m, the
        paper's); rope folding also ``matching_distance``, the mean distance under the best
        particle-to-goal matching (m, the paper's bipartite-matching distance)."""
        p = self.scene.positions(state)
        return {name: PICK_METRICS[name](p, self.final_goal, self.settings)
                for name in self.metric_names}


def make_problem(settings: PickPlaceSettings, seed: int = 0,
                 scene_overrides: dict | None = None) -> Problem:
    """The scene, start and stages of a task's goal (the seed picks a goal's drawn start, the
    crumpled rope of rope straightening; every other start is deterministic).
    ``scene_overrides``: scene-config fields set on top of the physics preset (what ``python
    -m planners.bench cloth`` sweeps). The sizes the settings imply are checked first
    (``planners.pick_place.budget``: a ``BudgetError``, a ValueError, naming the setting)."""
    from planners.pick_place.budget import check_budget

    check_settings(settings)
    check_budget(settings)
    check_seed(seed)
    if scene_overrides is not None and not isinstance(scene_overrides, dict):
        raise TypeError(f"scene_overrides must be a dict of scene-config fields, got "
                        f"{type(scene_overrides).__name__}")
    spec = PICK_TASKS[settings.task]
    goal = spec.goal(settings.goal)
    config = settings.scene_config(overrides=scene_overrides or {})
    planning_config = settings.planning_scene_config(scene_overrides or {})
    picker = settings.picker()
    start = {} if goal.start is None else {"positions": goal.start(settings, seed, config)}
    scene = spec.build(config, picker, **start)
    planning = (None if planning_config is None
                else spec.build(planning_config, picker, **start))
    stages = list(goal.stages(settings, scene))
    return Problem(settings, scene, scene.initial_state, stages, planning)
