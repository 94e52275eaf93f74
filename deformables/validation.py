"""Input checks shared by the rope and cloth reductions.

Every check raises ``ValueError`` with a message that names the problem; repairable defects
(duplicate faces) are repaired and logged as warnings. Shape letters: N particles, F faces.
"""
from __future__ import annotations

import logging

import numpy as np

logger = logging.getLogger(__name__)


def check_positions(positions, name: str = "positions", min_count: int = 3) -> np.ndarray:
    """Return ``positions`` as a float ``(N, 3)`` array after checking it.

    Raises:
        ValueError: wrong shape, fewer than ``min_count`` particles, NaN/inf entries, or all
            particles at one point (zero extent).
    """
    arr = np.asarray(positions, dtype=float)
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
    """Return ``threshold`` as a float after checking it is finite and positive."""
    value = float(threshold)
    if not np.isfinite(value) or value <= 0.0:
        raise ValueError(f"{name} must be a positive finite number, got {threshold}")
    return value


def triangle_areas(positions: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Areas ``(F,)`` of the triangles ``faces`` ``(F, 3)`` over ``positions`` ``(N, 3)``."""
    a, b, c = (positions[faces[:, k]] for k in range(3))
    return 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)


def check_faces(faces, n_particles: int, area_positions: np.ndarray) -> np.ndarray:
    """Return valid ``(F', 3)`` int64 faces: duplicates removed (logged), everything else checked.

    Args:
        faces: ``(F, 3)`` vertex indices.
        n_particles: N, the number of particles the faces index.
        area_positions: ``(N, 3)`` positions on which zero-area faces are detected (the rest
            shape when there is one: a face that is degenerate there is broken, not folded).

    Raises:
        ValueError: wrong shape or dtype, no faces, indices out of range, or zero-area faces.
    """
    arr = np.asarray(faces)
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
    _, first = np.unique(np.sort(arr, axis=1), axis=0, return_index=True)
    if len(first) < len(arr):
        logger.warning("removed %d duplicate faces (same three vertices) of %d",
                       len(arr) - len(first), len(arr))
        arr = arr[np.sort(first)]
    extent = float(np.ptp(area_positions, axis=0).max())
    zero = triangle_areas(area_positions, arr) <= 1e-12 * extent ** 2
    if zero.any():
        row = int(np.flatnonzero(zero)[0])
        raise ValueError(f"{int(zero.sum())} faces have zero area (first: face {row} = "
                         f"{arr[row].tolist()}); remove degenerate triangles")
    return arr
