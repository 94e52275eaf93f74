"""Cloth fold goals made by the simulator: each fold held along a line and turned over its crease.

What a user with a simulator does to make a folded goal: grasp the moving part of the sheet along
its edge farthest from the crease, turn that edge over the crease on a half circle, let go and
let the sheet settle; the rest of the moving part follows through the cloth's own physics. The
grasp is one ``connect`` equality per held particle to a world point that follows the path (added
to a copy of the scene's model): MuJoCo's soft constraint, so a sheet that cannot follow pulls
back instead of being stretched without limit, and the stability verdict skips the held
particles' edges as it does the picker's grasp. The one-point picker of ``planners.scripted`` does
not fold the stiff default sheet this cleanly (docs/DESIGN-NOTES.md, "Goals made by the
simulator").

A fold is a ``Crease`` of the flat sheet: a material line and the side of it that moves.
``folds`` gives the cloth tasks' creases for a sheet of edge ``side`` centred at the origin, in
the coordinates of ``deformables.goals``. The underneath fold tucks a flap under a stack, which a
grasp from above a floor cannot do without lifting the stack; its creases make the same stack
(the same layers in the same order joined by the same creases) as an accordion of three folds on
top: the paper's goal reflected in x, the same shape to the key-particle reduction.

Shapes: N particles, ns state size.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, replace

import mujoco
import numpy as np

from dopt.stability import Monitor
from dopt.state import INTEGRATION
from dopt.tasks.pick.picker import CONTROL_SPEC, fix_grasp_anchors
from dopt.tasks.pick.scene import DeformableScene
from dopt.validation import check_real, float_array

log = logging.getLogger(__name__)

#: the state a scene's model and its copy with the hold equalities share (the picker's grasp
#: flags stay off throughout)
_SHARED_STATE = INTEGRATION & ~int(mujoco.mjtState.mjSTATE_EQ_ACTIVE)

#: how deep the grasp reaches into the moving part, in grid spacings from its farthest particle
GRIP = 1.5


@dataclass(frozen=True)
class Crease:
    """One fold, in the flat sheet's own coordinates (its rest positions, z = 0): the material
    line through the xy ``point`` (2,) with the unit ``normal`` (2,) pointing to the part that
    moves. Where that line and that part are in the world is read from the current state when
    the fold starts, so a fold follows the sheet wherever earlier folds put it."""

    point: tuple[float, float]
    normal: tuple[float, float]

    def __post_init__(self):
        for name in ("point", "normal"):
            value = float_array(getattr(self, name), f"Crease.{name}", (2,))
            object.__setattr__(self, name, tuple(float(v) for v in value))
        norm = float(np.hypot(*self.normal))
        if not norm > 0:
            raise ValueError("Crease.normal must be a non-zero xy vector")
        object.__setattr__(self, "normal", (self.normal[0] / norm, self.normal[1] / norm))

    def distance(self, rest: np.ndarray) -> np.ndarray:
        """(N, 3) rest positions -> (N,) signed distance from the crease line (m)."""
        return (rest[:, :2] - np.asarray(self.point)) @ np.asarray(self.normal)


@dataclass(frozen=True)
class _Turn:
    """A crease placed in the world: the horizontal line through ``point`` (3,) normal to the
    horizontal unit vector ``normal`` (3,), which points to the moving side."""

    point: np.ndarray
    normal: np.ndarray

    def distance(self, p: np.ndarray) -> np.ndarray:
        return (p - self.point)[:, :2] @ self.normal[:2]


def folds(task: str, side: float) -> tuple[Crease, ...]:
    """The creases of cloth task ``task`` ("cloth_diagonal", "cloth_side",
    "cloth_reflective", "cloth_underneath") on a sheet of edge ``side`` (m) centred at the
    origin, in order (see the module docstring for the underneath fold)."""
    side = check_real(side, "side", positive=True)
    q = side / 4
    half = Crease((0.0, 0.0), (1.0, 0.0))
    table = {
        "cloth_diagonal": (Crease((0.0, 0.0), (1.0, 1.0)),),
        "cloth_side": (half,),
        "cloth_reflective": (half, Crease((q, 0.0), (1.0, 0.0))),
        "cloth_underneath": (Crease((-q, 0.0), (1.0, 0.0)), half, Crease((q, 0.0), (1.0, 0.0))),
    }
    if task not in table:
        raise ValueError(f"no folds for task {task!r}; choose from {', '.join(table)}")
    return table[task]


def _turn_over(positions: np.ndarray, turn: _Turn, axis_height: float,
               angle: float) -> np.ndarray:
    """Positions (M, 3) turned by ``angle`` (rad) about the world crease line ``turn`` at
    height ``axis_height`` (m), the moving side going up and over."""
    p = np.asarray(positions, dtype=float)
    s = turn.distance(p)                                # along the normal, from the crease
    h = p[:, 2] - axis_height
    out = p.copy()
    out[:, :2] += (s * np.cos(angle) - h * np.sin(angle) - s)[:, None] * turn.normal[:2]
    out[:, 2] = axis_height + s * np.sin(angle) + h * np.cos(angle)
    return out


def ideal_folds(rest: np.ndarray, creases: Sequence[Crease], gap: float) -> np.ndarray:
    """The folds as rigid turns with sharp creases: (N, 3) flat rest positions -> (N, 3), each
    fold landing its moving part ``gap`` (m) above the layer below it (the reference a
    simulated goal is measured against)."""
    rest = float_array(rest, "rest", (None, 3))
    gap = check_real(gap, "gap", positive=True)
    spacing = _spacing(rest)
    p = rest.copy()
    for crease in creases:
        moving = crease.distance(rest) > 0
        turn = _place(crease, rest, p, moving, spacing)
        p[moving] = _turn_over(p[moving], turn, _axis_height(p, moving, gap), np.pi)
    return p


@dataclass(frozen=True)
class FoldGoal:
    """A goal made by the simulator: positions (N, 3) and state (ns,) after the last fold
    settled; held: the particles grasped in each fold; unstable, reason: the first stability
    bound a fold or a settle broke (``dopt.stability``; the energy bound only in the settles,
    the grasp doing work while it holds)."""

    positions: np.ndarray
    state: np.ndarray
    held: tuple[np.ndarray, ...]
    unstable: bool
    reason: str


def fold_goal(scene: DeformableScene, creases: Sequence[Crease], start: np.ndarray | None = None,
              speed: float = 0.1, settle: float = 1.0, slack: float = 0.02) -> FoldGoal:
    """Fold the cloth of ``scene`` over ``creases`` in order, from ``start`` (ns,) (default:
    its initial state, whose particle positions are also the rest sheet the creases refer to).

    Each fold holds the moving particles within ``GRIP`` grid spacings of the farthest one from
    the crease (the far edge's rows, or the corner of a diagonal fold), turns them
    over on a half circle about the crease's line where the sheet is now, at the height that
    lands them one contact gap (two particle radii) above the layer below, with a smooth start
    and stop and a top speed of ``speed`` (m/s), lets go and settles ``settle`` seconds. The
    turning line sits ``(pi * gap / 2 + slack) / 2`` on the moving side of the crease, so that
    the held edge lands short of a rigid turn by the length a rounded crease takes (``slack``
    beyond a crease of radius gap / 2: the default sheet's crease loop is wider). The picker
    stays idle.

    Raises:
        TypeError: a scene that is not a DeformableScene, creases that are not Creases.
        ValueError: no creases, a bad speed, settle or slack, a start of the wrong size, a
            scene without its MJCF, a crease that moves no particle or passes none.
    """
    if not isinstance(scene, DeformableScene):
        raise TypeError(f"scene must be a DeformableScene, got {type(scene).__name__}")
    creases = tuple(creases)
    if not creases or not all(isinstance(c, Crease) for c in creases):
        raise TypeError("creases must be a non-empty sequence of Crease")
    speed = check_real(speed, "speed", positive=True)
    settle = check_real(settle, "settle", minimum=0)
    state = scene.initial_state if start is None else float_array(start, "start", (scene.nstate,))
    if scene.xml is None:
        raise ValueError("scene has no MJCF (DeformableScene.xml) to add the grasp to")
    rest = scene.positions(state)
    spacing = _spacing(rest)
    slack = check_real(slack, "slack", minimum=0)
    plan = _fold_plan(creases, rest, spacing)
    m, hold_eq = _hold_model(scene, plan)
    data, source = mujoco.MjData(m), mujoco.MjData(scene.model)
    mujoco.mj_setState(scene.model, source, state, scene.scene.layout.spec)
    mujoco.mj_setState(scene.model, source, scene.picker.idle_row, CONTROL_SPEC)
    _copy_state(scene.model, source, m, data)
    bounds = scene.scene.stability
    judges = (Monitor(m, replace(bounds, max_energy_gain=None)), Monitor(m, bounds))
    gap = 2 * scene.radius
    step, reason = 0, ""
    for i, (crease, moving, held) in enumerate(plan):
        _copy_state(m, data, scene.model, source)
        p = scene.positions(scene.scene.state_of(source))
        turn, height, nsteps = _fold_path(crease, rest, p, moving, held, spacing, gap, slack,
                                          speed, m.opt.timestep)
        log.info("fold %d: %d moving, %d held, %.2f s", i, int(moving.sum()), len(held),
                 nsteps * m.opt.timestep)
        step, reason = _turn_and_settle(m, data, hold_eq[held], p[held], turn, height, nsteps,
                                        settle, judges, step, reason)
    _copy_state(m, data, scene.model, source)
    final = scene.scene.state_of(source)
    if reason:
        log.warning("fold goal: %s", reason)
    return FoldGoal(scene.positions(final), final, tuple(h for _, _, h in plan), bool(reason),
                    reason)


def _fold_plan(creases: tuple[Crease, ...], rest: np.ndarray, spacing: float
               ) -> list[tuple[Crease, np.ndarray, np.ndarray]]:
    """[(crease, moving (N,) bool, held particle indices)] of each fold of ``fold_goal``: the
    particles on the crease's moving side, and those of them within ``GRIP`` grid spacings of
    the farthest one.

    Raises:
        ValueError: a crease that moves no particle.
    """
    plan = []
    for i, crease in enumerate(creases):
        dist = crease.distance(rest)
        moving = dist > 0
        if not moving.any():
            raise ValueError(f"fold {i}: {crease} moves no particle of the sheet")
        plan.append((crease, moving,
                     np.flatnonzero(moving & (dist >= dist[moving].max() - GRIP * spacing))))
    return plan


def _hold_model(scene: DeformableScene, plan) -> tuple[mujoco.MjModel, np.ndarray]:
    """(a copy of the scene's model with one inactive ``connect`` equality per particle held
    in any fold of ``plan``, hold_eq (N,): the equality id of each particle, -1 if none)."""
    grasped = np.unique(np.concatenate([held for _, _, held in plan]))
    holds = "".join(f'<connect name="hold{i}" body1="{scene.flex}_{i}" body2="world" '
                    f'anchor="0 0 0" active="false"/>' for i in grasped)
    m = mujoco.MjModel.from_xml_string(scene.xml.replace("</equality>", holds + "</equality>"))
    fix_grasp_anchors(m)
    hold_eq = np.full(scene.n_particles, -1)
    hold_eq[grasped] = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_EQUALITY, f"hold{i}")
                        for i in grasped]
    return m, hold_eq


def _fold_path(crease: Crease, rest: np.ndarray, p: np.ndarray, moving: np.ndarray,
               held: np.ndarray, spacing: float, gap: float, slack: float, speed: float,
               timestep: float) -> tuple[_Turn, float, int]:
    """(the turning line, its height, the number of steps) of one fold from the positions
    ``p`` (N, 3) (``fold_goal``: the line shifted by the rounded crease's length, the
    duration from the held particles' largest radius and the top speed)."""
    turn = _place(crease, rest, p, moving, spacing)
    turn = replace(turn, point=turn.point + 0.5 * (np.pi * gap / 2 + slack) * turn.normal)
    height = _axis_height(p, moving, gap)
    start_pos = p[held]
    radius = float(np.hypot(turn.distance(start_pos), start_pos[:, 2] - height).max())
    duration = np.pi ** 2 * radius / (2 * speed)    # peak of the cosine profile = speed
    return turn, height, max(1, int(np.ceil(duration / timestep)))


def _turn_and_settle(m: mujoco.MjModel, data: mujoco.MjData, eq: np.ndarray,
                     start_pos: np.ndarray, turn: _Turn, height: float, nsteps: int,
                     settle: float, judges, step: int, reason: str) -> tuple[int, str]:
    """One fold in ``data``: the held particles' equalities ``eq`` turn them from
    ``start_pos`` over ``turn`` in ``nsteps`` steps (a smooth start and stop), let go, and
    the sheet settles ``settle`` seconds; each phase judged by its monitor of ``judges``.
    Returns (the step count, the first broken bound) carried on from ``step``, ``reason``."""
    m.eq_data[eq, 3:6] = start_pos
    data.eq_active[eq] = 1
    scan = judges[0].start(1)
    for k in range(1, nsteps + 1):
        angle = np.pi * (1 - np.cos(np.pi * k / nsteps)) / 2
        m.eq_data[eq, 3:6] = _turn_over(start_pos, turn, height, angle)
        mujoco.mj_step(m, data)
        reason = reason or _judge(scan, data, step)
        step += 1
    data.eq_active[eq] = 0
    scan = judges[1].start(1)
    for _ in range(int(round(settle / m.opt.timestep))):
        mujoco.mj_step(m, data)
        reason = reason or _judge(scan, data, step)
        step += 1
    return step, reason


def _copy_state(ma: mujoco.MjModel, a: mujoco.MjData, mb: mujoco.MjModel,
                b: mujoco.MjData) -> None:
    """Copy the state of ``a`` into ``b`` (MuJoCo's integration state but the equalities'
    active flags: ``mb`` is ``ma`` with, or without, the hold equalities appended)."""
    state = np.empty(mujoco.mj_stateSize(ma, _SHARED_STATE))
    mujoco.mj_getState(ma, a, state, _SHARED_STATE)
    mujoco.mj_setState(mb, b, state, _SHARED_STATE)


def _place(crease: Crease, rest: np.ndarray, p: np.ndarray, moving: np.ndarray,
           spacing: float) -> _Turn:
    """Where the crease is in the world: the line through the particles (now at ``p``) nearest
    to it on the rest sheet (the row on it, or the rows on either side of it), its normal
    towards the moving part."""
    d = np.abs(crease.distance(rest))
    if not d.min() < spacing:
        raise ValueError(f"{crease} passes no particle of the sheet (nearest {d.min():.4g} m)")
    on_line = d <= d.min() + spacing / 4
    xy = p[on_line, :2]
    centre = xy.mean(axis=0)
    if len(xy) > 1:
        direction = np.linalg.svd(xy - centre)[2][0]
    else:                                          # one particle: the rest sheet's direction
        direction = np.array([-crease.normal[1], crease.normal[0]])
    normal = np.array([-direction[1], direction[0]])
    if (p[moving, :2].mean(axis=0) - centre) @ normal < 0:
        normal = -normal
    return _Turn(np.array([*centre, 0.0]), np.array([*normal, 0.0]))


def _axis_height(p: np.ndarray, moving: np.ndarray, gap: float) -> float:
    """The height of the turning line that lands the moving part's lowest layer ``gap``
    above the highest particle it lands on (the stationary particles within reach)."""
    rest = ~moving
    top = p[rest, 2].max() if rest.any() else p[:, 2].min()
    return 0.5 * (top + gap + p[moving, 2].max())


def _spacing(rest: np.ndarray) -> float:
    """The grid spacing of a rest sheet: the median distance to the nearest other particle."""
    from scipy.spatial import cKDTree
    return float(np.median(cKDTree(rest).query(rest, k=2)[0][:, 1]))


def _judge(scan, data: mujoco.MjData, step: int) -> str:
    """Feed one step into ``scan``; the reason if it broke a bound."""
    fields = {name: np.asarray(getattr(data, name)).copy()[None, None]
              for name in scan.monitor.record}
    if scan.update(np.array([0]), step, fields).size:
        return f"step {step}: {scan.reason[0]}"
    return ""
