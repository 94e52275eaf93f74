"""Pick-and-place on rope and cloth: the key-particle paper's pipeline as one library call.

A *problem* is a scene (rope or cloth with the picker), a start state and one or more *stages*:
the goal shape and, for the multi-step folds, its intermediate goals in turn (Sec. III-D), each
with the key particles of its goal (``deformables``). A *planner* plans one stage from the
current state; the plan is executed and the next stage starts from where it left the object.

Planners (the paper's Sec. IV-C.2), one interface (``PickPlanner``), built by name with
``make_planner``:

    simple    CEM over the key particles of each stage's goal (CEM(Simple))
    original  CEM over all particles (CEM(Original))
    random    CEM over a random subset as large as the key set (CEM(Random))
    scripted  pick each key particle, move it above its goal, release

One call runs a whole trial::

    from planners.pick_place import PickPlaceSettings, solve
    result = solve(PickPlaceSettings.preset("cloth", "diagonal"), method="simple", seed=0)
    result.metrics["final_cost"]          # mean particle distance to the goal (m)

Shapes: N particles, K key particles, H actions per plan, ns state row.
"""

from __future__ import annotations

import json
import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field, replace
from typing import Protocol

import numpy as np
import torch

from dopt.dicts import flatten
from dopt.rollout import RolloutConfig, RolloutService
from dopt.stats import difference_ci, mean_ci
from dopt.tasks.pick.cloth_scene import PHYSICS_PRESETS, ClothSceneConfig, make_cloth
from dopt.tasks.pick.constraints import ActionConstraint
from dopt.tasks.pick.picker import PickerConfig
from dopt.tasks.pick.rope_scene import RopeSceneConfig, make_rope
from dopt.tasks.pick.scene import (
    PICK_BOUNDS,
    DeformableScene,
    PickPlaceTask,
    end_to_end,
    matching_distance,
    mean_distance,
)
from dopt.validation import check_config, check_int
from planners.cem import CEM, CEMConfig, CEMProgress
from planners.scripted import ScriptedConfig, scripted

log = logging.getLogger(__name__)

#: the goals of each object, by the names the experiments take
GOALS = {"cloth": ("diagonal", "side", "reflective", "underneath"),
         "rope": ("straighten", "fold")}
#: planner names (the paper's methods), in the order of its figures
METHODS = ("simple", "original", "random", "scripted")
LABELS = {"simple": "CEM(Simple)", "original": "CEM(Original)", "random": "CEM(Random)",
          "scripted": "Scripted"}
#: how far a crumpled rope's start turns per particle (rad; deformables.goals.rope_crumpled)
CRUMPLE_TURN = 0.8


# ------------------------------------------------------------------------------ settings
@dataclass(frozen=True)
class PickPlaceSettings:
    """Everything that defines a pick-and-place trial except the method and the seed.

    Attributes:
        task: "cloth" or "rope".
        goal: one of ``GOALS[task]``.
        n: particles per side (cloth, N = n * n) or along the rope (N = n).
        bound: largest picker displacement per axis of one action (m).
        cem: the CEM settings of every stage (``horizon`` is H).
        scripted: the scripted policy's settings.
        selfcollide: cloth self-collision (the multi-layer folds need it).
        side: cloth edge length (m); length: rope length (m).
        physics: the scene's physics preset (``ClothSceneConfig.preset`` /
            ``RopeSceneConfig.preset``: "fast", "default", "accurate").
        planning_physics: a preset for CEM's sampled rollouts only (a cheaper planning model);
            every executed plan and every reported cost stays on ``physics``. None: the same.
        threads: simulation threads (0: one per core); not part of a trial's identity.
        max_stretch: the stretch limit of C(a_t) (relative edge elongation away from the grasp;
            a sampled rollout beyond it is infeasible, +inf); None: not judged
            (``dopt.tasks.pick.constraints``).
        picker_speed: the picker's average speed on the longest move (m/s,
            ``PickerConfig.speed``); it sets the steps of every action, so it sets the cost of
            a rollout. None: ``PickerConfig``'s default.
    """

    task: str
    goal: str
    n: int
    bound: float
    cem: CEMConfig
    scripted: ScriptedConfig = ScriptedConfig()
    selfcollide: bool = False
    side: float = 0.3
    length: float = 0.5
    physics: str = "default"
    threads: int = 0
    planning_physics: str | None = None
    max_stretch: float | None = None
    picker_speed: float | None = None

    def __post_init__(self):
        if not isinstance(self.task, str) or self.task not in GOALS:
            raise ValueError(f"unknown task {self.task!r}; choose from {', '.join(GOALS)}")
        if not isinstance(self.goal, str) or self.goal not in GOALS[self.task]:
            raise ValueError(f"unknown {self.task} goal {self.goal!r}; choose from "
                             f"{', '.join(GOALS[self.task])}")
        if not isinstance(self.cem, CEMConfig):
            raise TypeError(f"PickPlaceSettings.cem must be a CEMConfig, got {self.cem!r}")
        if not isinstance(self.scripted, ScriptedConfig):
            raise TypeError(f"PickPlaceSettings.scripted must be a ScriptedConfig, got "
                            f"{self.scripted!r}")
        # n an int >= 3, bound / side / length finite > 0 (m), threads an int >= 0 (0: one
        # per core), selfcollide a bool; TypeError or ValueError naming the field
        check_config(self, positive=("bound", "side", "length", "max_stretch", "picker_speed"),
                     minimum={"n": 3, "threads": 0},
                     choices={"physics": tuple(PHYSICS_PRESETS)})
        if self.planning_physics is not None and self.planning_physics not in PHYSICS_PRESETS:
            raise ValueError(f"PickPlaceSettings.planning_physics must be None or one of "
                             f"{sorted(PHYSICS_PRESETS)}, got {self.planning_physics!r}")
        for name in ("n", "threads"):          # numpy scalars -> Python (JSON-able to_dict)
            object.__setattr__(self, name, int(getattr(self, name)))
        for name in ("bound", "side", "length"):
            object.__setattr__(self, name, float(getattr(self, name)))
        object.__setattr__(self, "selfcollide", bool(self.selfcollide))

    @classmethod
    def preset(cls, task: str, goal: str, quick: bool = False,
               protocol: str = "ours") -> PickPlaceSettings:
        """The settings the experiments run by default: ``protocol`` "ours" (``PRESETS``) or
        "paper" (``PAPER_PRESETS``, Fig. 7 at the paper's CEM budget); ``quick`` shrinks
        either to a smoke run (8 x 8 cloth or 20-particle rope, population 8, 2 iterations)."""
        if protocol not in PROTOCOLS:
            raise ValueError(f"unknown protocol {protocol!r}; choose from {', '.join(PROTOCOLS)}")
        presets = PROTOCOLS[protocol]
        if (task, goal) not in presets:
            raise ValueError(f"no preset for {task!r} / {goal!r}; choose from {GOALS}")
        if not isinstance(quick, (bool, np.bool_)):
            raise TypeError(f"quick must be a bool, got {quick!r}")
        p = presets[task, goal]
        cem = CEMConfig(horizon=p.horizon, iterations=p.iterations, population=p.population,
                        elites=p.elites)
        n = p.n
        if quick:
            cem = replace(cem, population=8, elites=2, iterations=2,
                          horizon=2 if task == "rope" else cem.horizon)
            n = 8 if task == "cloth" else 20
        return cls(task, goal, n, p.bound, cem, ScriptedConfig(), p.selfcollide,
                   physics=p.physics, planning_physics=p.planning_physics)

    def departures(self, protocol: str = "ours", quick: bool = False) -> dict:
        """{field: value} of these settings that differ from ``preset(task, goal, quick,
        protocol)``, nested configs as dotted names ("cem.population"); the thread count is
        not a setting of the experiment and is left out. Empty: the protocol as it stands."""
        base = flatten(type(self).preset(self.task, self.goal, quick, protocol).to_dict())
        mine = flatten(self.to_dict())
        return {k: v for k, v in mine.items() if k != "threads" and base.get(k) != v}

    def constraint(self) -> ActionConstraint:
        """C(a_t) of the task (``dopt.tasks.pick.constraints``): SoftGym's workspace, the
        object's size on each side of its centre (cloth: side, rope: length), 0.5 m high."""
        return ActionConstraint.table(self.side if self.task == "cloth" else self.length,
                                      max_stretch=self.max_stretch)

    def picker(self) -> PickerConfig:
        """The picker of the task's scenes: the bound per axis, limited to ``constraint()``."""
        speed = {} if self.picker_speed is None else {"speed": float(self.picker_speed)}
        return PickerConfig(bound=(self.bound,) * 3, workspace=self.constraint(), **speed)

    def scene_config(self, physics: str | None = None,
                     overrides: dict | None = None) -> ClothSceneConfig | RopeSceneConfig:
        """The scene config of the preset ``physics`` (None: ``self.physics``) with the
        settings' own fields (n, side or length, selfcollide) and ``overrides`` on top."""
        physics = self.physics if physics is None else physics
        if self.task == "cloth":
            return ClothSceneConfig.preset(physics, **{"n": self.n, "side": self.side,
                                                       "selfcollide": self.selfcollide,
                                                       **(overrides or {})})
        return RopeSceneConfig.preset(physics, **{"n": self.n, "length": self.length,
                                                  **(overrides or {})})

    def planning_scene_config(self, overrides: dict | None = None
                              ) -> ClothSceneConfig | RopeSceneConfig | None:
        """``scene_config`` of ``planning_physics``; None where CEM plans on the scene itself
        (no planning preset, or the scene's own)."""
        if self.planning_physics in (None, self.physics):
            return None
        return self.scene_config(self.planning_physics, overrides)

    def resolved_physics(self) -> dict:
        """JSON-able scene and picker configs these settings run (what a preset name means
        today) and the stability bounds their rollouts are judged by (CEM scores an unstable
        sample +inf): a trial's identity, so that a changed preset, picker or verdict is not
        reused. Scene fields in ``UNSET_SCENE_FIELDS`` appear only when set."""
        out = {"scene": _scene_identity(self.scene_config()), "picker": asdict(self.picker()),
               "stability": asdict(PICK_BOUNDS)}
        planning = self.planning_scene_config()
        if planning is not None:
            out["planning_scene"] = _scene_identity(planning)
        return out

    def identity(self) -> dict:
        """JSON-able: the settings that change a trial's result, which name its trial (the
        sweep's key hashes it, a checkpoint must hold it): ``to_dict()`` without ``threads``
        and without the optional fields ``UNSET_SETTINGS`` at None (a trial run before such
        a field existed stays valid), plus what the presets and picker resolve to today
        (``resolved_physics``, under "resolved"). Plain JSON types (tuples as lists), so it
        equals itself read back from a file."""
        out = {k: v for k, v in self.to_dict().items()
               if k != "threads" and not (k in UNSET_SETTINGS and v is None)}
        out["resolved"] = self.resolved_physics()
        return json.loads(json.dumps(out))

    def to_dict(self) -> dict:
        """JSON-able form (nested configs as dicts); ``from_dict`` inverts it."""
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> PickPlaceSettings:
        """Inverse of ``to_dict``; ValueError naming missing or unknown fields."""
        if not isinstance(d, dict):
            raise TypeError(f"PickPlaceSettings.from_dict needs a dict, got {type(d).__name__}")
        d = dict(d)
        for name, config in (("cem", CEMConfig), ("scripted", ScriptedConfig)):
            if isinstance(d.get(name), dict):
                _check_fields(config, d[name], f"settings[{name!r}]")
                d[name] = config(**d[name])
        _check_fields(cls, d, "settings")
        return cls(**d)


#: optional settings ``PickPlaceSettings.identity`` leaves out at None: options whose unset
#: value is what every trial ran before they existed, so those trials stay valid
UNSET_SETTINGS = ("planning_physics", "max_stretch", "picker_speed")
#: scene-config fields a trial's identity leaves out at these values, for the same reason
UNSET_SCENE_FIELDS = {"passive": False}


def _scene_identity(config: ClothSceneConfig | RopeSceneConfig) -> dict:
    """``asdict(config)`` without the ``UNSET_SCENE_FIELDS`` at their unset values."""
    return {k: v for k, v in asdict(config).items()
            if k not in UNSET_SCENE_FIELDS or v != UNSET_SCENE_FIELDS[k]}


@dataclass(frozen=True)
class Preset:
    """A goal's default budget: n, bound (m), horizon H, CEM iterations per stage, population,
    elites, self-collision."""

    n: int
    bound: float
    horizon: int
    iterations: int
    population: int
    elites: int
    selfcollide: bool = False
    physics: str = "default"
    planning_physics: str | None = None


#: The experiments' defaults, chosen so that all four methods x 3 seeds of one goal finish in
#: minutes on 2 cores. The multi-layer folds need self-collision (a layered 12 x 12 step costs
#: ~6 ms instead of ~1 ms), so they run a smaller population and fewer iterations per stage.
#: A cloth action may carry a corner across the 0.3 m sheet; a rope action moves 0.1 m at most.
PRESETS = {
    ("cloth", "diagonal"): Preset(12, 0.3, 2, 15, 32, 6),
    ("cloth", "side"): Preset(12, 0.3, 3, 15, 32, 6),
    ("cloth", "reflective"): Preset(12, 0.3, 2, 8, 16, 4, selfcollide=True),
    ("cloth", "underneath"): Preset(12, 0.3, 2, 5, 16, 4, selfcollide=True),
    ("rope", "straighten"): Preset(40, 0.1, 6, 20, 32, 6),
    ("rope", "fold"): Preset(40, 0.1, 6, 20, 32, 6),
}

#: Fig. 7 at the paper's protocol (Sec. IV-C.2): 30 CEM iterations per stage and ten runs per
#: method (``PROTOCOL_SEEDS``), on a 20 x 20 cloth (400 candidates for CEM(Original)); even at
#: this size the four folds x three CEM methods x ten runs take days of CPU on 2 cores, and
#: the paper's 100 x 100 does not simulate without MuJoCo's flex-solve warnings
#: (docs/DESIGN-NOTES.md, "Large cloths"). Population, elites and horizon stay ours: the
#: paper's T (20 rope, 15 cloth) counts short drags of a picked particle, not pick-and-place
#: actions, and the authors' population (200 rope, 333 cloth) would cost the 20 x 20 cloth ten
#: times more (docs/DESIGN-NOTES.md, "The paper's CEM budget").
#: The cloth runs the default physics, whose scripted folds of the diagonal and side goals the
#: stability verdict leaves unflagged at 20 x 20 (docs/results/physics-cloth-20.json).
PAPER_PRESETS = {
    (task, goal): replace(p, n=20, iterations=30) if task == "cloth"
    else replace(p, iterations=30)
    for (task, goal), p in PRESETS.items()
}

#: protocol name -> its presets
PROTOCOLS = {"ours": PRESETS, "paper": PAPER_PRESETS}
#: seeds per method an experiment runs by default under each protocol (the paper: ten runs)
PROTOCOL_SEEDS = {"ours": 3, "paper": 10}


# ------------------------------------------------------------------------------- problem
@dataclass(frozen=True)
class Stage:
    """One (intermediate) goal: goal (N, 3) particle positions in the scene's frame, keys (K,)
    its key particles, name for the logs."""

    name: str
    goal: np.ndarray
    keys: np.ndarray


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
        """The keys of ``metrics``: final_cost; rope straightening also end_to_end_ratio and
        straighten_error, rope folding also matching_distance (the paper's Sec. IV-B
        metrics)."""
        s = self.settings
        if s.task == "rope" and s.goal == "straighten":
            return ("final_cost", "end_to_end_ratio", "straighten_error")
        if s.task == "rope":
            return ("final_cost", "matching_distance")
        return ("final_cost",)

    def metrics(self, state: np.ndarray) -> dict:
        """Metrics of a final state (ns,): ``final_cost`` the mean particle distance to the
        final goal (m, Eq. 2; the paper's cloth metric); rope straightening also
        ``end_to_end_ratio`` (end-to-end distance over the rope's length) and
        ``straighten_error`` = |end-to-end distance - length| (m, the paper's); rope folding
        also ``matching_distance``, the mean distance under the best particle-to-goal
        matching (m, the paper's bipartite-matching distance)."""
        p = self.scene.positions(state)
        out = {"final_cost": float(mean_distance(p, self.final_goal))}
        names = self.metric_names
        if "end_to_end_ratio" in names:
            out["end_to_end_ratio"] = float(end_to_end(p) / self.settings.length)
            out["straighten_error"] = float(abs(end_to_end(p) - self.settings.length))
        if "matching_distance" in names:
            out["matching_distance"] = matching_distance(p, self.final_goal)
        return out


def make_problem(settings: PickPlaceSettings, seed: int = 0,
                 scene_overrides: dict | None = None) -> Problem:
    """The scene, start and stages of a task (the seed picks the crumpled start of rope
    straightening; every other start is deterministic). ``scene_overrides``: scene-config
    fields set on top of the physics preset (what ``python -m planners.bench cloth`` sweeps).
    The sizes the settings imply are checked first (``planners.pick_budget``: a
    ``BudgetError``, a ValueError, naming the setting)."""
    from planners.pick_budget import check_budget

    _check_settings(settings)
    check_budget(settings)
    _check_seed(seed)
    if scene_overrides is not None and not isinstance(scene_overrides, dict):
        raise TypeError(f"scene_overrides must be a dict of scene-config fields, got "
                        f"{type(scene_overrides).__name__}")
    if settings.task == "cloth":
        return _cloth_problem(settings, scene_overrides or {})
    return _rope_problem(settings, seed, scene_overrides or {})


def _cloth_problem(s: PickPlaceSettings, overrides: dict) -> Problem:
    from deformables.cloth import cloth_key_particles
    from deformables.goals import goal_sequence

    scene = make_cloth(s.scene_config(overrides=overrides), s.picker())
    planning_config = s.planning_scene_config(overrides)
    planning = None if planning_config is None else make_cloth(planning_config, s.picker())
    lift = np.array([0.0, 0.0, scene.radius])          # the cloth rests at z = radius
    stages = []
    for goal in goal_sequence(f"cloth_{s.goal}", n=s.n, side=s.side):
        keys = cloth_key_particles(goal.positions, goal.faces,
                                   rest_positions=goal.rest_positions).indices
        stages.append(Stage(goal.name, goal.positions + lift, np.asarray(keys, dtype=int)))
    return Problem(s, scene, scene.initial_state, stages, planning)


def _rope_problem(s: PickPlaceSettings, seed: int, overrides: dict) -> Problem:
    """Straighten: a crumpled start (one per seed), the straight rope along the line through
    its ends, centred between them. Fold: the straight rope to the crossed triangle."""
    from deformables.goals import rope_crossed_triangle, rope_crumpled, rope_straight
    from deformables.rope import rope_key_particles

    config = s.scene_config(overrides=overrides)
    planning_config = s.planning_scene_config(overrides)
    picker = s.picker()
    planning = None
    if s.goal == "straighten":
        start = rope_crumpled(np.random.default_rng(seed), s.n, s.length,
                              turn=CRUMPLE_TURN).positions.copy()
        start[:, 2] = config.radius + 1e-4
        scene = make_rope(config, picker, positions=start)
        if planning_config is not None:
            planning = make_rope(planning_config, picker, positions=start)
        p0 = scene.positions(scene.initial_state)
        direction = p0[-1] - p0[0]
        goal = rope_straight(s.n, s.length, float(np.arctan2(direction[1], direction[0])))
        goal = replace(goal, positions=goal.positions + [*(0.5 * (p0[0] + p0[-1]))[:2], 0.0])
    else:
        scene = make_rope(config, picker)
        if planning_config is not None:
            planning = make_rope(planning_config, picker)
        goal = rope_crossed_triangle(s.n, s.length)
    keys = np.asarray(rope_key_particles(goal.positions).indices, dtype=int)
    positions = goal.positions.copy()
    positions[:, 2] = config.radius                     # the goal rests on the floor
    return Problem(s, scene, scene.initial_state, [Stage(goal.name, positions, keys)], planning)


# ------------------------------------------------------------------------------ planners
@dataclass(frozen=True)
class StagePlan:
    """A planner's answer for one stage: the actions particles (H,) / displacements (H, 3),
    the state (ns,) after executing them, its cost (m), the best cost after each iteration
    (one entry for the scripted policy), the candidates planned over, the seconds of
    each CEM iteration (empty for the scripted policy), the rollouts simulated while planning,
    how many of them the stability verdict flagged and how many broke the stretch limit of
    C(a_t), and whether the executed plan was unstable (with the reason)."""

    particles: np.ndarray
    displacements: np.ndarray
    final_state: np.ndarray
    cost: float
    cost_history: list
    n_candidates: int
    seconds_per_iteration: list = field(default_factory=list)
    n_rollouts: int = 0
    n_unstable_rollouts: int = 0
    unstable: bool = False
    unstable_reason: str = ""
    n_infeasible_rollouts: int = 0

    def to_dict(self) -> dict:
        """JSON-able form (arrays as lists; float64 round-trips exactly)."""
        d = asdict(self)
        for name in ("particles", "displacements", "final_state"):
            d[name] = np.asarray(d[name]).tolist()
        return d

    @classmethod
    def from_dict(cls, d: dict) -> StagePlan:
        d = dict(d)
        d["particles"] = np.asarray(d["particles"], dtype=int)
        for name in ("displacements", "final_state"):
            d[name] = np.asarray(d[name], dtype=float)
        return cls(**d)


class PickPlanner(Protocol):
    """Plans one stage: ``plan(task, keys, on_iteration)``, where ``task`` holds the start
    state and the stage's goal and ``keys`` (K,) are its key particles.

    A planner that can be stopped and resumed (``run_problem``'s ``checkpoint``) also has
    ``rng_state()`` / ``set_rng_state(state)`` (its random generators' state, JSON-able)
    and takes ``resume`` (a progress dict it gave ``on_progress``) and ``on_progress``
    (called with a JSON-able dict after each step of its planning) in ``plan``."""

    def plan(self, task: PickPlaceTask, keys: np.ndarray,
             on_iteration: Callable[[int, float], None] | None = None) -> StagePlan: ...


class CEMPlanner:
    """CEM over a candidate set: the keys ("keys", CEM(Simple)), every particle ("all",
    CEM(Original)) or as many random particles as keys ("random", CEM(Random), sorted).

    Args:
        config: the CEM settings.
        candidates: "keys", "all" or "random".
        seed: seeds the torch generator of CEM and the numpy generator of random candidates.
    """

    CANDIDATES = ("keys", "all", "random")

    def __init__(self, config: CEMConfig, candidates: str, seed: int):
        if candidates not in self.CANDIDATES:
            raise ValueError(f"candidates must be one of {self.CANDIDATES}, got {candidates!r}")
        _check_seed(seed)
        self.cem, self.candidates = CEM(config), candidates
        self.generator = torch.Generator().manual_seed(int(seed))
        self.rng = np.random.default_rng(int(seed))

    def candidate_particles(self, keys: np.ndarray, n_particles: int) -> np.ndarray:
        """(C,) particle indices CEM may pick for a stage with key particles ``keys`` (K,)."""
        keys = np.asarray(keys, dtype=int)
        if self.candidates == "keys":
            return keys
        if self.candidates == "all":
            return np.arange(n_particles)
        return np.sort(self.rng.choice(n_particles, size=len(keys), replace=False))

    def rng_state(self) -> dict:
        """The torch and numpy generators' state (JSON-able)."""
        return {"torch": self.generator.get_state().tolist(),
                "numpy": self.rng.bit_generator.state}

    def set_rng_state(self, state: dict) -> None:
        """Inverse of ``rng_state``."""
        self.generator.set_state(torch.tensor(state["torch"], dtype=torch.uint8))
        self.rng.bit_generator.state = state["numpy"]

    def plan(self, task, keys, on_iteration=None, *, resume: dict | None = None,
             on_progress: Callable[[dict], None] | None = None) -> StagePlan:
        """CEM over the candidates, then the best plan executed on the task's scene.
        ``resume``: a dict ``on_progress`` gave while planning this stage from the same rng
        state (candidates, CEM progress, the task's rollout counters), to go on from."""
        cand = self.candidate_particles(keys, task.n_particles)
        counters = ("n_evaluated", "n_unstable", "n_infeasible")
        cem_resume = None
        if resume is not None:
            if np.asarray(resume["candidates"]).tolist() != cand.tolist():
                raise ValueError("the saved progress planned over other candidates than this "
                                 "planner draws: not a progress of this stage and seed")
            cem_resume = CEMProgress.from_dict(resume["cem"])
            for name in counters:
                setattr(task, name, int(resume["task"][name]))

        def progress(p: CEMProgress) -> None:
            on_progress({"candidates": cand.tolist(), "cem": p.to_dict(),
                         "task": {name: getattr(task, name) for name in counters}})

        res = self.cem.plan(task, cand, self.generator, on_iteration, resume=cem_resume,
                            on_progress=progress if on_progress is not None else None)
        done = task.execute(res.particles, res.displacements)
        # the executed plan's cost, on the task's own scene (CEM may have planned on a cheaper
        # model; without one the two are the same rollout)
        return StagePlan(res.particles, res.displacements, done.state,
                         float(task.cost(done.state)),
                         res.cost_history.tolist(), len(cand),
                         res.seconds_per_iteration.tolist(), res.n_evaluated + 1,
                         res.n_nonfinite - task.n_infeasible + int(done.unstable),
                         done.unstable, done.reason, task.n_infeasible)


class ScriptedPlanner:
    """The paper's scripted policy over the key particles (deterministic: no seed)."""

    def __init__(self, config: ScriptedConfig = ScriptedConfig()):
        if not isinstance(config, ScriptedConfig):
            raise TypeError(f"config must be a ScriptedConfig, got {type(config).__name__}")
        self.config = config

    def plan(self, task, keys, on_iteration=None) -> StagePlan:
        res = scripted(task, keys, self.config)
        return StagePlan(res.particles, res.displacements, res.final_state, float(res.cost),
                         [float(res.cost)], len(np.asarray(keys).reshape(-1)),
                         n_rollouts=len(res.particles), n_unstable_rollouts=int(res.unstable),
                         unstable=res.unstable, unstable_reason=res.reason)


def make_planner(method: str, settings: PickPlaceSettings, seed: int = 0) -> PickPlanner:
    """The planner of a method name (``METHODS``) with the settings' configs; ``seed`` an
    int >= 0."""
    if not isinstance(method, str) or method not in METHODS:
        raise ValueError(f"unknown method {method!r}; choose from {', '.join(METHODS)}")
    _check_settings(settings)
    _check_seed(seed)
    if method == "scripted":
        return ScriptedPlanner(settings.scripted)
    kinds = {"simple": "keys", "original": "all", "random": "random"}
    return CEMPlanner(settings.cem, kinds[method], seed)


# ------------------------------------------------------------------------------- running
@dataclass(frozen=True)
class PickPlaceResult:
    """One trial: ``metrics`` of the final state (``Problem.metrics``), the best cost after
    every iteration of every stage (``cost_history``, with ``stage_of_iteration``), each
    stage's cost, candidates and actions, seconds per CEM iteration (None when scripted), the
    final state (ns,), the wall time (s), the rollouts simulated and how many the stability
    verdict flagged, and whether an executed plan was unstable (``unstable_reason`` names the
    stage, step and bound): such a trial's metrics are not those of a physical result.
    ``segments``: the runs the trial took (more than 1 when it was resumed from a checkpoint;
    ``wall_s`` is then their sum, and the same result as in one run)."""

    method: str
    seed: int
    metrics: dict
    cost_history: list
    stage_of_iteration: list
    stage_costs: list
    n_candidates: list
    s_per_iteration: float | None
    actions: list
    final_state: np.ndarray
    wall_s: float
    n_rollouts: int = 0
    n_unstable_rollouts: int = 0
    unstable: bool = False
    unstable_reason: str = ""
    n_infeasible_rollouts: int = 0
    segments: int = 1

    def to_dict(self) -> dict:
        """JSON-able form: the metrics at the top level, the final state as a list."""
        d = asdict(self)
        metrics = d.pop("metrics")
        d["final_state"] = self.final_state.tolist()
        return {"method": d.pop("method"), "seed": d.pop("seed"), **metrics, **d}


def run_problem(problem: Problem, planner: PickPlanner, *, method: str = "", seed: int = 0,
                service: RolloutService | None = None,
                on_iteration: Callable[[int, float], None] | None = None,
                checkpoint=None) -> PickPlaceResult:
    """Plan and execute every stage of ``problem`` in turn with ``planner``.

    ``service`` defaults to a new one with the settings' threads (closed at the end);
    ``method`` and ``seed`` only label the result. ``checkpoint`` (``dopt.sweep.Checkpoint``,
    or anything with ``load() -> dict | None`` and ``save(dict)``): the trial's progress is
    saved after every stage and, with a resumable planner (``PickPlanner``), after every step
    of its planning; a progress found there is resumed, and the result is the one the trial
    gives without a stop (only ``wall_s``, summed over the runs, and ``segments`` differ).
    """
    if not isinstance(problem, Problem):
        raise TypeError(f"problem must be a Problem (make_problem), got {type(problem).__name__}")
    if not callable(getattr(planner, "plan", None)):
        raise TypeError(f"planner must be a PickPlanner (with plan), got {type(planner).__name__}")
    if on_iteration is not None and not callable(on_iteration):
        raise TypeError(f"on_iteration must be callable or None, got {on_iteration!r}")
    resumable = callable(getattr(planner, "rng_state", None))
    if checkpoint is not None and not (callable(getattr(checkpoint, "load", None))
                                       and callable(getattr(checkpoint, "save", None))):
        raise TypeError(f"checkpoint must have load() and save(progress), got "
                        f"{type(checkpoint).__name__}")
    if checkpoint is not None and not resumable:
        log.info("%s: the planner has no rng_state, so the trial is not checkpointed",
                 type(planner).__name__)
        checkpoint = None
    start = time.perf_counter()
    saved = checkpoint.load() if checkpoint is not None else None
    done: list[StagePlan] = []
    earlier_s, segments, partial = 0.0, 1, None
    # what the progress must be of (threads do not change results)
    trial = {"method": method, "seed": int(seed), "settings": problem.settings.identity()}
    if saved is not None:
        if saved.get("trial") != trial:
            raise ValueError(f"the checkpoint holds the progress of another trial: "
                             f"{_trial_difference(saved.get('trial'), trial)}")
        done = [StagePlan.from_dict(d) for d in saved["stages"]]
        earlier_s, segments = float(saved["wall_s"]), int(saved["segments"]) + 1
        partial = saved["stage"]
        planner.set_rng_state(saved["planner"])
        log.info("%s seed %d resumes after %d of %d stages%s", method, seed, len(done),
                 len(problem.stages), " and part of the next" if partial else "")

    def save(stage_progress: dict | None, rng: dict) -> None:
        checkpoint.save({"trial": trial, "stages": [p.to_dict() for p in done], "planner": rng,
                         "stage": stage_progress, "segments": segments,
                         "wall_s": earlier_s + time.perf_counter() - start})

    own = service is None
    svc = service or RolloutService(problem.scene.scene,
                                    RolloutConfig(threads=problem.settings.threads))
    plan_svc = (RolloutService(problem.planning_scene.scene,
                               RolloutConfig(threads=problem.settings.threads))
                if problem.planning_scene is not None else None)
    try:
        state = done[-1].final_state if done else problem.start_state
        for stage in problem.stages[len(done):]:
            task = PickPlaceTask(problem.scene, stage.goal, state, svc,
                                 problem.planning_scene, plan_svc)
            kwargs = {}
            if checkpoint is not None:
                rng = planner.rng_state()           # the stage's start: a resume redraws
                kwargs = {"resume": partial,
                          "on_progress": lambda progress, rng=rng: save(progress, rng)}
            plan = planner.plan(task, stage.keys, on_iteration, **kwargs)
            partial = None
            state = plan.final_state
            done.append(plan)
            if plan.unstable:
                log.warning("%s seed %d stage %s: the executed plan went unstable (%s)", method,
                            seed, stage.name, plan.unstable_reason)
            log.info("%s seed %d stage %s: cost %.1f mm", method, seed, stage.name,
                     plan.cost * 1e3)
            if checkpoint is not None:
                save(None, planner.rng_state())
    finally:
        if own and hasattr(svc, "close"):
            svc.close()
        if plan_svc is not None:
            plan_svc.close()
    history = [c for p in done for c in p.cost_history]
    stage_of = [k for k, p in enumerate(done) for _ in p.cost_history]
    seconds = [t for p in done for t in p.seconds_per_iteration]
    reasons = [f"stage {stage.name}: {p.unstable_reason}"
               for stage, p in zip(problem.stages, done, strict=True) if p.unstable]
    # full precision: a cloth amplifies a micrometre of rounding into centimetres, and the
    # recorded actions must replay to the recorded final state
    actions = [{"stage": stage.name, "particles": p.particles.tolist(),
                "displacements": np.asarray(p.displacements, float).tolist()}
               for stage, p in zip(problem.stages, done, strict=True)]
    return PickPlaceResult(method, int(seed), problem.metrics(state), history, stage_of,
                           [p.cost for p in done], [p.n_candidates for p in done],
                           float(np.mean(seconds)) if seconds else None,
                           actions, np.asarray(state),
                           earlier_s + time.perf_counter() - start,
                           sum(p.n_rollouts for p in done),
                           sum(p.n_unstable_rollouts for p in done), bool(reasons),
                           "; ".join(reasons), sum(p.n_infeasible_rollouts for p in done),
                           segments)


def _trial_difference(saved, trial: dict) -> str:
    """How a checkpoint's trial identity ``saved`` differs from ``trial``'s."""
    if not isinstance(saved, dict):
        return "it names no trial"
    parts = [f"{k} {saved.get(k)!r}, not {trial[k]!r}" for k in ("method", "seed")
             if saved.get(k) != trial[k]]
    theirs = saved.get("settings") if isinstance(saved.get("settings"), dict) else {}
    other = sorted(k for k in set(theirs) | set(trial["settings"])
                   if theirs.get(k) != trial["settings"].get(k))
    if other:
        parts.append("other settings: " + ", ".join(other))
    return "; ".join(parts)


def solve(settings: PickPlaceSettings, method: str = "simple", seed: int = 0,
          on_iteration: Callable[[int, float], None] | None = None,
          checkpoint=None) -> PickPlaceResult:
    """One trial in one call: build the problem, plan every stage with ``method``, execute,
    measure. The same settings, method and seed give the same result, also when the trial
    is stopped and resumed from its ``checkpoint`` (``run_problem``).

    Raises:
        TypeError / ValueError: settings that are not PickPlaceSettings, an unknown method, a
            seed that is not an int >= 0, an on_iteration that is not callable.
    """
    if on_iteration is not None and not callable(on_iteration):
        raise TypeError(f"on_iteration must be callable or None, got {on_iteration!r}")
    planner = make_planner(method, settings, seed)      # checks all three before any scene
    problem = make_problem(settings, seed)
    return run_problem(problem, planner, method=method, seed=seed, on_iteration=on_iteration,
                       checkpoint=checkpoint)


def run_trial(params: dict, on_iteration: Callable[[int, float], None] | None = None,
              checkpoint=None) -> dict:
    """``solve`` for ``dopt.sweep``: params {"settings": PickPlaceSettings.to_dict(),
    "method", "seed"} -> ``PickPlaceResult.to_dict()``; the sweep's ``checkpoint`` lets a
    stopped trial resume."""
    settings = PickPlaceSettings.from_dict(params["settings"])
    return solve(settings, params["method"], int(params["seed"]), on_iteration,
                 checkpoint).to_dict()


def summarize(results: Sequence[dict], methods: Sequence[str],
              metric_names: Sequence[str]) -> dict:
    """Per method (in ``methods`` order, those with results): the mean, 95 % CI half-width
    (None with one seed) and per-seed values of each metric, the candidates (last stage and
    per stage), the mean seconds per CEM iteration (None when scripted), the seeds, each
    seed's ``last_improvement`` (None when scripted), the
    rollouts simulated and flagged unstable, and the trials whose executed plan was unstable.
    The means and intervals are over the stable trials only; the per-seed values list every
    trial (``unstable_seeds`` marks the others). Every method beside "simple" also holds each
    metric's difference to CEM(Simple), ``<metric>_minus_simple_mean`` and ``_ci95`` (its mean
    minus Simple's and the Welch 95 % half-width, ``dopt.stats.difference_ci``): whether the
    two differ where their own intervals overlap.

    results: ``PickPlaceResult.to_dict()`` of finished trials.
    """
    out, stable_values = {}, {}
    for m in methods:
        runs = sorted((r for r in results if r["method"] == m), key=lambda r: r["seed"])
        if not runs:
            continue
        entry: dict = {}
        stable = [r for r in runs if not r["unstable"]]
        for name in metric_names:
            mean, ci = mean_ci([r[name] for r in stable]) if stable else (None, None)
            entry[f"{name}_mean"], entry[f"{name}_ci95"] = _finite(mean), _finite(ci)
            entry[f"{name}s"] = [r[name] for r in runs]
            stable_values[m, name] = [r[name] for r in stable]
        entry["n_candidates"] = int(runs[0]["n_candidates"][-1])
        entry["n_candidates_per_stage"] = runs[0]["n_candidates"]
        secs = [r["s_per_iteration"] for r in runs if r["s_per_iteration"] is not None]
        entry["s_per_iteration"] = float(np.mean(secs)) if secs else None
        entry["seeds"] = [r["seed"] for r in runs]
        entry["last_improvements"] = [last_improvement(r) for r in runs]
        entry["n"] = len(runs)
        entry["n_stable"] = len(stable)
        entry["n_unstable_trials"] = len(runs) - len(stable)
        entry["unstable_seeds"] = [r["seed"] for r in runs if r["unstable"]]
        entry["n_rollouts"] = int(sum(r["n_rollouts"] for r in runs))
        entry["n_unstable_rollouts"] = int(sum(r["n_unstable_rollouts"] for r in runs))
        entry["n_infeasible_rollouts"] = int(sum(r.get("n_infeasible_rollouts", 0)
                                                 for r in runs))
        out[m] = entry
    for m, entry in out.items():
        for name in metric_names if m != "simple" and "simple" in out else ():
            xs, ys = stable_values["simple", name], stable_values[m, name]
            diff, half = difference_ci(xs, ys) if xs and ys else (None, None)
            entry[f"{name}_minus_simple_mean"] = _finite(diff)
            entry[f"{name}_minus_simple_ci95"] = _finite(half)
    return out


def last_improvement(result: dict) -> int | None:
    """The CEM iteration (1-based, within the last stage) after which that stage's best cost
    last fell: the stage's iteration count means it was still falling at the end. None for a
    trial without CEM iterations (scripted).

    result: ``PickPlaceResult.to_dict()``."""
    if result.get("s_per_iteration") is None:
        return None
    stages = result["stage_of_iteration"]
    last = [c for c, k in zip(result["cost_history"], stages, strict=True) if k == stages[-1]]
    falls = [i for i in range(1, len(last)) if last[i] < last[i - 1]]
    return (falls[-1] if falls else 0) + 1


def _check_seed(seed) -> None:
    check_int(seed, "seed", minimum=0)
    if seed >= 2 ** 63:
        raise ValueError(f"seed must be < 2**63, got {seed}")


def _check_settings(settings) -> None:
    if not isinstance(settings, PickPlaceSettings):
        raise TypeError(f"settings must be PickPlaceSettings (PickPlaceSettings.preset or "
                        f"from_dict), got {type(settings).__name__}")


def _check_fields(cls, d: dict, name: str) -> None:
    """ValueError naming the fields of dataclass ``cls`` that ``d`` lacks or does not know."""
    import dataclasses

    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = sorted(set(d) - set(fields))
    missing = sorted(n for n, f in fields.items() if n not in d
                     and f.default is dataclasses.MISSING
                     and f.default_factory is dataclasses.MISSING)
    if unknown or missing:
        raise ValueError(f"{name} does not match {cls.__name__}: "
                         + "; ".join(([f"missing {missing}"] if missing else [])
                                     + ([f"unknown {unknown}"] if unknown else [])))


def _finite(x: float | None) -> float | None:
    return None if x is None or not np.isfinite(x) else float(x)
