"""Goal shapes of ropes and square cloths, registered by their CLI names.

All positions are in metres, z up, the object centred on the origin of the xy plane.
Shape letters: N particles, F triangles, K corners of a rope goal.

Rope goals are ordered particle chains ``(N, 3)`` lying on the table (z = rope radius).
Cloth goals are an ``n x n`` particle grid (N = n * n) with a triangulation ``(F, 3)`` and the
flat rest positions ``(N, 3)``; folds are analytic and isometric: the folded part rolls over a
half-circle crease of radius ``gap / 2`` so that stacked layers sit exactly ``gap`` apart and no
edge away from the crease changes length.

Cloth vertex numbering follows MuJoCo's ``flexcomp type="grid" dim="2"``: vertex
``i = ix * n + iy`` (y fastest) at ``x = -side / 2 + ix * spacing``,
``y = -side / 2 + iy * spacing``.
"""
from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from dopt.validation import check_int, check_memory, check_real

logger = logging.getLogger(__name__)

ROPE_PARTICLES = 40
ROPE_LENGTH = 0.5
ROPE_RADIUS = 0.005
CLOTH_PARTICLES_PER_SIDE = 40
CLOTH_SIDE = 0.3
#: vertical distance between stacked cloth layers, about one particle radius
CLOTH_LAYER_GAP = 0.005
#: key particles of each cloth fold at any resolution: its corners and both ends of every
#: crease (4 = the paper's; the others are ours, docs/DESIGN-NOTES.md "Key particles"); the
#: reference the sweeps and benchmarks count against
CLOTH_REFERENCE_KEYS = {"cloth_diagonal": 4, "cloth_side": 6, "cloth_reflective": 8,
                        "cloth_underneath": 10}

TRIANGULATIONS = ("mujoco", "anti", "alternating", "random")
#: bytes per particle that building a goal and reducing it to its key particles may take (its
#: positions, faces and the reductions' per-particle arrays, generously): a goal's size is
#: checked against this machine's memory before anything is allocated
CLOTH_BYTES_PER_PARTICLE = 4096
ROPE_BYTES_PER_PARTICLE = 1024


def check_cloth_size(n, name: str = "n") -> int:
    """``n`` particles per side as an int: >= 2, and its ``n * n`` particles within this
    machine's memory (``CLOTH_BYTES_PER_PARTICLE`` each; ``dopt.validation.check_memory``).
    The messages name ``name`` (a CLI passes its flag)."""
    check_int(n, name)
    if n < 2:
        raise ValueError(f"a cloth grid needs at least 2 particles per side, got {name}={n}")
    check_memory(float(n) * n * CLOTH_BYTES_PER_PARTICLE,
                 f"{name}={n}: a cloth of {n} x {n} = {float(n) * n:.3g} particles")
    return int(n)


def _frozen(array: np.ndarray, dtype) -> np.ndarray:
    out = np.array(array, dtype=dtype, copy=True)
    out.setflags(write=False)
    return out


@dataclass(frozen=True)
class RopeGoal:
    """A rope goal.

    Attributes:
        name: registry name of the goal.
        positions: ``(N, 3)`` particle positions, ordered along the rope.
        corners: ``(K,)`` indices of the particles at the ends and corners of the goal shape.
    """

    name: str
    positions: np.ndarray
    corners: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "positions", _frozen(self.positions, float))
        object.__setattr__(self, "corners", _frozen(self.corners, np.int64))


@dataclass(frozen=True)
class ClothGoal:
    """A cloth goal.

    Attributes:
        name: registry name of the goal.
        positions: ``(N, 3)`` goal particle positions.
        faces: ``(F, 3)`` triangles (counter-clockwise seen from +z in the rest shape).
        rest_positions: ``(N, 3)`` flat rest positions (z = 0).
        layer_gap: distance between stacked layers in metres.
    """

    name: str
    positions: np.ndarray
    faces: np.ndarray
    rest_positions: np.ndarray
    layer_gap: float = CLOTH_LAYER_GAP

    def __post_init__(self):
        object.__setattr__(self, "positions", _frozen(self.positions, float))
        object.__setattr__(self, "faces", _frozen(self.faces, np.int64))
        object.__setattr__(self, "rest_positions", _frozen(self.rest_positions, float))


# ----------------------------------------------------------------------------------- rope
def _resample(path: np.ndarray, n: int) -> np.ndarray:
    """``n`` points evenly spaced by arc length along the polyline ``path`` ``(k, 2)``."""
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(path, axis=0), axis=1))])
    t = np.linspace(0.0, s[-1], n)
    return np.stack([np.interp(t, s, path[:, d]) for d in range(path.shape[1])], axis=1)


def _check_rope_size(n: int, length: float) -> None:
    check_int(n, "n")
    if n < 3:
        raise ValueError(f"a rope needs at least 3 particles, got n={n}")
    check_memory(float(n) * ROPE_BYTES_PER_PARTICLE, f"n={n}: a rope of {n} particles")
    if not isinstance(length, (int, float, np.integer, np.floating)) or isinstance(length, bool):
        raise TypeError(f"length must be a number of metres, got {length!r}")
    if not np.isfinite(length) or length <= 0:
        raise ValueError(f"rope length must be a positive number of metres, got {length}")


def _check_generator(rng, name: str = "rng") -> None:
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"{name} must be a numpy.random.Generator, got {type(rng).__name__}")


def rope_straight(n: int = ROPE_PARTICLES, length: float = ROPE_LENGTH,
                  angle: float = 0.0) -> RopeGoal:
    """Straight rope of ``n`` particles along the xy direction ``angle`` (radians).

    Returns a :class:`RopeGoal` with ``positions`` ``(n, 3)`` and ``corners`` = the two ends.
    """
    _check_rope_size(n, length)
    check_real(angle, "angle")
    direction = np.array([np.cos(angle), np.sin(angle)])
    t = np.linspace(-length / 2, length / 2, n)
    positions = np.zeros((n, 3))
    positions[:, :2] = t[:, None] * direction
    positions[:, 2] = ROPE_RADIUS
    return RopeGoal("rope_straighten", positions, np.array([0, n - 1]))


def rope_crossed_triangle(n: int = ROPE_PARTICLES, length: float = ROPE_LENGTH,
                          legs: tuple[float, float, float] = (1.0, 1.0, 1.0),
                          cross_at: float = 0.3, overshoot: float = 0.25) -> RopeGoal:
    """Rope folded into a crossed triangle (the paper's "rope folding" goal, Fig. 4b).

    The rope runs A -> B -> C -> D with leg lengths proportional to ``legs``; the last leg crosses
    the first one at the fraction ``cross_at`` of AB (measured from A) and goes on past it for
    the fraction ``overshoot`` of its own length. Particles of the last leg near the crossing are
    lifted by one rope diameter, so the rope lies over itself.

    Returns a :class:`RopeGoal` with ``positions`` ``(n, 3)`` and ``corners`` = the particles at
    A, B, C and D.

    Raises:
        ValueError: if the legs cannot form such a triangle, or ``n`` is too small to put its
            four corners on distinct particles.
    """
    _check_rope_size(n, length)
    check_real(cross_at, "cross_at", positive=True, maximum=1.0)
    check_real(overshoot, "overshoot", minimum=0.0)
    if overshoot >= 1.0:
        raise ValueError(f"overshoot must be < 1, got {overshoot!r}")
    legs_arr = np.asarray(legs, dtype=float)
    if legs_arr.shape != (3,) or not np.all(np.isfinite(legs_arr)) or np.any(legs_arr <= 0):
        raise ValueError(f"legs must be three positive lengths, got {legs}")
    l1, l2, l3 = legs_arr / legs_arr.sum() * length
    d = l1 * (1.0 - cross_at)          # distance from B back to the crossing point X
    reach = (1.0 - overshoot) * l3     # |C - X|
    cos_turn = (reach ** 2 - d ** 2 - l2 ** 2) / (2.0 * d * l2)
    if not -1.0 <= cos_turn <= 1.0:
        raise ValueError(f"legs {tuple(legs)} cannot form a crossed triangle "
                         f"(last leg must reach back across the first)")
    turn = np.arccos(cos_turn)
    a = np.array([0.0, 0.0])
    b = np.array([l1, 0.0])
    c = b + l2 * np.array([np.cos(turn), np.sin(turn)])
    x = np.array([cross_at * l1, 0.0])
    dvec = c + l3 * (x - c) / np.linalg.norm(x - c)
    path = np.stack([a, b, c, dvec])
    centre = 0.5 * (path.min(axis=0) + path.max(axis=0))
    path -= centre
    positions = np.zeros((n, 3))
    positions[:, :2] = _resample(path, n)
    positions[:, 2] = ROPE_RADIUS
    crossing = x - centre
    arc = np.linspace(0.0, length, n)
    on_last_leg = arc > l1 + l2
    bump = np.clip(1.0 - np.linalg.norm(positions[:, :2] - crossing, axis=1) / (4 * ROPE_RADIUS),
                   0.0, 1.0)
    positions[on_last_leg, 2] += 2 * ROPE_RADIUS * bump[on_last_leg]
    corner_arc = np.array([0.0, l1, l1 + l2, length])
    corners = np.rint(corner_arc / length * (n - 1)).astype(np.int64)
    if len(np.unique(corners)) < len(corners):
        raise ValueError(f"n={n} particles cannot place the fold's 4 corners A, B, C, D on "
                         f"distinct particles (they fall on {corners.tolist()}): use more "
                         f"particles")
    name = "rope_fold" if np.allclose(legs_arr, legs_arr[0]) else "rope_fold_unequal"
    return RopeGoal(name, positions, corners)


def rope_crumpled(rng: np.random.Generator, n: int = ROPE_PARTICLES,
                  length: float = ROPE_LENGTH, turn: float = 0.6, smooth: int = 3) -> RopeGoal:
    """Random smooth planar rope (a crumpled start configuration), evenly spaced particles.

    The heading performs a smoothed random walk with per-step turn ``turn`` radians (std).

    Returns a :class:`RopeGoal` with ``positions`` ``(n, 3)`` and ``corners`` = the two ends.
    """
    _check_rope_size(n, length)
    _check_generator(rng)
    check_real(turn, "turn", minimum=0.0)
    check_int(smooth, "smooth", minimum=1)
    turns = np.convolve(rng.normal(0.0, turn, n - 1), np.ones(smooth) / smooth, mode="same")
    heading = np.cumsum(turns)
    steps = np.stack([np.cos(heading), np.sin(heading)], axis=1) * length / (n - 1)
    positions = np.zeros((n, 3))
    positions[1:, :2] = np.cumsum(steps, axis=0)
    positions[:, :2] -= positions[:, :2].mean(axis=0)
    positions[:, 2] = ROPE_RADIUS
    return RopeGoal("rope_crumpled", positions, np.array([0, n - 1]))


# ---------------------------------------------------------------------------------- cloth
def grid_faces(n: int, triangulation: str = "mujoco",
               rng: np.random.Generator | None = None) -> np.ndarray:
    """Triangles ``(2 (n-1)^2, 3)`` of an ``n x n`` grid numbered ``ix * n + iy``.

    Args:
        triangulation: how each grid square is split:
            ``"mujoco"`` along (ix, iy)-(ix+1, iy+1), exactly MuJoCo's flexcomp grid;
            ``"anti"`` along the other diagonal (ix+1, iy)-(ix, iy+1);
            ``"alternating"`` the two in a checkerboard ("union jack");
            ``"random"`` each square at random (needs ``rng``).
    """
    if not isinstance(triangulation, str) or triangulation not in TRIANGULATIONS:
        raise ValueError(f"unknown triangulation {triangulation!r}; choose from {TRIANGULATIONS}")
    check_cloth_size(n)
    ix, iy = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
    ix, iy = ix.ravel(), iy.ravel()
    v00, v10 = ix * n + iy, (ix + 1) * n + iy
    v01, v11 = ix * n + iy + 1, (ix + 1) * n + iy + 1
    if triangulation == "mujoco":
        main = np.ones(len(ix), dtype=bool)
    elif triangulation == "anti":
        main = np.zeros(len(ix), dtype=bool)
    elif triangulation == "alternating":
        main = (ix + iy) % 2 == 0
    else:
        if rng is None:
            raise ValueError("triangulation='random' needs a numpy.random.Generator rng")
        _check_generator(rng)
        main = rng.random(len(ix)) < 0.5
    first = np.where(main[:, None], np.stack([v00, v10, v11], 1), np.stack([v00, v10, v01], 1))
    second = np.where(main[:, None], np.stack([v00, v11, v01], 1), np.stack([v10, v11, v01], 1))
    return np.stack([first, second], axis=1).reshape(-1, 3).astype(np.int64)


def cloth_rest(n: int = CLOTH_PARTICLES_PER_SIDE, side: float = CLOTH_SIDE) -> np.ndarray:
    """Flat rest positions ``(n * n, 3)`` of the cloth grid, z = 0."""
    check_cloth_size(n)
    check_real(side, "side")
    if side <= 0:
        raise ValueError(f"cloth side must be a positive number of metres, got {side}")
    coord = -side / 2 + np.arange(n) * side / (n - 1)
    x, y = np.meshgrid(coord, coord, indexing="ij")
    return np.stack([x.ravel(), y.ravel(), np.zeros(n * n)], axis=1)


def roll_over(positions: np.ndarray, movable: np.ndarray, point: np.ndarray,
              normal: np.ndarray, height: float, radius: float, up: bool = True) -> np.ndarray:
    """Isometric fold: roll part of a horizontal sheet over a half-circle crease.

    The crease is the vertical plane through the xy ``point`` with horizontal ``normal``.
    Particles in ``movable`` ``(N,)`` on the ``+normal`` side, lying on the plane z = ``height``,
    are rolled over a half circle of ``radius`` and land on the plane z = ``height +- 2 radius``
    (``up`` decides the sign) on the other side of the crease.

    Returns new positions ``(N, 3)``.
    """
    out = np.array(positions, dtype=float, copy=True)
    normal = np.asarray(normal, dtype=float) / np.linalg.norm(normal)
    dist = (out[:, :2] - np.asarray(point, dtype=float)) @ normal
    sel = movable & (dist > 0)
    s = dist[sel]
    on_arc = s < np.pi * radius
    angle = np.minimum(s / radius, np.pi)
    along = np.where(on_arc, radius * np.sin(angle), -(s - np.pi * radius))
    sign = 1.0 if up else -1.0
    out[sel, :2] += (along - s)[:, None] * normal
    out[sel, 2] = height + sign * radius * (1.0 - np.cos(angle))
    return out


def _cloth_base(n: int, side: float, triangulation: str,
                rng: np.random.Generator | None, gap: float) -> tuple[np.ndarray, np.ndarray]:
    rest = cloth_rest(n, side)
    check_real(gap, "gap", positive=True)
    return rest, grid_faces(n, triangulation, rng)


def cloth_flat(n: int = CLOTH_PARTICLES_PER_SIDE, side: float = CLOTH_SIDE,
               triangulation: str = "mujoco", rng: np.random.Generator | None = None,
               gap: float = CLOTH_LAYER_GAP) -> ClothGoal:
    """The flat cloth (goal = rest shape)."""
    rest, faces = _cloth_base(n, side, triangulation, rng, gap)
    return ClothGoal("cloth_flat", rest, faces, rest, gap)


def cloth_diagonal(n: int = CLOTH_PARTICLES_PER_SIDE, side: float = CLOTH_SIDE,
                   triangulation: str = "mujoco", rng: np.random.Generator | None = None,
                   gap: float = CLOTH_LAYER_GAP) -> ClothGoal:
    """Diagonal fold: the corner (+x, +y) is folded onto (-x, -y) across the line x + y = 0."""
    rest, faces = _cloth_base(n, side, triangulation, rng, gap)
    everything = np.ones(len(rest), dtype=bool)
    goal = roll_over(rest, everything, np.zeros(2), np.array([1.0, 1.0]), 0.0, gap / 2)
    return ClothGoal("cloth_diagonal", goal, faces, rest, gap)


def _side_fold(rest: np.ndarray, gap: float) -> np.ndarray:
    everything = np.ones(len(rest), dtype=bool)
    return roll_over(rest, everything, np.zeros(2), np.array([1.0, 0.0]), 0.0, gap / 2)


def _reflective_fold(rest: np.ndarray, side: float, gap: float) -> np.ndarray:
    top = rest[:, 0] > 0
    return roll_over(_side_fold(rest, gap), top, np.array([-side / 4, 0.0]),
                     np.array([-1.0, 0.0]), gap, gap / 2)


def cloth_side(n: int = CLOTH_PARTICLES_PER_SIDE, side: float = CLOTH_SIDE,
               triangulation: str = "mujoco", rng: np.random.Generator | None = None,
               gap: float = CLOTH_LAYER_GAP) -> ClothGoal:
    """Side fold: the half x > 0 is folded over onto the half x < 0 (crease x = 0)."""
    rest, faces = _cloth_base(n, side, triangulation, rng, gap)
    return ClothGoal("cloth_side", _side_fold(rest, gap), faces, rest, gap)


def cloth_reflective(n: int = CLOTH_PARTICLES_PER_SIDE, side: float = CLOTH_SIDE,
                     triangulation: str = "mujoco", rng: np.random.Generator | None = None,
                     gap: float = CLOTH_LAYER_GAP) -> ClothGoal:
    """Reflective fold: the side fold, then the outer quarter of the top layer folded back on top
    (crease x = -side / 4), a Z-fold with 3 layers over -side/4 < x < 0."""
    rest, faces = _cloth_base(n, side, triangulation, rng, gap)
    return ClothGoal("cloth_reflective", _reflective_fold(rest, side, gap), faces, rest, gap)


def cloth_underneath(n: int = CLOTH_PARTICLES_PER_SIDE, side: float = CLOTH_SIDE,
                     triangulation: str = "mujoco", rng: np.random.Generator | None = None,
                     gap: float = CLOTH_LAYER_GAP) -> ClothGoal:
    """Underneath fold: after the reflective fold, the remaining single-layer quarter
    (x < -side / 4) is folded under the rest, giving 4 layers over -side/4 < x < 0."""
    rest, faces = _cloth_base(n, side, triangulation, rng, gap)
    reflective = _reflective_fold(rest, side, gap)
    bottom = rest[:, 0] < 0
    goal = roll_over(reflective, bottom, np.array([-side / 4, 0.0]), np.array([-1.0, 0.0]),
                     0.0, gap / 2, up=False)
    goal[:, 2] += gap
    return ClothGoal("cloth_underneath", goal, faces, rest, gap)


def lift_layers(goal: ClothGoal, lift: float) -> np.ndarray:
    """A folded cloth goal with its layers pulled apart: ``(N, 3)`` positions, each particle
    raised ``lift`` (m) per layer gap of its height above the floor (``z / goal.layer_gap``),
    so the layer k gaps up rises ``k * lift`` and a crease between two layers is drawn out
    between them; the bottom layer stays.

    The start the key-particle authors prepare for a multi-layer fold (SoftGym's
    ``_set_to_folded``: each folded layer placed over the one below it, lifted 5 cm a layer,
    and dropped) is this with their lift; ``planners.pick_place.problem.drop_fold`` drops it
    in the simulator.
    """
    if not isinstance(goal, ClothGoal):
        raise TypeError(f"goal must be a ClothGoal, got {type(goal).__name__}")
    lift = check_real(lift, "lift", minimum=0)
    out = np.array(goal.positions, dtype=float)
    out[:, 2] += lift * out[:, 2] / goal.layer_gap
    return out


GoalFactory = Callable[..., "RopeGoal | ClothGoal"]

#: goals by CLI name; rope factories take (n, length), cloth factories (n, side, triangulation,
#: rng, gap)
GOALS: dict[str, GoalFactory] = {
    "rope_straighten": rope_straight,
    "rope_fold": rope_crossed_triangle,
    "rope_fold_unequal": lambda n=ROPE_PARTICLES, length=ROPE_LENGTH: rope_crossed_triangle(
        n, length, legs=(1.0, 1.3, 1.6)),
    "cloth_flat": cloth_flat,
    "cloth_diagonal": cloth_diagonal,
    "cloth_side": cloth_side,
    "cloth_reflective": cloth_reflective,
    "cloth_underneath": cloth_underneath,
}

#: multi-step tasks (the paper's Sec. III-D): the intermediate goals, in order, ending with the task
GOAL_SEQUENCES: dict[str, tuple[str, ...]] = {
    "cloth_reflective": ("cloth_side", "cloth_reflective"),
    "cloth_underneath": ("cloth_side", "cloth_reflective", "cloth_underneath"),
}


def make_goal(name: str, **kwargs) -> RopeGoal | ClothGoal:
    """Build the goal registered as ``name`` (see :data:`GOALS`) with factory ``kwargs``.

    Raises:
        ValueError: an unknown name or a bad value; TypeError: an argument the factory does
            not take, or of the wrong type (n not an int, rng not a Generator, ...).
    """
    if not isinstance(name, str) or name not in GOALS:
        raise ValueError(f"unknown goal {name!r}; choose from {sorted(GOALS)}")
    return GOALS[name](**kwargs)


def goal_sequence(name: str, **kwargs) -> list[RopeGoal | ClothGoal]:
    """The sequence of goals of task ``name``: intermediate goals first, the final goal last.

    Single-step tasks give a list with one goal."""
    return [make_goal(step, **kwargs) for step in GOAL_SEQUENCES.get(name, (name,))]
