"""Resample a cloth goal onto a canonical grid of its flat rest sheet.

Shape letters: N particles, F faces of the goal mesh, M grid nodes, G grid faces.

A cloth goal is a surface: the map from the flat rest sheet to the goal, sampled at the
particles and interpolated linearly over the faces. The key particles must depend on that
surface, not on where its particles sit or how they are joined. Quadric edge collapse and the
panel projection do not: QECD can only collapse the edges it is given, and the projection
replaces a rounded crease by a step between the particles on either side of a straight rest
line. On a grid the step runs between two rows of particles and its faces form a flat strip;
on a jittered, irregular mesh the particles next to the line lie at random distances from it
and the strip is a saw-tooth that a few faces cannot fit. An 80 x 80 sheet with a Delaunay
interior, a few slivers and shuffled vertices got 6 and 10 keys for the diagonal and the side
fold instead of 4 and 6 (the projection alone: the mesh without it got 6 and 8; with it, the
same sheet of a regular grid 4 and 6).

:func:`resample_on_grid` removes the dependence: a rectangular rest sheet (the supported goals
are rectangular cloths, whatever their triangulation) gets a regular grid of about as many
nodes as it has particles, along the sides of its smallest bounding rectangle, and every node
takes the goal position interpolated at its rest position. The reduction then runs on the grid,
where the pipeline holds its counts at any resolution and triangulation, and each key node is
given back as the particle nearest it on the rest sheet. A goal whose particles already are
the grid's nodes is left as it is (its own numbering and faces; the canonical triangulation
sets its diagonals). A sheet that is not a rectangle is not resampled (logged).
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from scipy.spatial import ConvexHull, cKDTree

from .validation import triangle_areas

logger = logging.getLogger(__name__)

#: a sheet is a rectangle when it covers its smallest bounding rectangle but for a band this
#: many grid spacings wide along the rectangle's perimeter (a boundary of particles that wander
#: off the straight side by less than that)
RECTANGLE_BAND = 0.25
#: particles within this many grid steps of every node already are the grid (the authors'
#: FleX grids, stored in float32, miss their nodes by 2e-5 steps)
ON_GRID = 1e-3
#: triangles searched per node (nearest centroids) before the search over all of them
NEAREST_TRIANGLES = 16


@dataclass(frozen=True)
class SheetGrid:
    """A goal resampled on the regular grid of its rest sheet.

    Attributes:
        goal: ``(M, 3)`` goal positions of the nodes.
        rest: ``(M, 3)`` rest positions of the nodes (on the rest sheet's plane).
        faces: ``(G, 3)`` grid triangles, node ``i * nv + j`` at the ``i``-th step along the
            rectangle's first side and the ``j``-th along the second; each square split along
            its ``(i, j) - (i + 1, j + 1)`` diagonal.
        shape: ``(nu, nv)`` nodes along the two sides.
        spacing: the grid step (both sides), in the units of the rest positions.
        error: what the resampling loses: the largest distance between a particle's goal
            position and the grid's, interpolated back at its rest position (a crease rounded
            over about a spacing is cut by chords of both meshes, up to about a layer gap).
    """

    goal: np.ndarray
    rest: np.ndarray
    faces: np.ndarray
    shape: tuple[int, int]
    spacing: float
    error: float


def sheet_rectangle(rest: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The smallest-area rectangle around the flat sheet ``rest`` ``(N, 3)`` (rotating
    calipers over its convex hull in the sheet's plane).

    Returns:
        ``(corner (3,), sides (2, 3), plane (2, 3))``: the rectangle's corner, its two side
        vectors (the longer first) in 3-D, and the orthonormal basis of the sheet's plane.
    """
    centre = rest.mean(axis=0)
    plane = np.linalg.svd(rest - centre, full_matrices=False)[2][:2]             # (2, 3)
    flat = (rest - centre) @ plane.T                                             # (N, 2)
    hull = flat[ConvexHull(flat).vertices]
    edge = np.roll(hull, -1, axis=0) - hull
    edge /= np.linalg.norm(edge, axis=1, keepdims=True)
    normal = np.c_[-edge[:, 1], edge[:, 0]]
    along, across = hull @ edge.T, hull @ normal.T                              # (H, E)
    area = np.ptp(along, axis=0) * np.ptp(across, axis=0)
    best = int(np.argmin(area))
    axes = np.stack([edge[best], normal[best]])                                  # (2, 2)
    low = np.array([along[:, best].min(), across[:, best].min()])
    length = np.array([np.ptp(along[:, best]), np.ptp(across[:, best])])
    if length[1] > length[0]:
        axes, low, length = axes[::-1], low[::-1], length[::-1]
    corner = centre + (low @ axes) @ plane
    sides = (length[:, None] * axes) @ plane
    return corner, sides, plane


def grid_step(long: float, short: float, count: int) -> float:
    """The step h of the grid of ``count`` nodes over a ``long x short`` rectangle:
    ``(long / h + 1) (short / h + 1) = count``, so that an ``n x m`` grid gives back its own
    step."""
    total, product = long + short, long * short
    return (total + np.sqrt(total ** 2 + 4.0 * (count - 1) * product)) / (2.0 * (count - 1))


def _grid(corner: np.ndarray, sides: np.ndarray, step: float):
    """Nodes ``(M, 3)``, faces ``(G, 3)`` and shape of the grid over the rectangle."""
    nu, nv = (max(int(round(np.linalg.norm(side) / step)) + 1, 2) for side in sides)
    iu, iv = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    nodes = corner + np.outer(iu.ravel() / (nu - 1), sides[0]) \
        + np.outer(iv.ravel() / (nv - 1), sides[1])
    a = (iu[:-1, :-1] * nv + iv[:-1, :-1]).ravel()
    b, c, d = a + nv, a + nv + 1, a + 1
    faces = np.concatenate([np.c_[a, b, c], np.c_[a, c, d]]).astype(np.int64)
    return nodes, faces, (nu, nv)


def _barycentric(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Barycentric coordinates ``(..., 3)`` of 2-D ``points`` ``(..., 2)`` in ``triangles``
    ``(..., 3, 2)``."""
    a, b, c = triangles[..., 0, :], triangles[..., 1, :], triangles[..., 2, :]
    u, v, w = b - a, c - a, points - a
    det = u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]
    second = (w[..., 0] * v[..., 1] - w[..., 1] * v[..., 0]) / det
    third = (u[..., 0] * w[..., 1] - u[..., 1] * w[..., 0]) / det
    return np.stack([1.0 - second - third, second, third], axis=-1)


def locate(points: np.ndarray, flat: np.ndarray, faces: np.ndarray,
           chunk: int = 256) -> tuple[np.ndarray, np.ndarray]:
    """The face of the flat mesh ``flat`` ``(N, 2)``, ``faces`` ``(F, 3)``, holding each 2-D
    point of ``points`` ``(P, 2)``, and the point's barycentric coordinates in it.

    A point outside every face (a node on a boundary that the particles miss by a rounding)
    takes the face it is least outside of (the largest least barycentric coordinate), and
    its coordinates extrapolate.

    Returns:
        ``(face (P,), weights (P, 3))``.
    """
    corners = flat[faces]                                                          # (F, 3, 2)
    k = min(NEAREST_TRIANGLES, len(faces))
    _, near = cKDTree(corners.mean(axis=1)).query(points, k)
    near = near.reshape(len(points), k)
    weights = _barycentric(points[:, None], corners[near])                       # (P, k, 3)
    pick = weights.min(axis=2).argmax(axis=1)
    rows = np.arange(len(points))
    face, best = near[rows, pick], weights[rows, pick]
    outside = np.flatnonzero(best.min(axis=1) < -1e-9)
    for start in range(0, len(outside), chunk):          # not in a near face: search them all
        some = outside[start:start + chunk]
        every = _barycentric(points[some, None], corners[None])                  # (c, F, 3)
        pick = every.min(axis=2).argmax(axis=1)
        face[some], best[some] = pick, every[np.arange(len(some)), pick]
    return face, best


def resample_on_grid(goal: np.ndarray, rest: np.ndarray, faces: np.ndarray) -> SheetGrid | None:
    """The goal ``(N, 3)`` over its flat rest sheet ``rest`` ``(N, 3)``, faces ``(F, 3)``,
    resampled on the regular grid of the sheet's smallest bounding rectangle with about N
    nodes (see the module docstring).

    Returns:
        The :class:`SheetGrid`; ``None`` when the sheet is not a rectangle (it misses more of
        the rectangle than a band of ``RECTANGLE_BAND`` grid steps along its perimeter) or
        its particles already are the grid's nodes.
    """
    corner, sides, plane = sheet_rectangle(rest)
    long, short = np.linalg.norm(sides, axis=1)
    step = grid_step(long, short, len(rest))
    missing = long * short - float(triangle_areas(rest, faces).sum())
    if missing > RECTANGLE_BAND * step * 2.0 * (long + short):
        logger.info("resample: the rest sheet is not a rectangle (%.3g of its bounding "
                    "rectangle uncovered); its mesh is reduced as given",
                    missing / (long * short))
        return None
    nodes, grid_faces, shape = _grid(corner, sides, step)
    if len(nodes) == len(rest):
        distance, _ = cKDTree(rest).query(nodes)
        if distance.max() <= ON_GRID * step:
            return None
    flat = rest @ plane.T
    face, weights = locate(nodes @ plane.T, flat, faces)
    values = np.einsum("pk,pkd->pd", weights, goal[faces[face]])
    face, weights = locate(flat, nodes @ plane.T, grid_faces)                  # and back
    back = np.einsum("pk,pkd->pd", weights, values[grid_faces[face]])
    error = float(np.linalg.norm(back - goal, axis=1).max())
    logger.info("resample: %d particles, %d faces -> a %d x %d grid (round trip %.3g steps)",
                len(rest), len(faces), *shape, error / step)
    return SheetGrid(values, nodes, grid_faces, shape, step, error)


def nearest_particles(points: np.ndarray, rest: np.ndarray) -> np.ndarray:
    """The particle of the rest sheet ``rest`` ``(N, 3)`` nearest each rest position of
    ``points`` ``(K, 3)`` (grid nodes), sorted and unique ``(K',)``."""
    return np.unique(cKDTree(rest).query(points)[1]).astype(np.int64)
