"""``PickPlaceSettings``: everything that defines a pick-and-place trial except the method and
the seed, its presets (``planners.pick_place.presets``), its scene and picker configs, and
its identity (what names a trial: the settings and what their presets resolve to today;
``planners.pick_place.trial_names``).

The task names a ``PickTaskSpec`` (``planners.pick_place.tasks.PICK_TASKS``): its scene
config, the fields that config takes and the object's extent come from there, so no method
here branches on the task's name.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import asdict, dataclass, field

import numpy as np

from dopt.lab.dicts import flatten
from dopt.tasks.pick.cloth_scene import PHYSICS_PRESETS
from dopt.tasks.pick.constraints import ActionConstraint
from dopt.tasks.pick.picker import MOVE_RULES, PickerConfig
from dopt.tasks.pick.scene import PICK_BOUNDS
from dopt.tasks.pick.settle import RestTest
from dopt.validation import check_config, check_int
from planners.cem import CEMConfig
from planners.pick_place.drag_settings import DragSettings
from planners.pick_place.presets import PROTOCOLS, quick_preset
from planners.pick_place.tasks import (
    GOALS,
    PICK_TASKS,
    PREPARED_LIFT,
    PREPARED_SETTLE,
    pick_task,
)
from planners.scripted import ScriptedConfig
from planners.trial_progress import RUN_ONLY_SETTINGS

#: optional settings ``PickPlaceSettings.identity`` leaves out at None: options whose unset
#: value is what every trial ran before they existed, so those trials stay valid
UNSET_SETTINGS = ("planning_physics", "max_stretch", "picker_speed", "rest_speed",
                  "picker_move", "fold_start", "mass", "drag")
#: the name of each optional setting whose unset value (None) has one (``departures``)
UNSET_NAMES = {"picker_move": "fixed", "fold_start": "chained"}
#: where a goal of several stages starts (``PickPlaceSettings.fold_start``)
FOLD_STARTS = ("chained", "prepared")
#: scene-config fields a trial's identity leaves out at these values, for the same reason
UNSET_SCENE_FIELDS = {"passive": False}
#: picker-config fields a trial's identity leaves out while the move is the fixed one (they
#: came with the sized move, and the fixed move ignores them), for the same reason
UNSET_PICKER_FIELDS = ("move", "min_move")


@dataclass(frozen=True)
class PickPlaceSettings:
    """Everything that defines a pick-and-place trial except the method and the seed.

    Attributes:
        task: a registered task (``PICK_TASKS``): "cloth" or "rope".
        goal: one of ``GOALS[task]``.
        n: particles per side (cloth, N = n * n) or along the rope (N = n).
        bound: largest picker displacement per axis of one action (m).
        cem: the CEM settings of every stage (``horizon`` is H).
        scripted: the scripted policy's settings.
        selfcollide: cloth self-collision (the multi-layer folds need it).
        side: cloth edge length (m).
        length: rope length (m).
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
        rest_speed: settle CEM's sampled rollouts until at rest (m/s, the particles'
            root-mean-square speed, ``dopt.tasks.pick.settle.RestTest``): a sample's settle
            ends once slower; executed plans keep the full settle. None: every sample
            simulates every step.
        picker_move: how long each action's move lasts (``PickerConfig.move``): None (the
            default) or "fixed", as long as the bound box's diagonal takes; "sized", as long
            as the action's own displacement takes at the same speed (fewer steps; not with
            ``rest_speed``). "fixed" is stored as None, so that a trial keeps its key.
        fold_start: where a goal of several stages (the reflective and underneath folds)
            starts (``FOLD_STARTS``): None or "chained" (the default), every stage planned in
            turn from the goal's start (the flat sheet), each from where the one before
            ended; "prepared", from the fold before the last prepared in place as the paper's
            authors do (``PickGoal.prepared``: its layers dropped and settled), only the last
            stage planned. On a goal of one stage both are its one start: "prepared" is
            stored as None there, and "chained" everywhere, so that a trial keeps its key.
        mass: the object's mass (kg; its scene config's ``mass``), for a task whose scene
            fields name it (the cloth); None: the physics preset's.
        drag: the authors' drag encoding (``DragSettings``) that the drag methods plan in
            (``planners.pick_place.drag``); None: none (the macro methods ignore it).
    """

    # the bounds and choices of a field are its metadata (``check_config`` and the flags of
    # ``dopt.lab.flags`` read them); its documentation is the Attributes section above
    task: str
    goal: str
    n: int = field(metadata={"at_least": 3})
    bound: float = field(metadata={"above": 0})
    cem: CEMConfig
    scripted: ScriptedConfig = ScriptedConfig()
    selfcollide: bool = False
    side: float = field(default=0.3, metadata={"above": 0})
    length: float = field(default=0.5, metadata={"above": 0})
    physics: str = field(default="default", metadata={"choices": tuple(PHYSICS_PRESETS)})
    threads: int = field(default=0, metadata={"at_least": 0})
    planning_physics: str | None = field(default=None,
                                         metadata={"choices": tuple(PHYSICS_PRESETS)})
    max_stretch: float | None = field(default=None, metadata={"above": 0})
    picker_speed: float | None = field(default=None, metadata={"above": 0})
    rest_speed: float | None = field(default=None, metadata={"above": 0})
    picker_move: str | None = field(default=None, metadata={"choices": MOVE_RULES})
    fold_start: str | None = field(default=None, metadata={"choices": FOLD_STARTS})
    mass: float | None = field(default=None, metadata={"above": 0})
    drag: DragSettings | None = None

    def __post_init__(self):
        pick_task(self.task).goal(self.goal)      # ValueError naming an unknown task or goal
        if not isinstance(self.cem, CEMConfig):
            raise TypeError(f"PickPlaceSettings.cem must be a CEMConfig, got {self.cem!r}")
        if not isinstance(self.scripted, ScriptedConfig):
            raise TypeError(f"PickPlaceSettings.scripted must be a ScriptedConfig, got "
                            f"{self.scripted!r}")
        # the annotations and the fields' metadata (bounds, choices); TypeError or ValueError
        # naming the field
        check_config(self)
        if self.drag is not None and not isinstance(self.drag, DragSettings):
            raise TypeError(f"PickPlaceSettings.drag must be DragSettings or None, got "
                            f"{self.drag!r}")
        if self.picker_move == "fixed":        # the default's own name: the same trial
            object.__setattr__(self, "picker_move", None)
        if self.picker_move is not None and self.rest_speed is not None:
            raise ValueError(f"PickPlaceSettings.picker_move {self.picker_move!r} cannot go "
                             f"with rest_speed (the rest test needs the fixed move)")
        if self.mass is not None and "mass" not in PICK_TASKS[self.task].scene_fields:
            raise ValueError(f"PickPlaceSettings.mass: the {self.task} scene takes no mass "
                             f"from the settings (its physics preset sets it)")
        if self.fold_start == "chained" or pick_task(self.task).goal(self.goal).prepared is None:
            object.__setattr__(self, "fold_start", None)     # the same trial as the default's
        for name in ("n", "threads"):          # numpy scalars -> Python (JSON-able to_dict)
            object.__setattr__(self, name, int(getattr(self, name)))
        for name in ("bound", "side", "length"):
            object.__setattr__(self, name, float(getattr(self, name)))
        if self.mass is not None:
            object.__setattr__(self, "mass", float(self.mass))
        object.__setattr__(self, "selfcollide", bool(self.selfcollide))

    @classmethod
    def preset(cls, task: str, goal: str, quick: bool = False,
               protocol: str = "ours") -> PickPlaceSettings:
        """The settings the experiments run by default: ``protocol`` "ours" (``PRESETS``) or
        "paper" (``PAPER_PRESETS``, Fig. 7 at the paper's CEM budget); ``quick`` shrinks
        either to a smoke run (``QUICK_CHANGES``: 8 x 8 cloth or 20-particle rope, population
        8, 2 iterations)."""
        if protocol not in PROTOCOLS:
            raise ValueError(f"unknown protocol {protocol!r}; choose from {', '.join(PROTOCOLS)}")
        presets = PROTOCOLS[protocol]
        if (task, goal) not in presets:
            raise ValueError(f"no preset for {task!r} / {goal!r}; choose from {GOALS}")
        if not isinstance(quick, (bool, np.bool_)):
            raise TypeError(f"quick must be a bool, got {quick!r}")
        p = quick_preset(task, presets[task, goal]) if quick else presets[task, goal]
        cem = CEMConfig(horizon=p.horizon, iterations=p.iterations, population=p.population,
                        elites=p.elites)
        return cls(task, goal, p.n, p.bound, cem, ScriptedConfig(), p.selfcollide,
                   physics=p.physics, planning_physics=p.planning_physics,
                   fold_start=p.fold_start)

    def departures(self, protocol: str = "ours", quick: bool = False) -> dict:
        """{field: value} of these settings that differ from ``preset(task, goal, quick,
        protocol)``, nested configs as dotted names ("cem.population"); the thread count is
        not a setting of the experiment and is left out; an optional setting the preset sets
        and these leave unset is named by its unset value (``UNSET_NAMES``: "fold_start":
        "chained"). Empty: the protocol as it stands."""
        base = flatten(type(self).preset(self.task, self.goal, quick, protocol).to_dict())
        mine = flatten(self.to_dict())
        unset = {k: UNSET_NAMES.get(k) for k in base if k not in mine}
        return {k: v for k, v in {**mine, **unset}.items()
                if k not in RUN_ONLY_SETTINGS and base.get(k) != v}

    def constraint(self) -> ActionConstraint:
        """C(a_t) of the task (``dopt.tasks.pick.constraints``): SoftGym's workspace, the
        object's size on each side of its centre (the task's ``extent``: a cloth's side, a
        rope's length), 0.5 m high."""
        return ActionConstraint.table(getattr(self, PICK_TASKS[self.task].extent),
                                      max_stretch=self.max_stretch)

    def picker(self) -> PickerConfig:
        """The picker of the task's scenes: the bound per axis, limited to ``constraint()``."""
        speed = {} if self.picker_speed is None else {"speed": float(self.picker_speed)}
        move = {} if self.picker_move is None else {"move": self.picker_move}
        return PickerConfig(bound=(self.bound,) * 3, workspace=self.constraint(), **speed,
                            **move)

    def rest(self) -> RestTest | None:
        """The rest test of CEM's sampled rollouts (``rest_speed``), or None."""
        return None if self.rest_speed is None else RestTest(speed=float(self.rest_speed))

    def scene_config(self, physics: str | None = None, overrides: dict | None = None):
        """The task's scene config (``ClothSceneConfig`` / ``RopeSceneConfig``) of the preset
        ``physics`` (None: ``self.physics``) with the settings' own fields (the task's
        ``scene_fields``: n, side or length, selfcollide, a cloth's mass where set) and
        ``overrides`` on top."""
        physics = self.physics if physics is None else physics
        spec = PICK_TASKS[self.task]
        fields = {name: getattr(self, name) for name in spec.scene_fields
                  if getattr(self, name) is not None}
        return spec.config.physics(physics, **{**fields, **(overrides or {})})

    def planning_scene_config(self, overrides: dict | None = None):
        """``scene_config`` of ``planning_physics``; None where CEM plans on the scene itself
        (no planning preset, or the scene's own)."""
        if self.planning_physics in (None, self.physics):
            return None
        return self.scene_config(self.planning_physics, overrides)

    def resolved_physics(self) -> dict:
        """JSON-able scene and picker configs these settings run (what a preset name means
        today) and the stability bounds their rollouts are judged by (CEM scores an unstable
        sample +inf): a trial's identity, so that a changed preset, picker or verdict is not
        reused. Scene fields in ``UNSET_SCENE_FIELDS`` appear only when set; a prepared start
        (``fold_start``) adds its lift and settle (m, s; ``tasks.PREPARED_LIFT``,
        ``PREPARED_SETTLE``)."""
        out = {"scene": _scene_identity(self.scene_config()),
               "picker": _picker_identity(self.picker()),
               "stability": asdict(PICK_BOUNDS)}
        if self.fold_start == "prepared":
            out["prepared_start"] = {"lift": PREPARED_LIFT, "settle": PREPARED_SETTLE}
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
               if k not in RUN_ONLY_SETTINGS and not (k in UNSET_SETTINGS and v is None)}
        out["resolved"] = self.resolved_physics()
        return json.loads(json.dumps(out))

    def to_dict(self) -> dict:
        """JSON-able form (nested configs as dicts); ``from_dict`` inverts it. ``picker_move``,
        ``fold_start`` and ``drag`` appear only when set, so that the settings of a trial with
        the fixed move, the chained start and the macro encoding read as they did before the
        fields existed (in its record, the sweep's params, the presets' snapshot)."""
        out = asdict(self)
        for name in ("picker_move", "fold_start", "drag"):
            if out[name] is None:
                del out[name]
        return out

    @classmethod
    def from_dict(cls, d: dict) -> PickPlaceSettings:
        """Inverse of ``to_dict``; ValueError naming missing or unknown fields."""
        if not isinstance(d, dict):
            raise TypeError(f"PickPlaceSettings.from_dict needs a dict, got {type(d).__name__}")
        d = dict(d)
        for name, config in (("cem", CEMConfig), ("scripted", ScriptedConfig),
                             ("drag", DragSettings)):
            if isinstance(d.get(name), dict):
                check_fields(config, d[name], f"settings[{name!r}]")
                d[name] = config(**d[name])
        check_fields(cls, d, "settings")
        return cls(**d)


def _scene_identity(config) -> dict:
    """``asdict(config)`` without the ``UNSET_SCENE_FIELDS`` at their unset values."""
    return {k: v for k, v in asdict(config).items()
            if k not in UNSET_SCENE_FIELDS or v != UNSET_SCENE_FIELDS[k]}


def _picker_identity(config: PickerConfig) -> dict:
    """``asdict(config)`` without the ``UNSET_PICKER_FIELDS`` while the move is fixed."""
    out = asdict(config)
    if config.move == "fixed":
        for name in UNSET_PICKER_FIELDS:
            out.pop(name)
    return out


def check_seed(seed) -> None:
    """TypeError / ValueError unless ``seed`` is an int in [0, 2**63)."""
    check_int(seed, "seed", minimum=0)
    if seed >= 2 ** 63:
        raise ValueError(f"seed must be < 2**63, got {seed}")


def check_settings(settings) -> None:
    """TypeError unless ``settings`` is a ``PickPlaceSettings``."""
    if not isinstance(settings, PickPlaceSettings):
        raise TypeError(f"settings must be PickPlaceSettings (PickPlaceSettings.preset or "
                        f"from_dict), got {type(settings).__name__}")


def check_fields(cls, d: dict, name: str) -> None:
    """ValueError naming the fields of dataclass ``cls`` that ``d`` lacks or does not know."""
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = sorted(set(d) - set(fields))
    missing = sorted(n for n, f in fields.items() if n not in d
                     and f.default is dataclasses.MISSING
                     and f.default_factory is dataclasses.MISSING)
    if unknown or missing:
        raise ValueError(f"{name} does not match {cls.__name__}: "
                         + "; ".join(([f"missing {missing}"] if missing else [])
                                     + ([f"unknown {unknown}"] if unknown else [])))
