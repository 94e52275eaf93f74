"""What a trial plans on: ``Problem`` (the scene, the start state, the stages) and
``make_problem``, which builds it from the settings through the task's and goal's
registrations (``planners.pick_place.tasks``): the goal's start, or its prepared start
(``PickPlaceSettings.fold_start`` "prepared": the fold before the last dropped in place and
settled, ``drop_fold``; only the last stage is planned from it).

Shapes: N particles, ns state row.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from dopt.errors import UnstableRolloutError
from dopt.rollout import RolloutConfig, RolloutService
from dopt.stability import Stability
from dopt.tasks import DeformableScene, mean_distance
from dopt.tasks.pick.picker import CONTROL_SPEC
from dopt.validation import check_real
from planners.pick_place.settings import PickPlaceSettings, check_seed, check_settings
from planners.pick_place.tasks import PICK_METRICS, PICK_TASKS, PREPARED_SETTLE, PickGoal, Stage

log = logging.getLogger(__name__)


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
    (``planners.pick_place.budget``: a ``BudgetError``, a ValueError, naming the setting). With
    ``settings.fold_start`` "prepared" the start is the goal's prepared one and the stages
    its last (``prepared_start``).

    Raises:
        UnstableRolloutError: a prepared start whose drop the stability verdict flags.
    """
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
    if settings.fold_start == "prepared":
        return Problem(settings, scene, prepared_start(settings, goal, scene, stages),
                       stages[-1:], planning)
    return Problem(settings, scene, scene.initial_state, stages, planning)


def prepared_start(settings: PickPlaceSettings, goal: PickGoal, scene: DeformableScene,
                   stages: list[Stage]) -> np.ndarray:
    """The prepared start (ns,) of ``goal``: its ``prepared`` positions (the stage before the
    last, layers lifted) dropped in ``scene`` and settled ``PREPARED_SETTLE`` seconds; logs
    its mean particle distance to that stage's goal. UnstableRolloutError when the verdict
    flags the drop (no trial plans from a start that blew up)."""
    dropped = drop_fold(scene, goal.prepared(settings, scene), PREPARED_SETTLE)
    if dropped.unstable:
        raise UnstableRolloutError(0, int(dropped.stability.step[0]), dropped.reason,
                                   what=f"the prepared start of {settings.task} "
                                        f"{settings.goal} (n {settings.n})")
    distance = float(mean_distance(scene.positions(dropped.state), stages[-2].goal))
    log.info("%s %s: prepared start %.1f mm from the %s goal", settings.task, settings.goal,
             distance * 1e3, stages[-2].name)
    return dropped.state


@dataclass(frozen=True)
class DroppedFold:
    """A sheet dropped in place (``drop_fold``): its state (ns,) after the settle and the
    verdict of the drop and settle (``dopt.stability.Stability`` of one rollout)."""

    state: np.ndarray
    stability: Stability

    @property
    def unstable(self) -> bool:
        return bool(self.stability.unstable[0])

    @property
    def reason(self) -> str:
        return self.stability.reason[0]


def drop_fold(scene: DeformableScene, positions: np.ndarray, settle: float) -> DroppedFold:
    """Place the particles of ``scene`` at ``positions`` (N, 3), at rest, with the rest of its
    ``initial_state`` (the picker idle above), and let them fall and settle ``settle`` seconds,
    judged by the scene's stability bounds. The key-particle authors prepare a multi-layer
    fold's start so (SoftGym's ``_set_to_folded``: each layer over the one below, 5 cm up, 15
    steps); here from ``PickGoal.prepared`` positions (``deformables.goals.lift_layers``).

    Raises:
        TypeError: a scene that is not a DeformableScene.
        ValueError: positions that are not (N, 3) finite, a settle shorter than one step.
    """
    if not isinstance(scene, DeformableScene):
        raise TypeError(f"scene must be a DeformableScene, got {type(scene).__name__}")
    settle = check_real(settle, "settle", positive=True)
    steps = int(round(settle / scene.model.opt.timestep))
    if steps < 1:
        raise ValueError(f"settle must be at least one step ({scene.model.opt.timestep} s), "
                         f"got {settle}")
    start = scene.with_positions(scene.initial_state, positions)
    idle = np.repeat(scene.picker.idle_row[None, None], steps, axis=1)        # (1, T, nc)
    with RolloutService(scene.scene, RolloutConfig(threads=1)) as service:
        res = service.rollout(start[None], idle, control_spec=CONTROL_SPEC)
    return DroppedFold(res.final_states[0], res.stability)
