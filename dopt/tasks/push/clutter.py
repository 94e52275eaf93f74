"""The clutter task (state-vector-reduction paper, Sec. 5.1 and Fig. 1).

The Panda pushes a green goal cylinder into a goal region on the table while disturbing seven
distractor cylinders as little as possible. nv = 7 (arm) + 8 x 6 (free cylinders) = 55, nu = 7,
dt = 0.004 s (Euler), T = 80, Y = 2000, slowdown 1.

A layout is drawn from the caller's generator: the goal cylinder in front of the robot, the goal
region 0.15-0.25 m beyond it along a heading within 30 degrees of +x, the pusher tip just above
the table behind the goal cylinder (so the goal cylinder lies between it and the goal), and the
distractors scattered around the pushing path without touching anything.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import mujoco
import numpy as np

from dopt.tasks.panda import TOOL_RADIUS, ik_pointing_down, rest_state, table_scene_spec
from dopt.tasks.push.task_model import EE_HEIGHT, PushTaskSpec, TaskModel, require_generator

log = logging.getLogger(__name__)

HORIZON = 80
DT = 0.004
TIMEOUT = 2000
SLOWDOWN = 1

CYLINDER_RADIUS = 0.035  # m
CYLINDER_HALF_HEIGHT = 0.06  # m
CYLINDER_MASS = 0.2  # kg
GOAL_CYLINDER = "goal_cylinder"
DISTRACTORS = tuple(f"distractor_{i}" for i in range(7))
GOAL_RGBA = (0.2, 0.8, 0.2, 1.0)
DISTRACTOR_RGBA = (0.85, 0.85, 0.9, 1.0)

STANDOFF = 0.03  # start gap between the pusher tip and the object it faces (m)
MIN_GAP = 0.02  # least clearance between objects (and the tip) in a layout (m)
SETTLE_STEPS = 50  # steps of zero control before the initial state is taken
_MAX_DRAWS = 10_000


@dataclass(frozen=True)
class ClutterLayout:
    """Where things start, in world coordinates (m).

    Attributes:
        goal_cylinder: (2,) xy of the goal cylinder's axis.
        goal: (2,) xy of the goal region's centre.
        distractors: (7, 2) xy of the distractor cylinders' axes.
        ee_start: (3,) position of the end-effector site.
    """

    goal_cylinder: np.ndarray
    goal: np.ndarray
    distractors: np.ndarray
    ee_start: np.ndarray


def draw_heading(rng: np.random.Generator) -> tuple[float, np.ndarray]:
    """A pushing heading (rad) drawn uniformly within 30 degrees of +x, and its (2,) unit vector."""
    heading = rng.uniform(-math.pi / 6, math.pi / 6)
    return heading, np.array([math.cos(heading), math.sin(heading)])


def sample_layout(rng: np.random.Generator) -> ClutterLayout:
    """Draw a layout; every draw comes from ``rng``.

    Distractors are drawn uniformly from a box around the path (from 0.1 m behind the goal
    cylinder to 0.15 m beyond the goal, 0.2 m to either side) and rejected if they come closer
    than ``MIN_GAP`` to another cylinder, the goal region or the pusher tip.

    Raises:
        TypeError: ``rng`` is not a ``numpy.random.Generator``.
    """
    rng = require_generator(rng)
    goal_cylinder = np.array([rng.uniform(0.42, 0.52), rng.uniform(-0.1, 0.1)])
    _, along = draw_heading(rng)
    across = np.array([-along[1], along[0]])
    distance = rng.uniform(0.15, 0.25)
    goal = goal_cylinder + distance * along
    tip = goal_cylinder - (CYLINDER_RADIUS + TOOL_RADIUS + STANDOFF) * along
    # (centre, radius) of what a new distractor must keep clear of
    occupied = [(goal_cylinder, CYLINDER_RADIUS), (goal, CYLINDER_RADIUS), (tip, TOOL_RADIUS)]
    distractors = []
    for _ in range(_MAX_DRAWS):
        xy = (goal_cylinder + rng.uniform(-0.1, distance + 0.15) * along
              + rng.uniform(-0.2, 0.2) * across)
        if all(np.linalg.norm(xy - c) >= CYLINDER_RADIUS + r + MIN_GAP for c, r in occupied):
            distractors.append(xy)
            occupied.append((xy, CYLINDER_RADIUS))
            if len(distractors) == len(DISTRACTORS):
                break
    else:
        raise RuntimeError(f"placed only {len(distractors)} distractors in {_MAX_DRAWS} draws")
    return ClutterLayout(goal_cylinder, goal, np.array(distractors), np.array([*tip, EE_HEIGHT]))


def add_cylinder(spec: mujoco.MjSpec, name: str, xy: np.ndarray, rgba: tuple[float, ...]) -> None:
    """Add a free upright cylinder standing on the table at ``xy``.

    The body, its joint and its geom are all called ``name``.
    """
    body = spec.worldbody.add_body(name=name, pos=[xy[0], xy[1], CYLINDER_HALF_HEIGHT])
    body.add_freejoint(name=name)
    body.add_geom(
        name=name,
        type=mujoco.mjtGeom.mjGEOM_CYLINDER,
        size=[CYLINDER_RADIUS, CYLINDER_HALF_HEIGHT, 0.0],
        mass=CYLINDER_MASS,
        friction=[0.5, 0.005, 0.0001],
        condim=3,
        rgba=list(rgba),
    )


def add_goal_marker(spec: mujoco.MjSpec, xy: np.ndarray, radius: float,
                    height: float) -> np.ndarray:
    """Add the goal region, a translucent green cylinder site standing on the table.

    It has no physics (sites do not collide). Returns its (3,) centre at table height.
    """
    spec.worldbody.add_site(
        name="goal",
        type=mujoco.mjtGeom.mjGEOM_CYLINDER,
        pos=[xy[0], xy[1], height / 2],
        size=[radius, height / 2, 0.0],
        rgba=[0.2, 0.9, 0.2, 0.3],
    )
    return np.array([xy[0], xy[1], 0.0])


def build_clutter(rng: np.random.Generator) -> TaskModel:
    """Build a clutter task instance from ``rng`` (a layout from ``sample_layout``).

    Raises:
        TypeError: ``rng`` is not a ``numpy.random.Generator``.
    """
    layout = sample_layout(rng)
    spec = table_scene_spec(DT, mujoco.mjtIntegrator.mjINT_EULER)
    add_cylinder(spec, GOAL_CYLINDER, layout.goal_cylinder, GOAL_RGBA)
    for name, xy in zip(DISTRACTORS, layout.distractors, strict=True):
        add_cylinder(spec, name, xy, DISTRACTOR_RGBA)
    goal = add_goal_marker(spec, layout.goal, CYLINDER_RADIUS, 2 * CYLINDER_HALF_HEIGHT)
    model = spec.compile()
    state = rest_state(model, ik_pointing_down(layout.ee_start), SETTLE_STEPS)
    log.debug("clutter: goal cylinder %s, goal %s", layout.goal_cylinder, layout.goal)
    return clutter_task(model, state, goal)


def clutter_task(model: mujoco.MjModel, state: np.ndarray, goal: np.ndarray) -> TaskModel:
    """The clutter task on a compiled scene whose goal cylinder is ``GOAL_CYLINDER`` and whose
    distractors are ``DISTRACTORS``: the paper's T, dt, Y and slowdown. ``state``: (ns,) the
    settled start; ``goal``: (3,) the goal region's centre on the table."""
    return TaskModel(
        name="clutter",
        model=model,
        initial_state=state,
        goal_object=GOAL_CYLINDER,
        goal_position=goal,
        distractors=DISTRACTORS,
        soft_body=None,
        horizon=CLUTTER.horizon,
        dt=CLUTTER.dt,
        timeout=CLUTTER.timeout,
        slowdown=CLUTTER.slowdown,
    )


#: the clutter task by name (``dopt.tasks.PUSH_TASKS``): nv = 7 + 8 x 6
CLUTTER = PushTaskSpec("clutter", horizon=HORIZON, dt=DT, timeout=TIMEOUT, slowdown=SLOWDOWN,
                       nv=55, build=build_clutter)
