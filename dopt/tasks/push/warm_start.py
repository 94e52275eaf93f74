"""The pushing tasks' initial plans: an end-effector waypoint path tracked by a task-space
controller and rolled out to give controls.

This is the idea of the state-vector-reduction authors' code (DMackRus/iLQR_SVR,
``PushBaseClass``: a set-up waypoint behind the pushed object, then a push toward the goal,
each followed by a Jacobian controller whose controls are recorded); the code and the
controller here are ours.

- ``setup``: the end effector moves in a straight line from where it is to the *set-up
  point*: on the line from the goal through the pushed object's centre, ``gap`` behind the
  object's back face, at ``height`` above the table, in ``setup_steps`` steps, then holds it
  for ``hold_steps``. The state it ends in starts the MPC episode; its steps are not part of
  the episode (the authors run it before the MPC and do not score it).
- ``push``: from any state, the end effector moves toward the goal along the same line over
  the T steps of a horizon; the controls that track it are the MPC's first plan. Its end
  point is the authors' (``EEWayPointsPush``): the pushed object's *centre* moved toward the
  goal by as much as ``speed * fraction * T * dt`` allows (their 0.1 m/s and 5/6), never past
  the goal. With ``moving_tail`` (the default) the path goes on past that point at the
  authors' push speed (``speed * fraction``) and the plan is the first T controls of its
  track: the plan ends moving forward, not at rest. The MPC pads every shifted plan with its
  last control; a plan that ends at rest pads with a control that stops the pusher, and once
  the pusher leaves the object the cost (Eq. 2, which reaches the controls only through
  contact) gives iLQR nothing to improve: the optimisation stalls (docs/DESIGN-NOTES.md, "Why
  iLQR-SVR stalled", has the measurements, including the authors' own P-only tracker, which
  on this arm moves the tip backwards). On the soft tasks the authors' code of the paper's
  time starts from zero torques; on this arm (gravity compensated, a rod pusher behind the
  block) zero torques never reach the block, so every task starts from this plan.

The pushed object is ``TaskModel.pushed_object``: the goal cylinder in clutter, the soft block
in soft and soft_rigid (it carries the cylinder in soft_rigid). Its centre and back face come
from the state (a rigid body: its position and its geom's radius; a flex: its vertices and
the flex radius), so any layout works.

Tracking: tau = Jp^T (kp (p* - p) + kv (v* - v)) + Jr^T (kr (a x down) - kw w) + D qd* - kq (qd
- qd*), with Jp, Jr the end-effector site's Jacobians, v* the path's velocity, qd* the joint
velocities that realise it with the tool not turning (least squares), D the model's joint
damping (heavy on the Panda: without D qd* the tip lags the path by centimetres), a the tool
axis; clipped to the torque limits. The arm's gravity is compensated by the model
(``gravcomp``), so, unlike the authors' controller, no gravity term is added.
Shapes: S steps, nu controls, ns a state row.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from dopt.state import INTEGRATION
from dopt.tasks.panda import TOOL_RADIUS
from dopt.tasks.push.task_model import TaskModel
from dopt.validation import check_config, check_int, float_array

_DOWN = np.array([0.0, 0.0, -1.0])


@dataclass(frozen=True)
class WarmStartConfig:
    """gap: tool surface to the pushed object's back face at the set-up point (m).
    height: the tool tip's centre above the table (m); None: the task's
        (``TaskModel.push_height``).
    setup_steps, hold_steps: steps to reach the set-up point and to hold it.
    speed, fraction: the push moves the object's centre toward the goal by at most
    ``speed * fraction * T * dt`` over a horizon of T steps (m/s; the authors' 0.1 and 5/6).
    depth_from: ``centre``: that reach is measured from the pushed object's centre (the
    authors'); ``tip``: from the end effector, stopping the tip at the object's back face
    when it reaches the goal (a shorter push).
    moving_tail: the plan is the first T controls of a track that goes on past the end
    point at the authors' push speed (``speed * fraction``); False: the path ends there and
    the plan ends at rest.
    kp, kv, kr, kw, kq: tracking gains (N/m, N s/m, N m/rad, N m s/rad, N m s/rad)."""

    gap: float = 0.01
    height: float | None = None
    setup_steps: int = 300
    hold_steps: int = 100
    speed: float = 0.1
    fraction: float = 5.0 / 6.0
    kp: float = 2000.0
    kv: float = 80.0
    kr: float = 50.0
    kw: float = 5.0
    kq: float = 1.0
    depth_from: str = "centre"
    moving_tail: bool = True

    def __post_init__(self):
        if self.depth_from not in ("centre", "tip"):
            raise ValueError(f"depth_from must be 'centre' or 'tip', got {self.depth_from!r}")
        check_config(self, positive=("height", "speed", "fraction", "kp"),
                     minimum={"gap": 0.0, "setup_steps": 1, "hold_steps": 0, "kv": 0.0,
                              "kr": 0.0, "kw": 0.0, "kq": 0.0})


@dataclass(frozen=True)
class EEPlan:
    """controls (S, nu) that track ``path`` (S, 3) from ``states[0]``; states (S+1, ns) the
    rollout (row t before control t); the end effector's positions (S+1, 3) along it."""

    controls: np.ndarray
    states: np.ndarray
    path: np.ndarray
    ee: np.ndarray

    @property
    def final_state(self) -> np.ndarray:
        return self.states[-1]


def push_line(task: TaskModel, state: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """The pushed object's (2,) centre, the (2,) unit direction from it to the goal, and the
    distance (m) from its centre to its back face along that direction, in ``state``."""
    points, radius = _object_points(task, state)
    centre = points.mean(axis=0)
    along = np.asarray(task.goal_position[:2], dtype=float) - centre
    norm = np.linalg.norm(along)
    if norm < 1e-9:
        raise ValueError("the pushed object is at the goal: no pushing direction")
    along = along / norm
    back = float(np.max((centre - points) @ along)) + radius
    return centre, along, back


def setup_point(task: TaskModel, state: np.ndarray,
                config: WarmStartConfig = WarmStartConfig()) -> np.ndarray:
    """(3,) where ``setup`` brings the end effector: ``config.gap`` behind the pushed object
    on the line from the goal through its centre, at ``config.height`` (None: the task's)."""
    centre, along, back = push_line(task, state)
    xy = centre - (back + TOOL_RADIUS + config.gap) * along
    return np.array([xy[0], xy[1], _height(task, config)])


def setup(task: TaskModel, state: np.ndarray | None = None,
          config: WarmStartConfig = WarmStartConfig()) -> EEPlan:
    """Bring the end effector from ``state`` (default: the task's initial state) to the
    set-up point and hold it there; returns the tracked plan (its final state starts the
    episode)."""
    state = _state(task, state)
    target = setup_point(task, state, config)
    start = _ee(task, state)
    s = np.arange(1, config.setup_steps + 1) / config.setup_steps
    path = np.concatenate([start + s[:, None] * (target - start),
                           np.repeat(target[None], config.hold_steps, axis=0)])
    return track(task, state, path, config)


def push(task: TaskModel, state: np.ndarray, horizon: int,
         config: WarmStartConfig = WarmStartConfig()) -> EEPlan:
    """The first plan of an episode from ``state``: ``horizon`` controls that move the end
    effector toward the goal along the pushing line (see the module docstring). With
    ``config.moving_tail`` the returned ``path``, ``states`` and ``ee`` are those of the
    first ``horizon`` steps of the 2T-step track."""
    horizon = check_int(horizon, "horizon", minimum=1)
    state = _state(task, state)
    end = push_end(task, state, horizon, config)
    start = _ee(task, state)
    s = np.arange(1, horizon + 1) / horizon
    head = start + s[:, None] * (end - start)
    if not config.moving_tail:
        return track(task, state, head, config)
    direction = (end - start) / max(np.linalg.norm(end - start), 1e-12)
    step = config.speed * config.fraction * task.model.opt.timestep
    tail = end + np.arange(1, horizon + 1)[:, None] * step * direction
    full = track(task, state, np.concatenate([head, tail]), config)
    return EEPlan(full.controls[:horizon], full.states[:horizon + 1], full.path[:horizon],
                  full.ee[:horizon + 1])


def push_end(task: TaskModel, state: np.ndarray, horizon: int,
             config: WarmStartConfig = WarmStartConfig()) -> np.ndarray:
    """(3,) where ``push`` sends the end effector over ``horizon`` steps from ``state`` (the
    end of its path; ``config.depth_from`` says what the reach is measured from)."""
    centre, along, back = push_line(task, state)
    start = _ee(task, state)
    goal = np.asarray(task.goal_position[:2], dtype=float)
    reach = config.speed * config.fraction * horizon * task.model.opt.timestep
    if config.depth_from == "centre":
        end_xy = centre + min(reach, float(np.linalg.norm(goal - centre))) * along
    else:
        delta = goal - back * along - start[:2]
        if np.linalg.norm(delta) > reach:
            delta *= reach / np.linalg.norm(delta)
        end_xy = start[:2] + delta
    return np.array([end_xy[0], end_xy[1], _height(task, config)])


def track(task: TaskModel, state: np.ndarray, path, config: WarmStartConfig = WarmStartConfig()
          ) -> EEPlan:
    """Roll the tracking controller along ``path`` (S, 3) from ``state``; one control per
    path point."""
    path = float_array(path, "path")
    if path.ndim != 2 or path.shape[1] != 3 or not len(path):
        raise ValueError(f"path must have shape (S, 3) with S >= 1, got {path.shape}")
    m = task.model
    d = mujoco.MjData(m)
    mujoco.mj_setState(m, d, _state(task, state), INTEGRATION)
    mujoco.mj_forward(m, d)
    site = m.site(task.ee_site).id
    dofs = task.robot_dofs
    lo, hi = m.actuator_ctrlrange[:, 0], m.actuator_ctrlrange[:, 1]
    jp, jr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    ns = mujoco.mj_stateSize(m, INTEGRATION)
    states, controls, ee = np.empty((len(path) + 1, ns)), np.empty((len(path), m.nu)), []
    mujoco.mj_getState(m, d, states[0], INTEGRATION)
    damping = m.dof_damping[dofs]
    velocity = np.diff(path, axis=0, append=path[-1:]) / m.opt.timestep   # (S, 3) path speed
    for t, target in enumerate(path):
        mujoco.mj_jacSite(m, d, jp, jr, site)
        Jp, Jr = jp[:, dofs], jr[:, dofs]
        qd = d.qvel[dofs]
        # the joint velocities that move the tip along the path without turning the tool
        qd_ref = np.linalg.lstsq(np.vstack([Jp, Jr]), np.concatenate([velocity[t], np.zeros(3)]),
                                 rcond=None)[0]
        axis = d.site_xmat[site].reshape(3, 3)[:, 2]
        force = config.kp * (target - d.site_xpos[site]) + config.kv * (velocity[t] - Jp @ qd)
        torque = config.kr * np.cross(axis, _DOWN) - config.kw * (Jr @ qd)
        tau = Jp.T @ force + Jr.T @ torque + damping * qd_ref - config.kq * (qd - qd_ref)
        controls[t] = np.clip(tau, lo, hi)     # actuators drive robot_joints in order
        ee.append(d.site_xpos[site].copy())
        d.ctrl[:] = controls[t]
        mujoco.mj_step(m, d)
        mujoco.mj_getState(m, d, states[t + 1], INTEGRATION)
    mujoco.mj_forward(m, d)
    ee.append(d.site_xpos[site].copy())
    return EEPlan(controls, states, path, np.array(ee))


# ---------------------------------------------------------------------------- internals
def _height(task: TaskModel, config: WarmStartConfig) -> float:
    """The push height (m): the config's, else the task's."""
    return float(task.push_height if config.height is None else config.height)


def _state(task: TaskModel, state) -> np.ndarray:
    if state is None:
        return np.asarray(task.initial_state, dtype=float)
    x = float_array(state, "state")
    ns = mujoco.mj_stateSize(task.model, INTEGRATION)
    if x.shape != (ns,):
        raise ValueError(f"state must have shape ({ns},), got {x.shape}")
    return x


def _positions(task: TaskModel, state: np.ndarray) -> mujoco.MjData:
    m = task.model
    d = mujoco.MjData(m)
    mujoco.mj_setState(m, d, state, INTEGRATION)
    mujoco.mj_kinematics(m, d)
    return d


def _ee(task: TaskModel, state: np.ndarray) -> np.ndarray:
    return _positions(task, state).site_xpos[task.model.site(task.ee_site).id].copy()


def _object_points(task: TaskModel, state: np.ndarray) -> tuple[np.ndarray, float]:
    """(P, 2) xy of the pushed object's points and their radius (m): a flex's vertices and
    its radius, or a rigid body's position and the xy radius of its first geom."""
    m = task.model
    d = _positions(task, state)
    name = task.pushed_object
    flex = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_FLEX, name)
    if flex >= 0:
        start, n = m.flex_vertadr[flex], m.flex_vertnum[flex]
        bodies = m.flex_vertbodyid[start:start + n]
        return d.xpos[bodies, :2].copy(), float(m.flex_radius[flex])
    body = m.body(name).id
    geom = m.body_geomadr[body]
    return d.xpos[body, None, :2].copy(), float(m.geom_size[geom, 0]) if geom >= 0 else 0.0
