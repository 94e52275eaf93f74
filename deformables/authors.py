"""The key-particle paper's authors' own cloth goals: their SoftGym / FleX files (repository
shengyin-git/ac_softagent; a copy lives outside the project, in ``../shared/external/ac_softagent``,
described in that folder's README). Loading them for :func:`deformables.cloth.cloth_key_particles`
and comparing keys with the authors'.

Per fold, ``particle_pos_ini.npy`` (the flat sheet) and ``particle_pos_final.npy`` (the goal)
are ``(n * n, 3)`` float32 positions of an ``n x n`` grid in row-major order (y up, 6.25 mm
spacing, the sheet rotated in its plane), and ``key_point_index.npy`` the particles nearest the
vertices of the authors' simplified mesh before their own 0.05 m filter.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

#: task: (the authors' folder, particles per side, triangles of the paper's simplified mesh)
AUTHORS_CLOTH = {"cloth_diagonal": ("cloth_diagonal_folding", 90, 4),
                 "cloth_side": ("cloth_side_folding", 100, 6)}
#: the authors' filter radius between key points, metres
AUTHORS_FILTER_M = 0.05


@dataclass(frozen=True)
class AuthorsCloth:
    """One of the authors' cloth goals: ``rest`` and ``goal`` ``(n * n, 3)`` float32 (as
    stored), ``keys`` ``(K,)`` their key particles, ``n`` particles per side and
    ``paper_faces`` the triangle count the paper reports for it."""

    task: str
    rest: np.ndarray
    goal: np.ndarray
    keys: np.ndarray
    n: int
    paper_faces: int


def load_authors_cloth(external: Path | str, task: str) -> AuthorsCloth:
    """The authors' goal of ``task`` (a key of ``AUTHORS_CLOTH``) from ``external``, the
    ``ac_softagent`` folder.

    Raises:
        ValueError: an unknown task, a missing folder or file, or arrays of the wrong shape.
    """
    if task not in AUTHORS_CLOTH:
        raise ValueError(f"no authors' goal for {task!r}; choose from {sorted(AUTHORS_CLOTH)}")
    folder, n, faces = AUTHORS_CLOTH[task]
    where = Path(external) / folder
    arrays = {}
    for name in ("particle_pos_ini", "particle_pos_final", "key_point_index"):
        path = where / f"{name}.npy"
        if not path.is_file():
            raise ValueError(f"the authors' file {path} is missing (the ac_softagent folder of "
                             f"../shared/external, see its README)")
        arrays[name] = np.load(path)
    rest, goal, keys = (arrays[k] for k in ("particle_pos_ini", "particle_pos_final",
                                            "key_point_index"))
    if rest.shape != (n * n, 3) or goal.shape != (n * n, 3):
        raise ValueError(f"{where}: positions of shape {rest.shape} and {goal.shape}, expected "
                         f"({n * n}, 3) each (an {n} x {n} grid)")
    if keys.ndim != 1 or not np.issubdtype(keys.dtype, np.integer) or \
            not ((0 <= keys) & (keys < n * n)).all():
        raise ValueError(f"{where}: key_point_index must be particle indices below {n * n}")
    return AuthorsCloth(task, rest, goal, keys, n, faces)


def keys_agree(rest: np.ndarray, ours: np.ndarray, theirs: np.ndarray,
               radius: float = AUTHORS_FILTER_M) -> bool:
    """Whether each of ``ours`` (particle indices) lies within ``radius`` of one of ``theirs``
    and each of theirs within ``radius`` of one of ours, measured on the flat sheet ``rest``
    ``(N, 3)`` (distances there are geodesic)."""
    a, b = np.asarray(rest, dtype=float)[ours], np.asarray(rest, dtype=float)[theirs]
    gaps = np.linalg.norm(a[:, None] - b[None], axis=2)
    return bool((gaps.min(axis=1) <= radius).all() and (gaps.min(axis=0) <= radius).all())
