"""TaskModel: one instance of a pushing task; PushTaskSpec: a task by name, its constants
readable without building a model; and helpers shared by the task builders."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass

import mujoco
import numpy as np

from dopt.stability import StabilityBounds
from dopt.tasks.panda import BODY_NAMES, EE_SITE, JOINT_NAMES
from dopt.validation import check_config

#: start height of the pusher tip's centre above the table (m), and the height the initial
#: plans push at unless a task sets its own (``TaskModel.push_height``)
EE_HEIGHT = 0.04


@dataclass(frozen=True, eq=False)
class TaskModel:
    """One instance of a task: what to simulate, from where, and what the cost looks at.

    Attributes:
        name: the task's CLI name (a key of ``dopt.tasks.PUSH_TASKS``).
        model: the compiled model, fresh for each build (mutable: changes to its options
            reach everything that holds this TaskModel).
        initial_state: (ns,) ``mjSTATE_INTEGRATION`` state to start every episode from (written
            by ``mujoco.mj_getState``; time 0, objects at rest).
        goal_object: what the cost brings to the goal: a body name for a rigid object
            (clutter, soft_rigid), or the flex name for the soft task, whose position is the
            mean of its vertices.
        goal_position: (3,) world position of the goal region's centre on the table (m); the
            paper's costs use its x and y.
        distractors: bodies whose displacement from their initial position the cost penalises
            (the clutter; empty elsewhere).
        soft_body: name of the flex (the soft body), or None.
        horizon: T, the optimisation horizon (control steps).
        dt: the model time step (s), equal to ``model.opt.timestep``.
        timeout: Y, the number of agent time steps until the task ends.
        slowdown: how many times slower than real time the paper ran the agent thread.
        pushed_object_name: what the pusher touches first, a body or flex name (the soft block in
            soft_rigid, which carries the cylinder); None: ``goal_object``. The initial plans
            of ``dopt.tasks.push.warm_start`` push it.
        robot_joints: the arm's 7 hinge joints, in the order of the actuators (``ctrl[i]`` is
            the torque of ``robot_joints[i]``, N m).
        robot_bodies: the arm's bodies, base first, pusher tool last.
        ee_site: the end-effector site (the centre of the pusher's round tip).
        stability: the bounds a rollout of this task must keep (``dopt.stability``); the
            default except where a material needs others (the authors' soft blocks).
        push_height: the tool tip's centre above the table (m) on the initial plans
            (``dopt.tasks.push.warm_start``): ``EE_HEIGHT`` except where an object needs
            another (the authors' soft_rigid block).
    """

    name: str
    model: mujoco.MjModel
    initial_state: np.ndarray
    goal_object: str
    goal_position: np.ndarray
    distractors: tuple[str, ...]
    soft_body: str | None
    horizon: int
    dt: float
    timeout: int
    slowdown: int
    pushed_object_name: str | None = None
    robot_joints: tuple[str, ...] = JOINT_NAMES
    robot_bodies: tuple[str, ...] = BODY_NAMES
    ee_site: str = EE_SITE
    stability: StabilityBounds = StabilityBounds()
    push_height: float = EE_HEIGHT

    @property
    def pushed_object(self) -> str:
        """The name of what the pusher touches first (``goal_object`` unless set)."""
        return self.pushed_object_name or self.goal_object

    @property
    def robot_dofs(self) -> np.ndarray:
        """(7,) indices into qvel (and the tangent state) of ``robot_joints``."""
        return np.array([self.model.joint(name).dofadr[0] for name in self.robot_joints])

    @property
    def goal_bodies(self) -> list[int]:
        """Body ids of ``goal_object``: its body, or every vertex body of the flex."""
        return self._bodies_of(self.goal_object)

    @property
    def cost_dofs(self) -> np.ndarray:
        """(k,) indices into qvel of the object DoFs the cost reads directly.

        The world x and y translations of ``goal_object`` (of every vertex, for a flex) and of
        each distractor. ``robot_dofs`` + ``cost_dofs`` is the paper's iLQR-Naive DoF set:
        7 + 16 = 23 (clutter), 7 + 72 = 79 (soft), 7 + 2 = 9 (soft_rigid).
        """
        bodies = self.goal_bodies + [self.model.body(name).id for name in self.distractors]
        return planar_dofs(self.model, bodies)

    def _bodies_of(self, name: str) -> list[int]:
        m = self.model
        flex = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_FLEX, name)
        if flex < 0:
            return [m.body(name).id]
        start = m.flex_vertadr[flex]
        return [int(b) for b in m.flex_vertbodyid[start:start + m.flex_vertnum[flex]]]


@dataclass(frozen=True)
class PushTaskSpec:
    """A push task, registered by name (``dopt.tasks.PUSH_TASKS``): what every instance of it
    shares, readable without compiling a model, and its builder.

    Calling the spec builds an instance: ``spec(rng)`` is ``spec.build(rng)``, a fresh
    ``TaskModel`` whose horizon, dt, timeout and slowdown are the spec's and whose
    ``model.nv`` is ``nv`` (tests/dopt/tasks/push/test_specs.py holds every task to it).

    Attributes:
        name: the CLI name (``TaskModel.name``, trial params' "task").
        horizon: T, the optimisation horizon (control steps).
        dt: the model time step (s).
        timeout: Y, agent time steps until the task ends.
        slowdown: how many times slower than real time the paper ran the agent thread.
        nv: the model's DoF count (the arm's 7 and the objects').
        build: ``(numpy.random.Generator) -> TaskModel``, one instance per call.
    """

    name: str
    horizon: int
    dt: float
    timeout: int
    slowdown: int
    nv: int
    build: Callable[[np.random.Generator], TaskModel]

    def __post_init__(self):
        check_config(self, positive=("horizon", "dt", "timeout", "slowdown", "nv"))
        if not self.name:
            raise ValueError("PushTaskSpec.name must be a non-empty str")
        if not callable(self.build):
            raise TypeError(f"PushTaskSpec.build must be callable, got {self.build!r}")

    def __call__(self, rng: np.random.Generator) -> TaskModel:
        """A fresh instance drawn from ``rng`` (``build``)."""
        return self.build(rng)


def require_generator(rng: object) -> np.random.Generator:
    """Return ``rng`` if it is a ``numpy.random.Generator``; raise TypeError otherwise."""
    if not isinstance(rng, np.random.Generator):
        raise TypeError(
            "rng must be a numpy.random.Generator (e.g. numpy.random.default_rng(seed)), "
            f"got {type(rng).__name__}"
        )
    return rng


def planar_dofs(model: mujoco.MjModel, body_ids: Iterable[int]) -> np.ndarray:
    """Indices into qvel of the world x and y translations of the given bodies.

    A free joint contributes its first two DoFs (its linear velocity is in the world frame); a
    slide joint along world x or y (the joints of a flex vertex) contributes its DoF.

    Returns:
        (k,) int array, in the order of ``body_ids`` and then of the joints.
    """
    dofs = []
    for body in body_ids:
        start = model.body_jntadr[body]
        for joint in range(start, start + model.body_jntnum[body]):
            kind, adr = model.jnt_type[joint], model.jnt_dofadr[joint]
            axis = np.abs(model.jnt_axis[joint])
            if kind == mujoco.mjtJoint.mjJNT_FREE:
                dofs += [adr, adr + 1]
            elif (kind == mujoco.mjtJoint.mjJNT_SLIDE and np.isclose(axis[2], 0.0)
                  and np.isclose(axis.max(), 1.0)):
                dofs.append(adr)
    return np.array(dofs, dtype=int)
