"""The soft and soft_rigid tasks (state-vector-reduction paper, Sec. 5.1 and Figs. 2-3).

soft: the Panda pushes a soft block of 3 x 4 x 3 = 36 vertices (every vertex a 3-DoF body) to a
flat goal circle on the table. nv = 7 + 36 x 3 = 115, nu = 7; T = 50, Y = 1000, slowdown 3.

soft_rigid: a soft block of 4 x 4 x 3 vertices less one top corner (47 vertices) lies between
the pusher and a free goal cylinder; the arm pushes the block, the block pushes the cylinder
into the goal region. nv = 7 + 47 x 3 + 6 = 154, nu = 7; T = 100, Y = 1000, slowdown 5.

Both use dt = 0.004 s and MuJoCo's ``discrete`` integrator: in MuJoCo 4.0 the elasticity of a 3D
flex raises an error under ``implicit``/``implicitfast`` and explodes under Euler at this step.
Each layout is drawn from the caller's generator: the block in front of the robot, turned to a
pushing heading within 30 degrees of +x, the goal ahead of it along that heading and the pusher
tip just above the table behind it. What a block is made of is a ``SoftMaterial`` (default: ours);
``dopt.tasks.push.authors`` builds the authors' blocks with these helpers.
"""

from __future__ import annotations

import itertools
import logging
import math
from dataclasses import dataclass

import mujoco
import numpy as np

from dopt.stability import StabilityBounds
from dopt.tasks.panda import TOOL_RADIUS, ik_pointing_down, rest_state, table_scene_spec
from dopt.tasks.push.clutter import (
    CYLINDER_HALF_HEIGHT,
    CYLINDER_RADIUS,
    EE_HEIGHT,
    GOAL_CYLINDER,
    GOAL_RGBA,
    STANDOFF,
    add_cylinder,
    add_goal_marker,
    draw_heading,
)
from dopt.tasks.push.task_model import PushTaskSpec, TaskModel, require_generator

log = logging.getLogger(__name__)

DT = 0.004
TIMEOUT = 1000
SOFT_BODY = "soft"
SPACING = 0.04  # distance between neighbouring vertices (m)
VERTEX_RADIUS = 0.005  # collision radius of the flex (m)
DENSITY = 400.0  # kg/m^3, a firm foam
YOUNG = 5e4  # Pa
POISSON = 0.2
ELASTIC_DAMPING = 0.002  # s, Rayleigh damping of the elasticity
SOFT_RGBA = (0.85, 0.15, 0.15, 1.0)
SETTLE_STEPS = 100  # steps of zero control before the initial state is taken


@dataclass(frozen=True)
class SoftMaterial:
    """What a soft block is made of (the defaults: ours).

    Attributes:
        spacing: distance between neighbouring vertices (m).
        radius: collision radius of the flex (m).
        young, poisson: Young's modulus (Pa) and Poisson's ratio of its elasticity.
        damping: Rayleigh damping of the elasticity (s).
        mass: total mass (kg); None: ``DENSITY`` times the block's volume.
    """

    spacing: float = SPACING
    radius: float = VERTEX_RADIUS
    young: float = YOUNG
    poisson: float = POISSON
    damping: float = ELASTIC_DAMPING
    mass: float | None = None


def block_mesh(counts: tuple[int, int, int], spacing: float,
               notch: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Tetrahedral mesh of a block of grid vertices.

    The block has ``counts`` = (along, across, up) vertices, ``spacing`` apart, centred on x = y
    = 0 with its bottom face at z = 0. Each grid cell is split into 6 tetrahedra around its main
    diagonal (a conforming Kuhn split). With ``notch`` the top cell at the (+x, +y) corner and its
    corner vertex are left out, which removes exactly one vertex.

    Returns:
        points (N, 3) float and tets (E, 4) int (indices into points).
    Raises:
        ValueError: a count below 2 or a non-positive spacing.
    """
    counts = tuple(int(c) for c in counts)
    if len(counts) != 3 or min(counts) < 2 or spacing <= 0:
        raise ValueError(f"need 3 counts >= 2 and a positive spacing, got {counts}, {spacing}")
    cells = [c - 1 for c in counts]
    dropped_cell = (cells[0] - 1, cells[1] - 1, cells[2] - 1) if notch else None
    dropped_vertex = (cells[0], cells[1], cells[2]) if notch else None
    index = {}
    for vertex in itertools.product(*(range(c) for c in counts)):
        if vertex != dropped_vertex:
            index[vertex] = len(index)
    points = np.array(list(index), dtype=float) * spacing
    points[:, :2] -= points[:, :2].max(axis=0) / 2
    tets = []
    for cell in itertools.product(*(range(c) for c in cells)):
        if cell == dropped_cell:
            continue
        for order in itertools.permutations(range(3)):
            corner = list(cell)
            path = [tuple(corner)]
            for axis in order:
                corner[axis] += 1
                path.append(tuple(corner))
            tets.append([index[v] for v in path])
    return points, np.array(tets, dtype=int)


def add_soft_block(spec: mujoco.MjSpec, points: np.ndarray, tets: np.ndarray, xy: np.ndarray,
                   heading: float, material: SoftMaterial = SoftMaterial()) -> None:
    """Add the soft body ``SOFT_BODY``: a flex with one 3-DoF body per point (``dof="full"``).

    ``points`` (N, 3) and ``tets`` (E, 4) as from ``block_mesh``; the block is turned by
    ``heading`` (rad) about z and placed with its origin at ``xy``, resting on the table.
    Its radius, elasticity and mass are ``material``'s (by default, ``DENSITY`` times its
    volume).
    """
    corners = points[tets]
    volume = np.abs(np.linalg.det(corners[:, 1:] - corners[:, :1])).sum() / 6
    mesh = spec.add_mesh(
        name=f"{SOFT_BODY}_mesh",
        uservert=points.ravel().tolist(),
        usernode=points.ravel().tolist(),
        usertet=tets.ravel().tolist(),
    )
    flex = spec.worldbody.make_flex(
        SOFT_BODY,
        dim=3,
        dof="full",
        mesh=mesh.name,
        radius=material.radius,
        mass=DENSITY * volume if material.mass is None else material.mass,
        pos=[xy[0], xy[1], material.radius],
        quat=[math.cos(heading / 2), 0.0, 0.0, math.sin(heading / 2)],
    )
    spec.delete(mesh)  # make_flex has copied the points; the mesh asset is not part of the model
    flex.young = material.young
    flex.poisson = material.poisson
    flex.damping = material.damping
    flex.selfcollide = mujoco.mjtFlexSelf.mjFLEXSELF_NONE
    flex.friction = [0.5, 0.005, 0.0001]
    flex.solref = [0.01, 1.0]
    flex.rgba = list(SOFT_RGBA)


@dataclass(frozen=True)
class _Block:
    """A drawn soft block: mesh (N, 3) points and (E, 4) tets in its own frame, its (2,) centre
    on the table, heading (rad) and (2,) unit pushing direction, and the (2,) start xy of the
    pusher tip behind it."""

    points: np.ndarray
    tets: np.ndarray
    centre: np.ndarray
    heading: float
    along: np.ndarray
    tip: np.ndarray


def _draw_block(rng: np.random.Generator, counts: tuple[int, int, int], notch: bool, x: float,
                half_x: float, half_y: float, material: SoftMaterial = SoftMaterial()) -> _Block:
    """Draw a block (vertices ``material.spacing`` apart) centred in [x +- half_x] x [+- half_y]
    (m), pushed along a heading within 30 degrees of +x, with the pusher tip ``STANDOFF``
    behind its back face."""
    centre = np.array([rng.uniform(x - half_x, x + half_x), rng.uniform(-half_y, half_y)])
    heading, along = draw_heading(rng)
    points, tets = block_mesh(counts, material.spacing, notch=notch)
    tip = centre - (_half_depth(points, material.radius) + TOOL_RADIUS + STANDOFF) * along
    return _Block(points, tets, centre, heading, along, tip)


def _half_depth(points: np.ndarray, radius: float = VERTEX_RADIUS) -> float:
    """Distance from a block's centre to its front face along the push, vertex ``radius``
    included."""
    return float(points[:, 0].max()) + radius


def _finish(task: PushTaskSpec, spec: mujoco.MjSpec, block: _Block, goal: np.ndarray,
            goal_object: str, settle_steps: int = SETTLE_STEPS,
            stability: StabilityBounds = StabilityBounds(),
            push_height: float = EE_HEIGHT) -> TaskModel:
    """Compile the scene, settle it with the pusher tip at ``block.tip`` (``settle_steps`` of
    zero control), and describe it as an instance of ``task`` (its name, T, dt, Y and
    slowdown; ``stability``: its rollouts' bounds;
    ``push_height``: the initial plans' tip height, m)."""
    model = spec.compile()
    state = rest_state(model, ik_pointing_down(np.array([*block.tip, EE_HEIGHT])), settle_steps)
    log.debug("%s: block at %s, heading %.3f, goal %s", task.name, block.centre, block.heading,
              goal)
    return TaskModel(
        name=task.name,
        model=model,
        initial_state=state,
        goal_object=goal_object,
        goal_position=goal,
        distractors=(),
        soft_body=SOFT_BODY,
        horizon=task.horizon,
        dt=task.dt,
        timeout=task.timeout,
        slowdown=task.slowdown,
        pushed_object_name=SOFT_BODY,
        stability=stability,
        push_height=push_height,
    )


def build_soft(rng: np.random.Generator) -> TaskModel:
    """Build a soft task instance from ``rng``: goal 0.15-0.25 m ahead of the block's centre.

    Raises:
        TypeError: ``rng`` is not a ``numpy.random.Generator``.
    """
    block = _draw_block(require_generator(rng), (3, 4, 3), notch=False, x=0.5, half_x=0.05,
                        half_y=0.1)
    goal_xy = block.centre + rng.uniform(0.15, 0.25) * block.along
    spec = table_scene_spec(DT, mujoco.mjtIntegrator.mjINT_DISCRETE)
    add_soft_block(spec, block.points, block.tets, block.centre, block.heading)
    goal = add_goal_marker(spec, goal_xy, radius=0.05, height=0.002)
    return _finish(SOFT, spec, block, goal, SOFT_BODY)


def build_soft_rigid(rng: np.random.Generator) -> TaskModel:
    """Build a soft_rigid task instance from ``rng``: the goal cylinder 1 cm beyond the block's
    front face, the goal 0.12-0.2 m beyond the cylinder.

    Raises:
        TypeError: ``rng`` is not a ``numpy.random.Generator``.
    """
    block = _draw_block(require_generator(rng), (4, 4, 3), notch=True, x=0.45, half_x=0.03,
                        half_y=0.08)
    cylinder_xy = block.centre + (_half_depth(block.points) + 0.01 + CYLINDER_RADIUS) * block.along
    goal_xy = cylinder_xy + rng.uniform(0.12, 0.2) * block.along
    spec = table_scene_spec(DT, mujoco.mjtIntegrator.mjINT_DISCRETE)
    add_soft_block(spec, block.points, block.tets, block.centre, block.heading)
    add_cylinder(spec, GOAL_CYLINDER, cylinder_xy, GOAL_RGBA)
    goal = add_goal_marker(spec, goal_xy, CYLINDER_RADIUS, 2 * CYLINDER_HALF_HEIGHT)
    return _finish(SOFT_RIGID, spec, block, goal, GOAL_CYLINDER)


#: the soft tasks by name (``dopt.tasks.PUSH_TASKS``): soft nv = 7 + 36 x 3, soft_rigid
#: nv = 7 + 47 x 3 + 6
SOFT = PushTaskSpec("soft", horizon=50, dt=DT, timeout=TIMEOUT, slowdown=3, nv=115,
                    build=build_soft)
SOFT_RIGID = PushTaskSpec("soft_rigid", horizon=100, dt=DT, timeout=TIMEOUT, slowdown=5, nv=154,
                          build=build_soft_rigid)
