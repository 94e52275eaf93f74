"""Input checks shared by the rope and cloth reductions.

Every check raises ``TypeError`` (wrong type or dtype) or ``ValueError`` (wrong value or
shape) with a message that names the argument and the problem; repairable defects (duplicate
faces) are repaired and logged as warnings, and defects the algorithms survive (non-manifold
edges and vertices) are logged as warnings. Shape letters: N particles, F faces, E edges.

The scalar checks are ``dopt.validation``'s (pure Python and numpy: the one module of ``dopt``
that ``deformables`` imports; it loads neither MuJoCo nor torch).
"""
from __future__ import annotations

import logging

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from dopt.validation import is_real

from .mesh import edges, unique_rows

logger = logging.getLogger(__name__)

#: a rest mesh whose median goal/rest edge length ratio lies outside this range is not the
#: rest shape of the goal: a fold keeps edges at their rest length (crease chords shorten to
#: no less than 2/pi of it), noise changes them by a fraction of a spacing
REST_RATIO_RANGE = (0.5, 2.0)
#: goal edges longer than this multiple of their rest length cannot come from folding cloth
#: (a fold never stretches an edge; 2 mm of Gaussian goal noise on a 40 x 40 sheet of 0.3 m
#: stretches the worst of its edges 2.7 times, 3 would take 15 mm)
STRETCH_LIMIT = 3.0


# ----------------------------------------------------------------------------- arrays
def check_numeric(x, name: str) -> np.ndarray:
    """``x`` as a numeric array; bool, string and object arrays raise TypeError."""
    if x is None:
        raise TypeError(f"{name} must be an array, got None")
    try:
        arr = np.asarray(x)
    except (TypeError, ValueError) as e:               # ragged nesting
        raise ValueError(f"{name} is not a rectangular array: {e}") from None
    if arr.dtype.kind not in "fiu":
        raise TypeError(f"{name} must be a numeric array, got dtype {arr.dtype}")
    return arr


def check_positions(positions, name: str = "positions", min_count: int = 3) -> np.ndarray:
    """Return ``positions`` as a float ``(N, 3)`` array after checking it.

    Raises:
        TypeError: not numeric (bool, strings, None).
        ValueError: wrong shape, fewer than ``min_count`` particles, NaN/inf entries, or all
            particles at one point (zero extent).
    """
    arr = np.asarray(check_numeric(positions, name), dtype=float)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"{name} must have shape (N, 3), got {arr.shape}")
    if arr.shape[0] < min_count:
        raise ValueError(f"{name} needs at least {min_count} particles, got {arr.shape[0]}")
    bad = ~np.all(np.isfinite(arr), axis=1)
    if bad.any():
        raise ValueError(f"{name} has {int(bad.sum())} particles with NaN or inf coordinates "
                         f"(first: index {int(np.flatnonzero(bad)[0])})")
    if float(np.ptp(arr, axis=0).max()) <= 0.0:
        raise ValueError(f"{name} has zero extent: all {arr.shape[0]} particles coincide")
    return arr


def check_threshold(threshold: float, name: str = "threshold") -> float:
    """Return ``threshold`` as a float after checking it is a finite positive number (not a
    bool, a string or an array: TypeError)."""
    if not is_real(threshold):
        raise TypeError(f"{name} must be a number, got {threshold!r}")
    value = float(threshold)
    if not np.isfinite(value) or value <= 0.0:
        raise ValueError(f"{name} must be a positive finite number, got {threshold}")
    return value


def triangle_areas(positions: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Areas ``(F,)`` of the triangles ``faces`` ``(F, 3)`` over ``positions`` ``(N, 3)``."""
    a, b, c = (positions[faces[:, k]] for k in range(3))
    return 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)


def check_faces(faces, n_particles: int, area_positions: np.ndarray | None = None,
                *, require_all: bool = False) -> np.ndarray:
    """Return valid ``(F', 3)`` int64 faces: duplicates removed (logged), everything else checked.

    Args:
        faces: ``(F, 3)`` vertex indices.
        n_particles: N, the number of particles the faces index.
        area_positions: ``(N, 3)`` positions on which zero-area faces are detected (the rest
            shape when there is one: a face that is degenerate there is broken, not folded);
            None skips that check (:func:`check_areas` does it).
        require_all: every particle must belong to a face.

    Raises:
        TypeError: bool, string or None faces.
        ValueError: wrong shape, non-integer values, no faces, indices out of range, a face
            that repeats a vertex, particles in no face (``require_all``), or zero-area faces.
    """
    arr = check_numeric(faces, "faces")
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"faces must have shape (F, 3), got {arr.shape}")
    if arr.shape[0] == 0:
        raise ValueError("faces is empty: a cloth needs at least one triangle")
    if not np.issubdtype(arr.dtype, np.integer):
        if not np.all(np.isfinite(arr)) or np.any(arr != np.round(arr)):
            raise ValueError("faces must hold integer vertex indices")
    arr = arr.astype(np.int64)
    out_of_range = (arr < 0) | (arr >= n_particles)
    if out_of_range.any():
        row = int(np.flatnonzero(out_of_range.any(axis=1))[0])
        raise ValueError(f"faces index particles out of range [0, {n_particles}): "
                         f"{int(out_of_range.any(axis=1).sum())} faces, first face {row} = "
                         f"{arr[row].tolist()}")
    ordered = np.sort(arr, axis=1)
    repeated = (ordered[:, 0] == ordered[:, 1]) | (ordered[:, 1] == ordered[:, 2])
    if repeated.any():
        row = int(np.flatnonzero(repeated)[0])
        raise ValueError(f"{int(repeated.sum())} faces have zero area: they repeat a vertex "
                         f"(first: face {row} = {arr[row].tolist()}); remove degenerate "
                         f"triangles")
    _, first = unique_rows(ordered, return_index=True)
    if len(first) < len(arr):
        logger.warning("removed %d duplicate faces (same three vertices) of %d",
                       len(arr) - len(first), len(arr))
        arr = arr[np.sort(first)]
    if require_all:
        unused = np.setdiff1d(np.arange(n_particles), arr)
        if len(unused):
            raise ValueError(f"{len(unused)} of {n_particles} particles belong to no face "
                             f"(first: particle {int(unused[0])}); every particle of a cloth "
                             f"must be a vertex of its mesh")
    if area_positions is not None:
        check_areas(arr, area_positions)
    return arr


def check_areas(faces: np.ndarray, positions: np.ndarray) -> None:
    """ValueError if a face of ``faces`` ``(F, 3)`` has zero area on ``positions`` ``(N, 3)``."""
    extent = float(np.ptp(positions, axis=0).max())
    zero = triangle_areas(positions, faces) <= 1e-12 * extent ** 2
    if zero.any():
        row = int(np.flatnonzero(zero)[0])
        raise ValueError(f"{int(zero.sum())} faces have zero area (first: face {row} = "
                         f"{faces[row].tolist()}); remove degenerate triangles")


def non_manifold(faces: np.ndarray, n_particles: int) -> tuple[np.ndarray, np.ndarray]:
    """Non-manifold parts of a triangle mesh ``(F, 3)``: edges ``(E', 2)`` shared by more than
    two faces, and vertices ``(V',)`` whose faces form more than one fan (two sheets touching
    at a vertex, a "bowtie")."""
    f = len(faces)
    corner_vertex = faces.reshape(-1)                                        # (3F,)
    a = faces.reshape(-1)
    b = faces[:, [1, 2, 0]].reshape(-1)
    owner = np.repeat(np.arange(f), 3)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    key = lo.astype(np.int64) * n_particles + hi
    order = np.argsort(key, kind="stable")
    keys, start, counts = np.unique(key[order], return_index=True, return_counts=True)
    heavy = keys[counts > 2]
    edges = np.stack([heavy // n_particles, heavy % n_particles], axis=1)
    # corners (face, vertex) of one vertex are joined when their faces share an edge at it
    same = key[order][1:] == key[order][:-1]
    e1, e2 = order[:-1][same], order[1:][same]                               # half-edge pairs
    f1, f2 = owner[e1], owner[e2]
    rows, cols = [], []
    for v in (lo, hi):                                                       # both endpoints
        c1 = 3 * f1 + np.argmax(faces[f1] == v[e1][:, None], axis=1)
        c2 = 3 * f2 + np.argmax(faces[f2] == v[e1][:, None], axis=1)
        rows.append(c1)
        cols.append(c2)
    rows, cols = np.concatenate(rows), np.concatenate(cols)
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(3 * f, 3 * f))
    _, component = connected_components(graph, directed=False)
    fans = unique_rows(np.stack([corner_vertex, component], axis=1))
    vertices, n_fans = np.unique(fans[:, 0], return_counts=True)
    return edges, vertices[n_fans > 1]


def warn_non_manifold(faces: np.ndarray, n_particles: int) -> None:
    """Log a warning naming how many edges and vertices of ``faces`` are non-manifold (the
    reduction runs on such meshes, but a cloth sheet has none: a fin or two sheets touching at
    a vertex is likely a broken triangulation, and each adds key particles)."""
    edges, vertices = non_manifold(faces, n_particles)
    if len(edges) or len(vertices):
        logger.warning("the cloth mesh is non-manifold: %d edges shared by more than two faces "
                       "(first: %s), %d vertices where separate sheets meet (first: %s); a "
                       "cloth is one sheet, check the faces",
                       len(edges), edges[0].tolist() if len(edges) else None,
                       len(vertices), int(vertices[0]) if len(vertices) else None)


def check_rest_matches(goal: np.ndarray, rest: np.ndarray, faces: np.ndarray) -> None:
    """ValueError if ``rest`` ``(N, 3)`` cannot be the rest shape of ``goal`` ``(N, 3)`` on the
    mesh ``faces`` ``(F, 3)``: folding keeps edge lengths (crease chords shorten to no less than
    2/pi), so a median goal/rest edge ratio outside ``REST_RATIO_RANGE`` means the rest
    positions are of another sheet, in another order or another unit. Goal edges stretched
    beyond ``STRETCH_LIMIT`` times their rest length are logged as a warning."""
    pairs = edges(faces)
    rest_len = np.linalg.norm(rest[pairs[:, 0]] - rest[pairs[:, 1]], axis=1)
    goal_len = np.linalg.norm(goal[pairs[:, 0]] - goal[pairs[:, 1]], axis=1)
    if np.any(rest_len <= 0):
        e = pairs[int(np.flatnonzero(rest_len <= 0)[0])]
        raise ValueError(f"rest_positions puts the two particles of edge {e.tolist()} at one "
                         f"point; the rest shape of a cloth has no zero-length edge")
    ratio = goal_len / rest_len
    median = float(np.median(ratio))
    if not REST_RATIO_RANGE[0] <= median <= REST_RATIO_RANGE[1]:
        raise ValueError(f"rest_positions do not match positions: the goal's edges are "
                         f"{median:.3g} times their rest length (median over {len(pairs)} "
                         f"edges; a fold keeps them at about 1). Are the rest positions of "
                         f"another sheet, in another particle order or another unit?")
    stretched = ratio > STRETCH_LIMIT
    if stretched.any():
        e = pairs[int(np.argmax(ratio))]
        logger.warning("%d of %d goal edges are more than %g times their rest length (most: "
                       "edge %s, %.3g times); a fold cannot stretch cloth, check the goal and "
                       "rest_positions", int(stretched.sum()), len(pairs), STRETCH_LIMIT,
                       e.tolist(), float(ratio.max()))
