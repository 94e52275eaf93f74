"""Triangle-mesh helpers: edges, and a canonical triangulation of a folded sheet.

Shape letters: N vertices, F faces, E edges.

A regular grid can be split into triangles in many ways (MuJoCo's flexcomp uses one diagonal,
other tools the other, or alternate them). Each grid square is a rest quad whose four corners
lie on a circle, so both of its diagonals give a Delaunay triangulation of the rest sheet: the
choice is arbitrary there, but once the sheet is folded it decides whether the triangles follow
a crease or cut across it in a saw-tooth. :func:`canonical_triangulation` removes the
arbitrariness: for every such rest-cocircular pair of triangles it keeps the diagonal whose
length the fold changes least, by ``|log(goal / rest)|`` (an isometric fold keeps the lines
along a crease at full length and shortens the chords across it; a sharp crease that lifts the
top layer by the gap stretches the chord from the crease row to the layer above, which "least
compressed" would choose: a 21 x 21 sheet so folded along its diagonal under MuJoCo's
triangulation gave 28 faces and 10 keys instead of 4 and 4). Triangles of irregular meshes,
whose rest quads are not cocircular, are left as they are.
"""
from __future__ import annotations

import logging

import numpy as np

logger = logging.getLogger(__name__)

#: two rest angles opposite an edge summing to pi within this tolerance (radians) mean
#: "cocircular": either diagonal of that quad fits the rest sheet. Loose enough for rest
#: positions stored in float32: the squares of the key-particle authors' FleX sheet (90 x 90,
#: 6.25 mm spacing) deviate by up to 1.1e-5 (median 1.1e-6), and a 2 m sheet at 2 mm spacing
#: would by about 2.4e-4 (float32's step over the spacing); 1e-6 left half of the authors'
#: squares unflipped, and the canonical triangulation then depended on the input's.
_COCIRCULAR_TOL = 1e-3


def unique_rows(rows: np.ndarray, return_index: bool = False):
    """``np.unique(rows, axis=0)`` (and the index of each row's first occurrence) for
    non-negative integer rows ``(R, C)``, through one integer key per row: the same sorted rows
    ``(U, C)``, without sorting rows as records.

    Returns:
        ``(U, C)`` rows, or ``((U, C), (U,))`` with ``return_index``.
    """
    rows = np.asarray(rows)
    base = int(rows.max()) + 1 if rows.size else 1
    if rows.ndim != 2 or not np.issubdtype(rows.dtype, np.integer) or rows.size == 0 \
            or rows.min() < 0 or base ** rows.shape[1] >= 2 ** 62:
        return np.unique(rows, axis=0, return_index=return_index)
    key = rows[:, 0].astype(np.int64)
    for column in range(1, rows.shape[1]):
        key = key * base + rows[:, column]
    _, first = np.unique(key, return_index=True)
    return (rows[first], first) if return_index else rows[first]


def edges(faces: np.ndarray) -> np.ndarray:
    """Unique undirected edges ``(E, 2)`` (sorted pairs) of ``faces`` ``(F, 3)``."""
    return unique_rows(np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1))


def _angle(at: np.ndarray, p: np.ndarray, q: np.ndarray) -> np.ndarray:
    u, v = p - at, q - at
    cos = np.einsum("ij,ij->i", u, v) / (np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1))
    return np.arccos(np.clip(cos, -1.0, 1.0))


def canonical_triangulation(goal: np.ndarray, faces: np.ndarray, rest: np.ndarray,
                            max_passes: int = 10) -> np.ndarray:
    """Faces ``(F, 3)`` with every rest-cocircular diagonal set to the one whose length the
    fold changes least.

    Args:
        goal: ``(N, 3)`` goal positions.
        faces: ``(F, 3)`` consistently oriented triangles.
        rest: ``(N, 3)`` rest positions.
        max_passes: flip passes at most (a pass flips each face at most once; on a grid one
            pass settles every square).
    """
    faces = np.array(faces, dtype=np.int64, copy=True)
    total = 0
    for _ in range(max_passes):
        flips = _flip_pass(goal, faces, rest)
        total += flips
        if flips == 0:
            break
    if total:
        logger.debug("canonical triangulation: flipped %d diagonals", total)
    return faces


def _flip_pass(goal: np.ndarray, faces: np.ndarray, rest: np.ndarray) -> int:
    """One pass of :func:`canonical_triangulation`, flipping ``faces`` in place; returns the
    number of flips."""
    # half-edges (a -> b) with the opposite vertex c, for every face (a, b, c)
    a = faces.reshape(-1)
    b = faces[:, [1, 2, 0]].reshape(-1)
    c = faces[:, [2, 0, 1]].reshape(-1)
    owner = np.repeat(np.arange(len(faces)), 3)
    key = np.minimum(a, b) * len(goal) + np.maximum(a, b)
    order = np.argsort(key, kind="stable")
    same = key[order][1:] == key[order][:-1]
    first, second = order[:-1][same], order[1:][same]        # the two half-edges of an edge
    ok = (a[first] == b[second]) & (b[first] == a[second])    # consistently oriented pair
    first, second = first[ok], second[ok]
    ea, eb, ec, ed = a[first], b[first], c[first], c[second]
    cocircular = np.abs(_angle(rest[ec], rest[ea], rest[eb]) + _angle(rest[ed], rest[ea], rest[eb])
                        - np.pi) < _COCIRCULAR_TOL
    # how far each diagonal's goal length is from its rest length, as |log(goal / rest)|
    change_now = np.abs(np.log(np.linalg.norm(goal[ea] - goal[eb], axis=1)
                               / np.linalg.norm(rest[ea] - rest[eb], axis=1)))
    change_flip = np.abs(np.log(np.linalg.norm(goal[ec] - goal[ed], axis=1)
                                / np.linalg.norm(rest[ec] - rest[ed], axis=1)))
    candidates = np.flatnonzero(cocircular & (change_flip < change_now - 1e-9))
    touched = np.zeros(len(faces), dtype=bool)
    flips = 0
    for i in candidates[np.argsort(change_flip[candidates] - change_now[candidates])]:
        f, g = owner[first[i]], owner[second[i]]
        if touched[f] or touched[g]:
            continue
        # (a, b, c) + (b, a, d) -> (c, d, b) + (d, c, a): same orientation, diagonal c-d
        faces[f] = (ec[i], ed[i], eb[i])
        faces[g] = (ed[i], ec[i], ea[i])
        touched[f] = touched[g] = True
        flips += 1
    return flips
