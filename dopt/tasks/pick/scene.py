"""Rope and cloth scenes with the picker, and the pick-and-place task that CEM evaluates.

``DeformableScene`` is a compiled flex object plus the picker (built by ``rope_scene`` and
``cloth_scene`` next to this module). ``PickPlaceTask`` holds a scene, a start state and a goal
shape, and turns a population of pick-and-place action sequences into costs with one batched
rollout: the paper's objective (Eq. 2), the mean distance of the particles to their goal
positions.

Blow-up captures (``PickPlaceTask(..., blowup_out=OUT)``, opt-in): an executed action sequence
(``execute``, ``step``; never a population that ``evaluate`` scores) that the stability verdict
flags is re-simulated from its start to the flagged step (``dopt.blowup.capture_blowup``)
and its last ``dopt.blowup.KEEP`` states, the model and the verdict are written to
``OUT/blowups/<blowup_label>``, which ``dopt-view`` opens at that step; ``blowups`` lists them.

Shapes: P population, H actions per sequence, K steps per action, N particles, ns state size.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Iterable
from dataclasses import dataclass, replace

import mujoco
import numpy as np

from dopt.blowup import capture_blowup, capture_dir
from dopt.rollout import RolloutConfig, RolloutResult, RolloutService
from dopt.scene import Scene
from dopt.stability import StabilityBounds
from dopt.state import check_model, check_states
from dopt.tasks.pick.constraints import ActionConstraint
from dopt.tasks.pick.picker import CONTROL_SPEC, Picker, PickerConfig, fix_grasp_anchors
from dopt.tasks.pick.settle import RestTest, rollout_until_rest
from dopt.validation import check_real, float_array, index_array, is_int

log = logging.getLogger(__name__)

#: the bounds rope and cloth rollouts are judged by: the defaults, and the energy gain while
#: nothing holds the object (grasp released, or the None action): 0.5 J/kg, the energy of a
#: 5 cm rise of the whole object, against a few hundredths of a J/kg that random pick-and-place
#: on the presets gains there (docs/results/physics-*-verdict.json) and about 10 J/kg of a
#: sheet thrown 1 m up (docs/DESIGN-NOTES.md, "Energy")
PICK_BOUNDS = StabilityBounds(max_energy_gain=0.5)


def check_pickable(pickable: Iterable[int] | None, n: int, picker) -> np.ndarray:
    """The pickable particles of an object of n: (k,) unique ints in [0, n) (None: all), for
    a picker built from the ``PickerConfig`` ``picker``."""
    if not isinstance(picker, PickerConfig):
        raise TypeError(f"picker must be a PickerConfig, got {type(picker).__name__}")
    if pickable is None:
        return np.arange(n)
    if isinstance(pickable, Iterable) and not isinstance(pickable, (np.ndarray, str)):
        pickable = list(pickable)
    ids = index_array(pickable, "pickable", n)
    if len(np.unique(ids)) != len(ids):
        raise ValueError(f"pickable has repeated particles: {ids.tolist()}")
    return ids


#: the constraint solvers a scene config may name
SOLVERS = ("CG", "Newton", "PGS")
#: MuJoCo's midphase strategies for a flex's self-collision (``<contact selfcollide>``)
SELFCOLLIDE_MODES = ("none", "narrow", "bvh", "sap", "auto")


def selfcollide_mode(value, name: str) -> str:
    """A scene config's ``selfcollide`` as MuJoCo's attribute: False -> "none", True ->
    "auto" (sap for 1D and 2D flexes), or one of ``SELFCOLLIDE_MODES`` by name; TypeError /
    ValueError naming ``name`` otherwise."""
    if isinstance(value, (bool, np.bool_)):
        return "auto" if value else "none"
    if not isinstance(value, str):
        raise TypeError(f"{name} must be a bool or one of {list(SELFCOLLIDE_MODES)}, "
                        f"got {value!r}")
    if value not in SELFCOLLIDE_MODES:
        raise ValueError(f"{name} must be a bool or one of {list(SELFCOLLIDE_MODES)}, "
                         f"got {value!r}")
    return value


def physics_fields(presets: dict, name: str, fields: dict) -> dict:
    """The fields of preset ``name`` that ``fields`` does not set; ValueError naming an unknown
    preset."""
    if not isinstance(name, str) or name not in presets:
        raise ValueError(f"unknown physics preset {name!r}; choose from {', '.join(presets)}")
    return {k: v for k, v in presets[name].items() if k not in fields}


def floor_scene_xml(name: str, option: str, memory_mb: int, floor: str, flexcomp: str,
                    picker_parts: tuple[str, str, str]) -> str:
    """MJCF shell shared by the rope and cloth: options, a lit floor, one flexcomp, the picker.

    option: extra <option> attributes after the discrete integrator (solver, timestep, ...);
    floor: extra attributes of the floor geom; flexcomp: the <flexcomp> element;
    picker_parts: (body, equalities, actuators) from ``picker_mjcf``.
    """
    body, eqs, acts = picker_parts
    return f"""
<mujoco model="{name}">
  <option integrator="discrete" {option}/>
  <size memory="{memory_mb}M"/>
  <visual><global offwidth="640" offheight="480"/></visual>
  <worldbody>
    <light pos="0 0 2" dir="0 0 -1" diffuse=".8 .8 .8"/>
    <geom name="floor" type="plane" size="2 2 .05" {floor} rgba=".85 .85 .8 1"/>
    {flexcomp}
    {body}
  </worldbody>
  <equality>{eqs}</equality>
  <actuator>{acts}</actuator>
</mujoco>"""


class DeformableScene:
    """A compiled rope or cloth (one flex) with the picker.

    Args:
        model: compiled model holding flex ``flex`` and the picker (see ``picker_mjcf``); its
            grasp anchors are fixed in place (``fix_grasp_anchors``).
        flex: name of the flex; its vertex bodies are ``<flex>_<i>``.
        picker: the picker config the model was built with.
        settle: seconds the object settles to make ``initial_state``.
        positions: (N, 3) start positions of the particles (None: the compiled layout).
        stability: the bounds rollouts of this scene are judged by (``PICK_BOUNDS``; the
            picker, a massless virtual gripper, is never judged: not its speed, and its
            servo and grasps are what end a free window of the energy bound).

    Attributes:
        scene: the ``dopt.Scene``; picker: the ``Picker``; radius: particle radius (m);
        initial_state: (ns,) the settled start state; n_particles: N; elements: (E, d + 1)
        the flex's elements in particle indices (cloth: triangles, rope: segments); xml: the
        MJCF the model was compiled from, when given (what other models are built on, e.g.
        the arm's in ``panda_gripper``).
    """

    def __init__(self, model: mujoco.MjModel, flex: str, picker: PickerConfig,
                 settle: float = 0.2,
                 positions: np.ndarray | None = None,
                 stability: StabilityBounds = PICK_BOUNDS, xml: str | None = None):
        check_model(model)
        if not isinstance(stability, StabilityBounds):
            raise TypeError(f"stability must be a StabilityBounds, got "
                            f"{type(stability).__name__}")
        if not isinstance(flex, str):
            raise TypeError(f"flex must be the flex's name, got {flex!r}")
        check_real(settle, "settle", minimum=0)
        fix_grasp_anchors(model)
        self.model = model
        unjudged = tuple(dict.fromkeys(stability.unjudged_bodies + ("picker",)))
        self.scene = Scene(model, stability=replace(stability, unjudged_bodies=unjudged))
        self.flex = flex
        f = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_FLEX, flex)
        if f < 0:
            raise ValueError(f"model has no flex named {flex!r}")
        self.n_particles = int(model.flex_vertnum[f])
        self.radius = float(model.flex_radius[f])
        corners = int(model.flex_dim[f]) + 1
        start = int(model.flex_elemdataadr[f])
        self.elements = model.flex_elem[start:start + corners * int(model.flex_elemnum[f])] \
            .reshape(-1, corners).astype(np.int64)
        bodies = model.flex_vertbodyid[model.flex_vertadr[f]:][:self.n_particles]
        vertices = [f"vertex:{model.flex_vertadr[f] + i}" for i in range(self.n_particles)]
        self._qpos = np.stack([self.scene.qpos_indices(v) for v in vertices])          # (N, 3)
        self._origin = model.body_pos[bodies] - model.qpos0[self._qpos]               # (N, 3)
        #: (N, 3) qvel indices of the particles' linear velocities
        self.velocity_dofs = np.stack([self.scene.dofs(v) for v in vertices])
        self.picker = Picker(model, self.n_particles, picker)
        self.xml = xml
        state = self.scene.state_of(mujoco.MjData(model))
        if positions is not None:
            state = self.with_positions(state, positions)
        self.initial_state = self.settle(state, settle)

    @property
    def nstate(self) -> int:
        return self.scene.nstate

    def positions(self, states: np.ndarray) -> np.ndarray:
        """Particle positions of state rows: (..., ns) -> (..., N, 3)."""
        states = float_array(states, "states", finite=False)
        if states.shape[-1:] != (self.nstate,):
            raise ValueError(f"states must have shape (..., {self.nstate}), got {states.shape}")
        qpos = states[..., self.scene.layout["qpos"]]
        return self._origin + qpos[..., self._qpos]

    def with_positions(self, state: np.ndarray, positions: np.ndarray) -> np.ndarray:
        """A copy of state row (ns,) with the particles placed at positions (N, 3), at rest."""
        out = check_states(self.model, state, batched=False, name="state").copy()
        pos = float_array(positions, "positions", (self.n_particles, 3))
        lay = self.scene.layout
        qpos = out[lay["qpos"]]
        qpos[self._qpos] = pos - self._origin
        out[lay["qpos"]] = qpos
        out[lay["qvel"]] = 0.0
        out[lay["warmstart"]] = 0.0
        return out

    def settle(self, state: np.ndarray, seconds: float) -> np.ndarray:
        """Let the object come to rest holding nothing: (ns,) -> (ns,)."""
        m = self.model
        state = check_states(m, state, batched=False, name="state")
        seconds = check_real(seconds, "seconds", minimum=0)
        data = mujoco.MjData(m)
        mujoco.mj_setState(m, data, state, self.scene.layout.spec)
        mujoco.mj_setState(m, data, self.picker.idle_row, CONTROL_SPEC)
        for _ in range(int(round(seconds / m.opt.timestep))):
            mujoco.mj_step(m, data)
        return self.scene.state_of(data)


def mean_distance(positions: np.ndarray, goal: np.ndarray) -> np.ndarray:
    """Eq. 2 of the paper as a mean: mean particle distance to the goal (m).

    positions (..., N, 3), goal (N, 3) -> (...).
    """
    return np.linalg.norm(np.asarray(positions) - goal, axis=-1).mean(axis=-1)


def end_to_end(positions: np.ndarray) -> np.ndarray:
    """Distance between the first and last particle (m): (..., N, 3) -> (...)."""
    p = np.asarray(positions)
    return np.linalg.norm(p[..., -1, :] - p[..., 0, :], axis=-1)


def matching_distance(positions: np.ndarray, goal: np.ndarray) -> float:
    """Mean particle distance under the best one-to-one matching of particles to goal
    positions (the paper's rope-folding metric: bipartite matching, scipy's
    ``linear_sum_assignment``): (N, 3), (N, 3) -> m. At most ``mean_distance``."""
    from scipy.optimize import linear_sum_assignment

    p, g = np.asarray(positions, dtype=float), np.asarray(goal, dtype=float)
    if p.shape != g.shape or p.ndim != 2 or p.shape[1] != 3 or not len(p):
        raise ValueError(f"positions and goal must both be (N, 3) with N >= 1, got {p.shape} "
                         f"and {g.shape}")
    d = np.linalg.norm(p[:, None] - g[None], axis=-1)
    rows, cols = linear_sum_assignment(d)
    return float(d[rows, cols].mean())


class PickPlaceTask:
    """Bring a scene's object from a start state to a goal shape with pick-and-place actions.

    This is what ``planners.cem`` asks for costs: ``evaluate`` runs a population of action
    sequences as one batched rollout and returns Eq. 2 for each.

    Args:
        scene: the rope or cloth scene.
        goal: (N, 3) goal particle positions (m).
        start_state: (ns,) state to plan from (default: the scene's initial state).
        rollout: the rollout service (default: a new one on every core).
        planning_scene: a cheaper model of the same object (e.g. another physics preset of the
            same resolution) on which ``evaluate`` simulates the population; ``execute``, and
            every cost reported of an executed plan, stay on ``scene``. Its states must have
            the layout of ``scene``'s (the start state carries over).
        planning_rollout: the planning scene's rollout service.
        blowup_out: optional run folder: an executed sequence the verdict flags writes a
            blow-up capture to ``blowup_out/blowups/<blowup_label>`` (``-2``, ... where one
            exists; the module docstring), listed in ``blowups``. None (default): no capture.
        blowup_label: the captures' name (in the folder, the console and the viewer).
        rest: settle until at rest in ``evaluate`` (``dopt.tasks.pick.settle``): a sampled
            rollout's settle ends once its object is at rest; ``execute`` and ``step`` keep
            the picker's full settle, so an executed plan replays unchanged. None: every
            sample simulates every step. ``n_steps`` and ``n_full_steps`` count the steps
            ``evaluate`` simulated and those a full settle would have (and, with sized moves,
            ``PickerConfig.move``, those fixed moves would have).
    """

    def __init__(self, scene: DeformableScene, goal: np.ndarray,
                 start_state: np.ndarray | None = None,
                 rollout: RolloutService | None = None,
                 planning_scene: DeformableScene | None = None,
                 planning_rollout: RolloutService | None = None,
                 blowup_out: str | os.PathLike | None = None, blowup_label: str = "pick",
                 rest: RestTest | None = None):
        if not isinstance(scene, DeformableScene):
            raise TypeError(f"scene must be a DeformableScene, got {type(scene).__name__}")
        if rollout is not None and not callable(getattr(rollout, "rollout", None)):
            raise TypeError(f"rollout must be a dopt.RolloutService, got "
                            f"{type(rollout).__name__}")
        if blowup_out is not None and not isinstance(blowup_out, (str, os.PathLike)):
            raise TypeError(f"blowup_out must be a folder path or None, got "
                            f"{type(blowup_out).__name__}")
        if not isinstance(blowup_label, str):
            raise TypeError(f"blowup_label must be a string, got {type(blowup_label).__name__}")
        if rest is not None and not isinstance(rest, RestTest):
            raise TypeError(f"rest must be a RestTest or None, got {type(rest).__name__}")
        if rest is not None and scene.picker.config.move != "fixed":
            raise ValueError(f"rest: the rest test needs the fixed move (PickerConfig.move "
                             f"'fixed'), the picker's is {scene.picker.config.move!r}")
        self.blowup_out, self.blowup_label, self.blowups = blowup_out, blowup_label, []
        self.rest = rest
        self.n_steps = self.n_full_steps = 0
        self.scene = scene
        self.goal = float_array(goal, "goal", (scene.n_particles, 3))
        state = scene.initial_state if start_state is None else start_state
        self.start_state = check_states(scene.model, state, batched=False, name="start_state")
        self.service = rollout or RolloutService(scene.scene, RolloutConfig())
        self.picker = scene.picker
        self.n_evaluated = 0
        self.n_unstable = 0
        self.n_infeasible = 0
        self.planning = None
        if planning_scene is not None:
            if not isinstance(planning_scene, DeformableScene):
                raise TypeError(f"planning_scene must be a DeformableScene, got "
                                f"{type(planning_scene).__name__}")
            if (planning_scene.n_particles != scene.n_particles
                    or planning_scene.scene.nstate != scene.scene.nstate):
                raise ValueError(
                    f"planning_scene must model the same object: {planning_scene.n_particles} "
                    f"particles and {planning_scene.scene.nstate} state entries against "
                    f"{scene.n_particles} and {scene.scene.nstate}")
            self.planning = PickPlaceTask(planning_scene, self.goal, self.start_state,
                                          planning_rollout)

    @property
    def n_particles(self) -> int:
        return self.scene.n_particles

    @property
    def bound(self) -> np.ndarray:
        """(3,) largest displacement per axis (m)."""
        return self.picker.bound

    @property
    def constraint(self) -> ActionConstraint | None:
        """C(a_t): the workspace box the picker's joints keep every action in, and the stretch
        limit ``evaluate`` judges (``dopt.tasks.pick.constraints``); None: unconstrained."""
        return self.picker.config.workspace

    def rollout(self, particles, displacements, start: np.ndarray | None = None
                ) -> RolloutResult:
        """A population of action sequences, (P, H), (P, H, 3), simulated from ``start`` (ns,)
        (default: the task's start state): final states (P, ns) and the stability verdict.
        Each sequence takes its own steps (``Picker.schedule``).

        Raises:
            ValueError: a bad action (see ``Picker.check``).
        """
        return self._simulate(particles, displacements, start)[0]

    def _simulate(self, particles, displacements, start: np.ndarray | None = None
                  ) -> tuple[RolloutResult, np.ndarray]:
        """``rollout`` and the steps (P,) each sequence simulated."""
        plan = self.picker.schedule(_numpy(particles), _numpy(displacements))
        x0 = self.start_state if start is None else check_states(
            self.scene.model, start, batched=False, name="start")
        return self.service.rollout(x0, plan.controls, control_spec=CONTROL_SPEC,
                                    lengths=plan.lengths), plan.lengths

    def cost(self, states: np.ndarray) -> np.ndarray:
        """Eq. 2 (mean particle distance to the goal, m) of state rows: (..., ns) -> (...)."""
        return mean_distance(self.scene.positions(states), self.goal)

    def evaluate(self, particles, displacements):
        """Costs of a population: (P, H) ints (NONE = -1), (P, H, 3) metres -> (P,) torch
        float64 tensor (numpy in, numpy out). An unstable rollout (``dopt.stability``) costs
        +inf, and so does one that breaks the constraint's stretch limit (infeasible);
        ``n_evaluated``, ``n_unstable`` and ``n_infeasible`` count them over the task's life.
        With a planning scene, the population is simulated there."""
        model = self.planning or self
        if self.rest is None:
            res, lengths = model._simulate(particles, displacements)
            steps = int(lengths.sum())
            full = res.final_states.shape[0] * model.picker.steps_per_action \
                * np.shape(particles)[-1]
        else:
            rested = rollout_until_rest(model.service, model.picker,
                                        model.scene.velocity_dofs, model.start_state,
                                        _numpy(particles), _numpy(displacements), self.rest)
            res = rested.result
            steps, full = int(rested.steps.sum()), rested.full_steps * len(rested.steps)
        self.n_steps += int(steps)
        self.n_full_steps += int(full)
        st = res.stability
        stretched = (self.constraint.stretched(st.max_strain) if self.constraint is not None
                     else np.zeros(len(st.unstable), bool)) & ~st.unstable
        costs = np.where(st.unstable | stretched, np.inf, model.cost(res.final_states))
        self.n_evaluated += len(costs)
        self.n_unstable += st.n_unstable
        self.n_infeasible += int(stretched.sum())
        if _is_torch(particles) or _is_torch(displacements):
            import torch
            return torch.from_numpy(costs)
        return costs

    def positions(self, states: np.ndarray) -> np.ndarray:
        """Particle positions: (..., ns) -> (..., N, 3)."""
        return self.scene.positions(states)

    def execute(self, particles, displacements, start: np.ndarray | None = None) -> Execution:
        """One action sequence, (H,), (H, 3), from ``start`` (ns,) (default: the task's start
        state): its final state and verdict (with ``blowup_out``, a flagged one is captured:
        the module docstring)."""
        particles = np.asarray(_numpy(particles))[None]
        displacements = np.asarray(_numpy(displacements), dtype=float)[None]
        res = self.rollout(particles, displacements, start)
        st = res.stability
        done = Execution(res.final_states[0], bool(st.unstable[0]), int(st.step[0]),
                         st.reason[0], float(st.max_speed[0]), float(st.max_penetration[0]),
                         float(st.max_strain[0]))
        if done.unstable and self.blowup_out is not None:
            self._capture(self.picker.encode(particles, displacements)[0],
                          self.start_state if start is None else start, done)
        return done

    def step(self, state: np.ndarray, particle: int, displacement) -> Execution:
        """One action from ``state`` (ns,): ``particle`` an int (NONE = -1), ``displacement``
        (3,) metres."""
        if not is_int(particle):
            raise TypeError(f"particle must be an int (or NONE = -1), got {particle!r}")
        disp = float_array(_numpy(displacement), "displacement", (3,), finite=False)
        return self.execute([particle], disp[None], state)

    def _capture(self, controls: np.ndarray, start: np.ndarray, done: Execution) -> None:
        """The blow-up capture of an executed sequence, its control rows (T, nc) of
        ``CONTROL_SPEC`` from ``start`` (ns), that ``done`` flagged: re-simulated up to
        ``done.step``, its folder added to ``blowups`` (one that cannot be written is logged,
        and the run goes on)."""
        try:
            out = capture_blowup(capture_dir(self.blowup_out, self.blowup_label),
                                 self.scene.model, start, controls, done.step, done.reason,
                                 spec=self.scene.scene.layout.spec, control_spec=CONTROL_SPEC,
                                 xml=self.scene.xml, label=self.blowup_label)
        except OSError as e:
            log.error("the blow-up capture of step %d (%s) was not written: %s", done.step,
                      done.reason, e)
            return
        self.blowups.append(str(out))


@dataclass(frozen=True)
class Execution:
    """An executed action sequence: the final state (ns,), whether the simulation broke a
    stability bound (``dopt.stability``), the step and reason, and the extremes seen."""

    state: np.ndarray
    unstable: bool
    step: int
    reason: str
    max_speed: float
    max_penetration: float
    max_strain: float


def _is_torch(x) -> bool:
    return type(x).__module__.startswith("torch")


def _numpy(x):
    return x.detach().cpu().numpy() if _is_torch(x) else x
