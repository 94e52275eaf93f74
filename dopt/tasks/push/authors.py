"""The state-vector-reduction authors' own push problems, as task builders.

The authors of iLQR-SVR (repositories DMackRus/iLQR_SVR and DMackRus/mujoco_models; the
comparison with ours is in the project's notes ``svr-authors-setup.md``) ran Table 1 on their
own scenes. These builders rebuild those scenes on our arm and table, so that a planner can be
run on the authors' problem as well as on ours (``dopt.tasks.build_push_task``):

    build_clutter_authors(layout_path)  one of their 100 clutter scenes (``TestTasks/push_mcl/
                                        {i}.csv``, read by ``read_layout``): their goal
                                        cylinder and their seven obstacles (six cylinders and
                                        a box) at the file's poses, their soft contacts,
                                        friction 1, the goal at the file's target; nv 55
    build_soft_authors(rng)             their soft block: 3 x 4 x 3 vertices 0.07 m apart,
                                        1 kg, Young 4e3 Pa, Poisson 0; nv 7 + 36 x 3 = 115
    build_soft_rigid_authors(rng)       their 3 x 4 x 4 block (2 kg) touching their cylinder
                                        (r 0.06 m, half-height 0.08 m, 0.74 kg) that moves on
                                        three slide joints x, y, z; nv 7 + 48 x 3 + 3 = 154

A layout file is checked for sense before its scene is built (``check_layout``): a goal on the
goal cylinder, an object or the goal off the table, a goal or goal cylinder beyond the arm's
reach, objects overlapping one another or the arm at their start poses are each refused with a
ValueError naming the file (all 100 of theirs pass).

What stays ours in every scene: the Panda (``panda.py``: gravity compensated, a rod pusher;
theirs is franka_sim's Panda with its hand as the pusher), the table plane, dt 0.004 s, T, Y and
the slowdown of ``PUSH_TASKS``' tasks of the same name, and the start of the arm: the pusher tip
behind the pushed object on the line from the goal through its centre, at ``EE_HEIGHT``, by
``ik_pointing_down`` (``STANDOFF`` behind it; ``BLOCK_STANDOFF`` in soft_rigid). The names are
ours too (the goal body ``GOAL_CYLINDER``, the obstacles ``DISTRACTORS`` in their order, the flex
``SOFT_BODY``), so the costs, warm starts and planners take these tasks unchanged.

Soft tasks: integrator and damping. The scenes use MuJoCo 4.0's ``discrete`` integrator, as our
soft tasks do: a comparison of the two problems then changes the scene and nothing else, and
``discrete`` integrates the flex elasticity implicitly (MuJoCo 4.0's recommended route for
continuum elasticity; ``implicit``/``implicitfast`` refuse it). Their own choice, Euler with flex
edge damping, does run these two blocks at rest and under random torques in MuJoCo 4.0
(measured), but ``discrete`` rejects edge damping (``MjsFlex.edgedamping``, their ``<edge
damping>``), so their edge damping is carried by the elasticity's Rayleigh damping
(``MjsFlex.damping``, units of time), converted: ``EDGE_TO_RAYLEIGH`` is the median, over the
block's deformation modes, of the Rayleigh coefficient that damps each mode as their edge
damping does (7.8 ms for 0.9 N s/m on the 3 x 4 x 3 block, 6.9 ms for 0.8 on the 3 x 4 x 4 one;
per mode 2-16 ms). Poisson 0 makes MuJoCo 4.0's corrected 3D elastic constants equal to the
older ones (changelog 4.0, item 11), so their Young's modulus means what it meant to them.

Soft tasks: layouts. Theirs are one fixed scene each (``PushSoft.cpp::ReturnRandomStartState``
draws soft_rigid's cylinder x in [0.5, 0.501] and y in [0, 0.01]; the goals are fixed in
``push_soft.yaml``, (0.65, 0.1), and ``push_soft_into_rigid.yaml``, (0.75, 0.1)), so these are
drawn like ours: the block in front of the robot within our ranges, turned to a heading within
30 degrees of +x, the goal ahead; in soft_rigid the goal 0.24-0.30 m beyond the cylinder (theirs:
0.27 m, at 21.8 degrees). Their soft_rigid block lies at x 0.31-0.45, nearer the robot than our
pusher can start behind it (with the tool down at ``EE_HEIGHT`` our IK fails nearer than about
0.29 m). Their blocks are soft: pushed at the bottom by our rod, the 3 x 4 x 4 block's back
bottom cells compress by about half (``dopt.stability``'s default strain bound is 0.5): the
edges of a 4 kPa block under the pusher's push, with every vertex slow and above the table, not a
blow-up. Under the default bound every line-search rollout from such a state is flagged at its
first step, so iLQR can never change the plan; the authors' soft tasks therefore judge strain
at ``SOFT_STRAIN_BOUND`` (the speed, penetration and solver bounds stay the default's). In
soft_rigid the block is squeezed between the pusher and the cylinder (0.74 kg at friction 1):
pushed at ``EE_HEIGHT``, level with its bottom layer, that layer folds over and its
tetrahedra invert (open loop on the first plan and its last control, seeds 0-5: volume
ratios down to -1.3, the strain bound broken in 4 of 6 by step 76-187; a real break, which
the bound rightly flags), so its initial plans push at ``SOFT_RIGID_PUSH_HEIGHT``, one
spacing up (the same seeds: strain at most 0.747, the worst tetrahedron at -0.05, the slight
inversion seeds 0 and 1 also show at ``EE_HEIGHT``).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, replace
from pathlib import Path

import mujoco
import numpy as np

from dopt.stability import StabilityBounds
from dopt.tasks.panda import (
    TABLE_NAME,
    TOOL_RADIUS,
    arm_qpos_index,
    ik_pointing_down,
    rest_state,
    table_scene_spec,
)
from dopt.tasks.push.clutter import (
    DISTRACTOR_RGBA,
    DISTRACTORS,
    EE_HEIGHT,
    GOAL_CYLINDER,
    GOAL_RGBA,
    STANDOFF,
    add_goal_marker,
    clutter_task,
)
from dopt.tasks.push.soft import (
    DT,
    SOFT,
    SOFT_BODY,
    SOFT_RIGID,
    SoftMaterial,
    _draw_block,
    _finish,
    _half_depth,
    add_soft_block,
)
from dopt.tasks.push.task_model import TaskModel, require_generator

log = logging.getLogger(__name__)

#: the strain bound of the authors' soft blocks (module docstring): an edge may shorten or
#: lengthen by 75 % before a rollout counts as broken
SOFT_STRAIN_BOUND = 0.75
SOFT_BOUNDS = StabilityBounds(max_strain=SOFT_STRAIN_BOUND)
#: the initial plans' tip height on soft_rigid (m): one grid spacing up, about level with
#: the block's second layer of vertices (module docstring: at ``EE_HEIGHT`` the block,
#: squeezed between the pusher and the cylinder, folds its bottom layer over)
SOFT_RIGID_PUSH_HEIGHT = 0.07

#: numbers in one of their layout files: 7 joints, 8 poses of 6, 20 residual targets
LAYOUT_LENGTH = 75
FRICTION = (1.0, 0.005, 0.0001)  # MuJoCo's default, which their objects and table keep
CLUTTER_SOLIMP = (0.0, 0.99, 0.01, 0.5, 2.0)
GOAL_SOLREF = (0.08, 1.1)
OBSTACLE_SOLREF = (0.06, 1.1)
CYLINDER_SOLIMP = (0.0, 0.8, 0.01, 0.5, 2.0)  # soft_rigid's cylinder
CYLINDER_SOLREF = (0.06, 1.0)
MARGIN = 0.001  # m, on every object geom of theirs
CLUTTER_SETTLE_STEPS = 250  # their contacts are soft (time constant 0.06-0.08 s)
SOFT_SETTLE_STEPS = 1000  # their blocks are soft and lightly damped: they rock for ~3 s
#: soft_rigid's start gap between the pusher tip and the block (m): ``STANDOFF`` + 1 cm, so that
#: the wrist (link 7, 4.5 cm around the tool axis, down to 12 cm above the tip) clears their
#: 0.2 m tall block
BLOCK_STANDOFF = STANDOFF + 0.01


@dataclass(frozen=True)
class Shape:
    """One rigid object of theirs: ``kind`` "cylinder" (size: radius, half-height) or "box"
    (size: half-sizes x, y, z), all in m, and its mass (kg)."""

    kind: str
    size: tuple[float, ...]
    mass: float

    @property
    def half_height(self) -> float:
        return self.size[-1]

    def geom_size(self) -> list[float]:
        return [*self.size, 0.0] if self.kind == "cylinder" else list(self.size)


#: mujoco_models Franka_emika_scenes_V1/cylinder_pushing_heavyClutter.xml: the goal cylinder,
#: then obstacle_1 .. obstacle_7 (the order of the poses in their layout files)
GOAL_SHAPE = Shape("cylinder", (0.05, 0.06), 0.3)
OBSTACLE_SHAPES = (
    Shape("cylinder", (0.05, 0.06), 0.55),
    Shape("box", (0.04, 0.05, 0.06), 0.5),
    Shape("cylinder", (0.05, 0.04), 0.6),
    Shape("cylinder", (0.03, 0.05), 0.5),
    Shape("cylinder", (0.06, 0.05), 0.6),
    Shape("cylinder", (0.04, 0.05), 0.4),
    Shape("cylinder", (0.06, 0.05), 0.6),
)
#: soft_rigid's cylinder (push_soft_rigid.xml)
CYLINDER_SHAPE = Shape("cylinder", (0.06, 0.08), 0.74)

#: Rayleigh damping (s) that stands for their edge damping (module docstring)
EDGE_TO_RAYLEIGH = {0.9: 0.0078, 0.8: 0.0069}
SOFT_MATERIAL = SoftMaterial(spacing=0.07, radius=0.005, young=4e3, poisson=0.0,
                             damping=EDGE_TO_RAYLEIGH[0.9], mass=1.0)
SOFT_RIGID_MATERIAL = SoftMaterial(spacing=0.07, radius=0.005, young=4e3, poisson=0.0,
                                   damping=EDGE_TO_RAYLEIGH[0.8], mass=2.0)
SOFT_COUNTS = (3, 4, 3)  # vertices (along the push, across, up)
SOFT_RIGID_COUNTS = (3, 4, 4)


@dataclass(frozen=True)
class AuthorsLayout:
    """One of their clutter scenes, as ``read_layout`` found it in ``path``.

    Attributes:
        arm_qpos: (7,) their arm's joint angles (rad) for franka_sim's Panda; not ours (the same
            pose in our model has joint 6 larger by 1.570 rad), so the builder does not use them.
        poses: (8, 6) x, y, z (m) and roll, pitch, yaw (rad) of the goal cylinder, then of
            obstacles 1-7. Their z belong to their scene (the builder stands every object on
            the table); roll and pitch are 0 in all 100 files and not used.
        targets: (20,) their residuals' targets: goal xy, goal velocity (0, 0), the obstacles'
            xy (their start positions), joint-5 velocity 0, reach 0.
    """

    path: Path
    arm_qpos: np.ndarray
    poses: np.ndarray
    targets: np.ndarray

    @property
    def goal(self) -> np.ndarray:
        """(2,) xy of the goal: where their cost brings the goal cylinder."""
        return self.targets[:2]


def read_layout(path: str | Path) -> AuthorsLayout:
    """Read one of their layout files (``push_mcl_layouts/{i}.csv``): one row of 75 numbers,
    comma separated (their files end with a comma).

    Raises:
        FileNotFoundError: no such file.
        ValueError: naming the file: not one row, a field that is not a number, not 75 numbers,
            or a number that is not finite.
    """
    path = Path(path)
    rows = [row for row in path.read_text().splitlines() if row.strip()]
    if len(rows) != 1:
        raise ValueError(f"{path}: a layout is one row of {LAYOUT_LENGTH} numbers, "
                         f"got {len(rows)} rows")
    fields = [field.strip() for field in rows[0].split(",")]
    if fields[-1] == "":
        fields.pop()
    try:
        values = np.array([float(field) for field in fields])
    except ValueError as error:
        raise ValueError(f"{path}: {error}") from None
    if values.shape != (LAYOUT_LENGTH,):
        raise ValueError(f"{path}: a layout has {LAYOUT_LENGTH} numbers, got {len(values)}")
    bad = np.flatnonzero(~np.isfinite(values))
    if len(bad):
        raise ValueError(f"{path}: number {bad[0]} is {values[bad[0]]}, not finite")
    return AuthorsLayout(path, values[:7], values[7:55].reshape(8, 6), values[55:])


def add_object(spec: mujoco.MjSpec, name: str, shape: Shape, xy: np.ndarray, yaw: float,
               rgba: tuple[float, ...], solref: tuple[float, ...], solimp: tuple[float, ...],
               slides: bool = False) -> None:
    """Add one of their objects standing upright on the table at ``xy``, turned by ``yaw``
    (rad) about z: body, joint(s) and geom named ``name``, with their contact parameters
    (``margin`` ``MARGIN``, friction 1, condim 3).

    A free joint, or with ``slides`` three slide joints along world x, y, z (``name``_x, _y,
    _z; the body is not turned, so ``yaw`` is not used) whose references put the body's world
    position in their qpos, as a free joint's first three coordinates do (so the costs read it
    the same way).
    """
    pos = [xy[0], xy[1], shape.half_height]
    yaw = 0.0 if slides else yaw  # slide axes are in the body's frame
    body = spec.worldbody.add_body(name=name, pos=pos,
                                   quat=[math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)])
    if slides:
        for axis, (label, ref) in enumerate(zip("xyz", pos, strict=True)):
            body.add_joint(name=f"{name}_{label}", type=mujoco.mjtJoint.mjJNT_SLIDE,
                           axis=np.eye(3)[axis].tolist(), ref=ref)
    else:
        body.add_freejoint(name=name)
    kind = mujoco.mjtGeom.mjGEOM_CYLINDER if shape.kind == "cylinder" else mujoco.mjtGeom.mjGEOM_BOX
    body.add_geom(name=name, type=kind, size=shape.geom_size(), mass=shape.mass,
                  friction=list(FRICTION), condim=3, solref=list(solref), solimp=list(solimp),
                  margin=MARGIN, rgba=list(rgba))


def _tip_behind(centre: np.ndarray, goal: np.ndarray, radius: float) -> np.ndarray:
    """(3,) the pusher tip's start: ``STANDOFF`` behind an object of ``radius`` centred at
    ``centre``, on the line from ``goal`` through it, at ``EE_HEIGHT``."""
    along = (goal - centre) / np.linalg.norm(goal - centre)
    xy = centre - (radius + TOOL_RADIUS + STANDOFF) * along
    return np.array([xy[0], xy[1], EE_HEIGHT])


def _clutter_spec(layout: AuthorsLayout) -> tuple[mujoco.MjSpec, np.ndarray]:
    """The clutter scene of ``layout`` before it is compiled, and the goal marker's centre."""
    spec = table_scene_spec(DT, mujoco.mjtIntegrator.mjINT_EULER)
    spec.geom(TABLE_NAME).friction = list(FRICTION)
    add_object(spec, GOAL_CYLINDER, GOAL_SHAPE, layout.poses[0, :2], layout.poses[0, 5],
               GOAL_RGBA, GOAL_SOLREF, CLUTTER_SOLIMP)
    for name, shape, pose in zip(DISTRACTORS, OBSTACLE_SHAPES, layout.poses[1:], strict=True):
        add_object(spec, name, shape, pose[:2], pose[5], DISTRACTOR_RGBA, OBSTACLE_SOLREF,
                   CLUTTER_SOLIMP)
    goal = add_goal_marker(spec, layout.goal, GOAL_SHAPE.size[0], 2 * GOAL_SHAPE.half_height)
    return spec, goal


def _plane_problem(layout: AuthorsLayout, table_half: np.ndarray) -> str | None:
    """What makes the layout's plan view senseless (a goal on the goal cylinder, a goal or
    an object off the table, a goal the pusher cannot reach), or None. ``table_half``: (2,)
    the table's half sizes (m)."""
    centre, goal, radius = layout.poses[0, :2], layout.goal, GOAL_SHAPE.size[0]
    if np.linalg.norm(goal - centre) < radius:
        return (f"the goal {goal.tolist()} lies on the goal cylinder (centre "
                f"{centre.tolist()}, radius {radius} m): there is nothing to push, and no "
                f"direction to push it in")
    names = (GOAL_CYLINDER, *DISTRACTORS)
    places = {"the goal": goal, **{name: pose[:2] for name, pose in
                                   zip(names, layout.poses, strict=True)}}
    for name, xy in places.items():
        if np.any(np.abs(xy) > table_half):
            return (f"{name} at {xy.tolist()} is off the table (|x| <= {table_half[0]:g} m, "
                    f"|y| <= {table_half[1]:g} m)")
    along = (goal - centre) / np.linalg.norm(goal - centre)
    for what, xy in (("the goal cylinder", centre), ("the goal", goal)):
        tip = xy - (radius + TOOL_RADIUS) * along        # the tip touching it, behind it
        try:
            ik_pointing_down(np.array([tip[0], tip[1], EE_HEIGHT]))
        except RuntimeError as e:
            return (f"{what} at {xy.tolist()} is beyond the arm's reach: the pusher cannot "
                    f"stand behind it with the tool down ({e})")
    return None


def _overlap_problem(model: mujoco.MjModel, arm_qpos: np.ndarray) -> str | None:
    """Which two bodies of the scene ``model`` overlap at their start poses with the arm at
    ``arm_qpos`` (MuJoCo's own contacts: a penetration, not the table's), or None: such a
    scene is not what the file means (the overlap is thrown apart while the scene settles,
    objects flying up to 1 m)."""
    data = mujoco.MjData(model)
    data.qpos[arm_qpos_index(model)] = arm_qpos
    mujoco.mj_forward(model, data)
    table = model.geom(TABLE_NAME).id
    worst = min(((c.dist, c.geom1, c.geom2) for c in data.contact[:data.ncon]
                 if table not in (c.geom1, c.geom2)), default=None)
    if worst is None or worst[0] >= 0.0:
        return None
    dist, a, b = worst
    return (f"{model.geom(a).name} and {model.geom(b).name} overlap by {-dist * 1e3:.1f} mm "
            f"at their start poses")


def check_layout(layout_path: str | Path) -> None:
    """Check that one of their layout files (``read_layout``) makes a sensible scene,
    without settling it: the goal off the goal cylinder, every object and the goal on the
    table, the goal cylinder and the goal within the arm's reach (the pusher tip behind each
    on the line of the push, by ``ik_pointing_down``), no two objects overlapping and none
    overlapping the arm at its start (MuJoCo's contacts at the start poses). All 100 of
    theirs pass (their closest objects are 1.0 mm apart; their goals 0.28-0.30 m from the
    goal cylinder, at most 0.71 m from the arm's base).

    Raises:
        FileNotFoundError: no such file.
        ValueError: naming the file and what is wrong (``read_layout``'s, or the above).
    """
    layout = read_layout(layout_path)
    _check_scene(layout, _clutter_spec(layout)[0].compile())


def _check_scene(layout: AuthorsLayout, model: mujoco.MjModel) -> np.ndarray:
    """``check_layout`` on the compiled scene ``model`` of ``layout``; returns the arm's start
    (7,) joint angles."""
    problem = _plane_problem(layout, model.geom(TABLE_NAME).size[:2])
    arm_qpos = None
    if problem is None:
        arm_qpos = ik_pointing_down(_tip_behind(layout.poses[0, :2], layout.goal,
                                                GOAL_SHAPE.size[0]))
        problem = _overlap_problem(model, arm_qpos)
    if problem is not None:
        raise ValueError(f"{layout.path}: {problem}")
    return arm_qpos


def build_clutter_authors(layout_path: str | Path) -> TaskModel:
    """The clutter task on one of their scenes (a file ``read_layout`` reads).

    Their goal cylinder and obstacles (``GOAL_SHAPE``, ``OBSTACLE_SHAPES``; named
    ``GOAL_CYLINDER`` and ``DISTRACTORS``) at the file's xy and yaw, standing on the table, on
    free joints; their contacts (solimp ``CLUTTER_SOLIMP``, solref ``GOAL_SOLREF`` /
    ``OBSTACLE_SOLREF``, margin 1 mm, friction 1, condim 3) and table friction 1 (ours is 0.5,
    and our own clutter keeps it); the goal at the file's target. nv = 7 + 8 x 6 = 55, Euler at
    dt 0.004 s, T 80, Y 2000, slowdown 1, as ours.

    The arm does not start at the file's joint angles, which are for franka_sim's Panda (not
    ours) and put their hand somewhere else: the pusher tip starts ``STANDOFF`` behind the goal
    cylinder on the line from the goal through its centre, at ``EE_HEIGHT``, as in ours.

    Raises:
        FileNotFoundError, ValueError: as ``check_layout`` (a file that is not a layout, or
            whose scene makes no sense: named with the file).
        RuntimeError: the scene raised a MuJoCo warning while it settled.
    """
    layout = read_layout(layout_path)
    spec, goal = _clutter_spec(layout)
    model = spec.compile()
    state = rest_state(model, _check_scene(layout, model), CLUTTER_SETTLE_STEPS)
    log.debug("clutter (authors, %s): goal cylinder %s, goal %s", layout.path,
              layout.poses[0, :2], layout.goal)
    return clutter_task(model, state, goal)


def build_soft_authors(rng: np.random.Generator) -> TaskModel:
    """The soft task with their block (``SOFT_MATERIAL``, ``SOFT_COUNTS``), drawn from ``rng``
    as ours: the block's centre in [0.45, 0.55] x [-0.1, 0.1], a heading within 30 degrees of
    +x, the goal 0.15-0.25 m ahead of the centre. nv 115; T 50, Y 1000, slowdown 3.

    Raises:
        TypeError: ``rng`` is not a ``numpy.random.Generator``.
    """
    block = _draw_block(require_generator(rng), SOFT_COUNTS, notch=False, x=0.5, half_x=0.05,
                        half_y=0.1, material=SOFT_MATERIAL)
    goal_xy = block.centre + rng.uniform(0.15, 0.25) * block.along
    spec = table_scene_spec(DT, mujoco.mjtIntegrator.mjINT_DISCRETE)
    add_soft_block(spec, block.points, block.tets, block.centre, block.heading, SOFT_MATERIAL)
    goal = add_goal_marker(spec, goal_xy, radius=0.05, height=0.002)
    return _finish(SOFT, spec, block, goal, SOFT_BODY,
                   settle_steps=SOFT_SETTLE_STEPS, stability=SOFT_BOUNDS)


def build_soft_rigid_authors(rng: np.random.Generator) -> TaskModel:
    """The soft_rigid task with their block (``SOFT_RIGID_MATERIAL``, ``SOFT_RIGID_COUNTS``)
    and cylinder (``CYLINDER_SHAPE``, solimp ``CYLINDER_SOLIMP``, solref ``CYLINDER_SOLREF``,
    margin 1 mm, on slide joints x, y, z: their cylinder's angular DoFs were inactive), the
    cylinder touching the block's front face (gap 0; settled, pressed in by about 0.6 mm), the
    pusher tip ``BLOCK_STANDOFF`` behind the block. Drawn from ``rng``: the block's centre in
    [0.42, 0.48] x [-0.08, 0.08] (as ours), a heading within 30 degrees of +x, the goal
    0.24-0.30 m beyond the cylinder. nv 154; T 100, Y 1000, slowdown 5.

    The cost reads the cylinder's x and y slides (``TaskModel.cost_dofs``: 2 DoFs).

    Raises:
        TypeError: ``rng`` is not a ``numpy.random.Generator``.
    """
    material = SOFT_RIGID_MATERIAL
    block = _draw_block(require_generator(rng), SOFT_RIGID_COUNTS, notch=False, x=0.45,
                        half_x=0.03, half_y=0.08, material=material)
    half_depth = _half_depth(block.points, material.radius)
    block = replace(block, tip=block.centre - (half_depth + TOOL_RADIUS + BLOCK_STANDOFF)
                    * block.along)
    radius = CYLINDER_SHAPE.size[0]
    cylinder_xy = block.centre + (half_depth + radius) * block.along
    goal_xy = cylinder_xy + rng.uniform(0.24, 0.30) * block.along
    spec = table_scene_spec(DT, mujoco.mjtIntegrator.mjINT_DISCRETE)
    add_soft_block(spec, block.points, block.tets, block.centre, block.heading, material)
    add_object(spec, GOAL_CYLINDER, CYLINDER_SHAPE, cylinder_xy, block.heading, GOAL_RGBA,
               CYLINDER_SOLREF, CYLINDER_SOLIMP, slides=True)
    goal = add_goal_marker(spec, goal_xy, radius, 2 * CYLINDER_SHAPE.half_height)
    return _finish(SOFT_RIGID, spec, block, goal, GOAL_CYLINDER,
                   settle_steps=SOFT_SETTLE_STEPS, stability=SOFT_BOUNDS,
                   push_height=SOFT_RIGID_PUSH_HEIGHT)
