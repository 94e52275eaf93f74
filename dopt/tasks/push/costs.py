"""The pushing tasks' costs (Eq. 2-3 of the state-vector-reduction paper) and success tests.

Every cost is diagonal-quadratic in the full tangent state, plus (``PushWeights()``, not
``PushWeights.paper()``) one end-effector term:

- the goal object's x, y to the goal (for the soft body: every vertex to its place in the
  block translated onto the goal), running weight ``goal`` and terminal ``goal_f``;
- each distractor's x, y to where it started ("minimally disturbing"), ``distractor``;
- the arm's joint velocities, ``arm_velocity``; torques scaled by their limits, ``torque``;
- the end effector's x, y distance to the goal object (the goal cylinder in clutter and
  soft_rigid, the soft body's centroid in soft), ``ee``: without it no gradient reaches the
  arm before the pusher touches the object. In soft_rigid it pulls the arm through the soft
  block onto the cylinder behind it, so the cost reads only the robot and the cylinder's x, y:
  the paper's 9 naive DoFs (a term on the block's centroid made all 94 vertex x, y "costed").

- (``reach``, ``reach_f``) the authors' "reach" residual of their soft task: the end
  effector's 3D distance to the goal object's centre at table height, less the distance at
  which the pusher touches it (``contact_distance``; theirs is 0.28 m from their gripper body's
  origin, ours is measured from the pusher tip), squared.

The paper does not give its W, R, W_f; ``PushWeights()`` are ours, ``AUTHORS_COSTS`` the
authors' code's. ``COST_PRESETS`` names the costs: ``authors-<task>`` (the authors' own weights
of each task: no control cost, no end-effector term), ``paper`` (Eq. 2 with our weights and
torque cost, no end-effector term; the pushing then relies on the initial plan of
``dopt.tasks.push.warm_start`` to bring the pusher into contact), ``paper-reach`` (Eq. 2 with
the reach residual at the authors' terminal weight, 100 times the goal's) and ``ee`` (with the
end-effector term).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, fields

import mujoco
import numpy as np

from dopt.costs import EEDistanceTerm, QuadraticCost
from dopt.scene import Scene
from dopt.tasks.panda import TAU_MAX
from dopt.tasks.push.clutter import STANDOFF
from dopt.tasks.push.task_model import TaskModel, planar_dofs
from dopt.validation import check_config


@dataclass(frozen=True)
class PushWeights:
    goal: float = 100.0
    goal_f: float = 1000.0
    goal_velocity: float = 1.0      # slows the goal object down near the goal: no overshoot
    goal_velocity_f: float = 10.0
    distractor: float = 20.0
    distractor_f: float = 200.0
    arm_velocity: float = 0.05
    arm_velocity_f: float = 0.5
    torque: float = 1e-2
    ee: float = 10.0
    ee_f: float = 10.0
    reach: float = 0.0
    reach_f: float = 0.0
    joint_velocity: tuple[float, ...] | None = None   # per arm joint, replaces arm_velocity(_f)
    success_radius: float = 0.02     # m: goal object centre within this of the goal ends the task

    @classmethod
    def paper(cls, **overrides) -> PushWeights:
        """The paper's Eq. 2 cost: these weights without the end-effector term (ee = ee_f =
        0). The authors' clutter task file weights its "reach" residual 0 as well; their soft
        task file does not (``COST_PRESETS["paper-reach"]``)."""
        return cls(**{"ee": 0.0, "ee_f": 0.0, **overrides})

    def __post_init__(self):
        check_config(self, minimum=dict.fromkeys((f.name for f in fields(self)), 0),
                     positive=("success_radius",))
        if self.joint_velocity is not None and len(self.joint_velocity) != len(TAU_MAX):
            raise ValueError(f"PushWeights.joint_velocity needs one weight per arm joint "
                             f"({len(TAU_MAX)}), got {len(self.joint_velocity)}")

    @property
    def has_control_cost(self) -> bool:
        """Whether the cost has a control term (R != 0 in Eq. 2)."""
        return self.torque > 0


#: the pushing costs by name: the paper's Eq. 2; Eq. 2 with the authors' soft-task "reach"
#: residual (their push_soft.yaml: terminal weight 1e5 against the goal's 1e3, running 0); ours
#: with the end-effector term
COST_PRESETS = {"paper": PushWeights.paper(), "paper-reach": PushWeights.paper(reach_f=1e5),
                "ee": PushWeights()}

#: the authors' own weights per task (DMackRus/iLQR_SVR), with no control cost (their code has
#: none in any version) and no end-effector term; residuals are w r^2 without dt, as ours.
#: clutter: ``PaperData/MPC_push_mcl/Cost config`` of the paper's runs (goal position 8, goal
#: velocity 1.5, distractor position 4, joint velocities 0.1 0.1 0.1 0.01 0 0.1 0; the file
#: says its terminal costs served only the final evaluation, so the terminal weights equal the
#: running ones). soft_rigid: ``push_soft_into_rigid.yaml`` at 838e034 (goal position 100
#: running, 0 terminal; goal velocity 0.1; no arm term). soft: ``push_soft.yaml`` (goal 10
#: running, 1000 terminal; reach residual 0 running, 1e5 terminal; no velocity terms). The
#: clutter weights moved between their commits (838e034: goal 0/1000, obstacles 0/10; HEAD:
#: goal 4/4, obstacles 0.1); the ones above are those the paper's runs record.
_NONE = dict(goal_velocity=0.0, goal_velocity_f=0.0, distractor=0.0, distractor_f=0.0,
             arm_velocity=0.0, arm_velocity_f=0.0, torque=0.0, ee=0.0, ee_f=0.0)
AUTHORS_COSTS = {
    "clutter": PushWeights(**{**_NONE, "goal": 8.0, "goal_f": 8.0, "goal_velocity": 1.5,
                              "goal_velocity_f": 1.5, "distractor": 4.0, "distractor_f": 4.0,
                              "joint_velocity": (0.1, 0.1, 0.1, 0.01, 0.0, 0.1, 0.0)}),
    "soft_rigid": PushWeights(**{**_NONE, "goal": 100.0, "goal_f": 0.0, "goal_velocity": 0.1}),
    "soft": PushWeights(**{**_NONE, "goal": 10.0, "goal_f": 1000.0, "reach_f": 1e5}),
}
COST_PRESETS.update({f"authors-{task}": w for task, w in AUTHORS_COSTS.items()})


def _xy(scene: Scene, bodies: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """(k,) qpos indices and (k,) DoFs of the world x, y translations of bodies."""
    dofs = planar_dofs(scene.model, bodies)
    return scene.linear_qpos_indices(dofs), dofs


def _centroid_map(m: mujoco.MjModel, bodies: list[int], k: int):
    """Mean x, y of vertex bodies as offset + M q over their k x/y slide coordinates
    (x, y interleaved): world x = body_pos x + q_x, since vertex slides are world-aligned."""
    n = len(bodies)
    M = np.zeros((3, k))
    M[0, 0::2] = 1.0 / n
    M[1, 1::2] = 1.0 / n
    offset = np.zeros(3)
    offset[:2] = m.body_pos[bodies, :2].mean(axis=0)
    return M, offset


def push_cost(tm: TaskModel, scene: Scene, weights: PushWeights = PushWeights()) -> QuadraticCost:
    """The task's cost over the full state of ``scene`` (built on ``tm.model``)."""
    m, W = scene.model, weights
    x0 = np.asarray(tm.initial_state)
    q0 = x0[scene.layout["qpos"]]
    nv = m.nv
    q_ref = q0.copy()
    w, w_f = np.zeros(2 * nv), np.zeros(2 * nv)

    goal_q, goal_d = _xy(scene, tm.goal_bodies)
    start_xy = q0[goal_q].reshape(-1, 2)
    if len(goal_q) > 2:   # a soft body: translate every vertex so that the centroid is the goal
        shift = tm.goal_position[:2] - (m.body_pos[tm.goal_bodies, :2] + start_xy).mean(0)
        q_ref[goal_q] = (start_xy + shift).ravel()
        per_vertex = 1.0 / (len(goal_q) // 2)
    else:
        q_ref[goal_q] = tm.goal_position[:2]
        per_vertex = 1.0
    w[goal_d], w_f[goal_d] = W.goal * per_vertex, W.goal_f * per_vertex
    w[nv + goal_d] = W.goal_velocity * per_vertex
    w_f[nv + goal_d] = W.goal_velocity_f * per_vertex

    if tm.distractors:
        _, dis_d = _xy(scene, [m.body(n).id for n in tm.distractors])
        w[dis_d], w_f[dis_d] = W.distractor, W.distractor_f
    arm = tm.robot_dofs
    if W.joint_velocity is None:
        w[nv + arm], w_f[nv + arm] = W.arm_velocity, W.arm_velocity_f
    else:
        w[nv + arm] = w_f[nv + arm] = np.asarray(W.joint_velocity, dtype=float)
    r = W.torque / TAU_MAX ** 2
    terms = []
    if W.ee or W.ee_f or W.reach or W.reach_f:
        from dopt.tasks.panda import ee_chain
        chain = ee_chain()

        def fk(q):
            return chain.forward_kinematics(q).get_matrix()[:, :3, 3]

        if len(goal_d) > 2:   # the soft body is the goal: its centroid
            M, offset = _centroid_map(m, tm.goal_bodies, len(goal_d))
        else:
            M, offset = np.eye(3)[:, :2], np.zeros(3)
        if W.ee or W.ee_f:
            terms.append(EEDistanceTerm(scene, fk, arm, goal_d, M, offset, axes=(0, 1),
                                        weight=W.ee, terminal_weight=W.ee_f))
        if W.reach or W.reach_f:
            geometry = (scene, fk, arm, goal_d, M, offset)
            kw = {"axes": (0, 1, 2), "weight": W.reach, "terminal_weight": W.reach_f}
            r0 = contact_distance(EEDistanceTerm(*geometry, **kw), q0)
            terms.append(EEDistanceTerm(*geometry, **kw, distance=r0))
    return QuadraticCost(scene, q_ref, w, w_f, r, terms=terms)


def contact_distance(term: EEDistanceTerm, q0: np.ndarray) -> float:
    """The pusher tip's 3D distance to the target of ``term`` (a vector term: ``distance``
    None; the goal object's centre, or the soft body's centroid, at table height z = 0, as the
    authors' residual has it) when it touches the object: every push task starts the tip
    ``STANDOFF`` behind the object on the line through its centre, so the horizontal distance
    at ``q0`` less ``STANDOFF``, with the tip's height kept."""
    import torch
    if term.distance is not None:
        raise ValueError("contact_distance needs the term's offset vector (distance None)")
    d = term.residual(torch.as_tensor(q0)[None]).numpy()[0]          # (3,): x, y, z
    return float(np.hypot(np.hypot(d[0], d[1]) - STANDOFF, d[2]))


def goal_distance(tm: TaskModel, scene: Scene) -> Callable[[np.ndarray], float]:
    """State row (ns,) -> distance (m) in x, y of the goal object's centre to the goal."""
    m = scene.model
    bodies = tm.goal_bodies
    qadr, _ = _xy(scene, bodies)
    base = m.body_pos[bodies, :2].mean(axis=0) if len(bodies) > 1 else np.zeros(2)
    qpos = scene.layout["qpos"]
    goal = np.asarray(tm.goal_position[:2])

    def distance(state: np.ndarray) -> float:
        xy = state[qpos][qadr].reshape(-1, 2).mean(axis=0) + base
        return float(np.linalg.norm(xy - goal))

    return distance
