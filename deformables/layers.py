"""The stacking axis and the layer gap of a folded cloth goal, estimated from the goal itself.

Shape letters: N particles, F faces, P candidate particle pairs.

A folded sheet lies in flat layers stacked along one axis (z for a cloth on a table, whatever
its rotation about z or its translation). The cloth reduction measures its error in a space
stretched along that axis and sets its threshold in layer gaps, so both are taken from the
goal rather than from the generator that made it (``deformables.goals`` stacks its layers
5 mm apart; a simulated or perceived cloth, or another generator, keeps another distance):

* :func:`stacking_axis`: the direction most of the goal's area faces: the normal of its
  layers.
* :func:`estimate_layer_gap`: among the particles of flat parts (every face of theirs within
  ``max_tilt_deg`` of the layers' plane: not on a crease), for every particle the other layers
  are the particles the mesh does not join to it by an edge that lie within ``reach``
  particle spacings of its line along the axis; its distance to the nearest one, measured
  along the axis, is its gap. The estimate is the median over the particles that have a layer
  above or below them. It does not depend on the numbering, the triangulation, the rigid
  placement or the shape of the creases, and, as a median of many distances, little on noise
  (Gaussian noise biases it low, by up to about a sigma: the nearest of a few noisy
  neighbours is taken).
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix, identity
from scipy.spatial import cKDTree

from dopt.validation import check_int, check_real

from .mesh import edges
from .validation import check_faces, check_positions

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class LayerGap:
    """Outcome of :func:`estimate_layer_gap`.

    Attributes:
        gap: the estimated distance between stacked layers along ``axis``, metres; ``nan`` when
            no particle has a layer above or below it (a single-layer goal).
        axis: ``(3,)`` unit stacking axis.
        stacked: the number of particles with a layer above or below them.
    """

    gap: float
    axis: np.ndarray
    stacked: int

    @property
    def found(self) -> bool:
        """Whether the goal has stacked layers (and ``gap`` is a number)."""
        return bool(np.isfinite(self.gap))


def stacking_axis(positions: np.ndarray, faces: np.ndarray, flat_deg: float = 20.0,
                  rounds: int = 10) -> np.ndarray:
    """Unit vector ``(3,)`` most of the sheet's area is perpendicular to: the top eigenvector of
    ``sum_f area_f n_f n_f^T`` over the unit face normals ``n_f`` of ``faces`` ``(F, 3)`` on
    ``positions`` ``(N, 3)`` (either orientation of a face counts alike: a folded-over layer
    faces down), its largest component made positive (z up for a cloth on a table).

    It is refitted, up to ``rounds`` times, on the flat faces only, so that the faces of
    creases do not tilt it: first those within ``flat_deg`` of perpendicular to it, then those
    within three times the median angle of the faces kept before (noise spreads the normals of
    flat faces by a few degrees; on an exact fold the median is 0 and the axis exact). The
    direction of least extent would do for a wide stack, but a narrow one (a 5-spacing-wide,
    4-layer underneath fold) is about as thick as it is wide."""
    a, b, c = (positions[faces[:, k]] for k in range(3))
    normal = np.cross(b - a, c - a)                         # length: twice the area
    length = np.linalg.norm(normal, axis=1)
    unit = normal / np.where(length > 0, length, 1.0)[:, None]
    kept = length > 0

    def top(mask: np.ndarray) -> np.ndarray:
        return np.linalg.eigh(np.einsum("f,fi,fj->ij", np.where(mask, length, 0.0), unit,
                                        unit))[1][:, -1]

    axis = top(kept)
    for round_ in range(rounds):
        angle = np.arccos(np.clip(np.abs(unit @ axis), 0.0, 1.0))
        cut = (np.radians(flat_deg) if round_ == 0
               else max(3.0 * float(np.median(angle[kept])), 1e-6))
        flat = (angle <= cut) & (length > 0)
        if not flat.any():
            break
        previous, axis, kept = axis, top(flat), flat
        if round_ and abs(previous @ axis) > 1.0 - 1e-15:
            break
    return axis if axis[np.argmax(np.abs(axis))] > 0 else -axis


def _within_rings(pairs: np.ndarray, n: int, rings: int):
    """Sparse boolean ``(N, N)`` matrix: particles joined by at most ``rings`` mesh edges."""
    adjacency = coo_matrix((np.ones(2 * len(pairs), dtype=bool),
                            (np.r_[pairs[:, 0], pairs[:, 1]], np.r_[pairs[:, 1], pairs[:, 0]])),
                           shape=(n, n)).tocsr()
    step = (adjacency + identity(n, dtype=bool, format="csr")).astype(bool)
    reach = step
    for _ in range(rings - 1):
        reach = (reach @ step).astype(bool)
    return reach


def flat_particles(positions: np.ndarray, faces: np.ndarray, axis: np.ndarray,
                   max_tilt_deg: float) -> np.ndarray:
    """``(N,)`` bool: particles all of whose faces ``(F, 3)`` are within ``max_tilt_deg`` of
    perpendicular to ``axis`` (either orientation: a folded-over layer faces down)."""
    a, b, c = (positions[faces[:, k]] for k in range(3))
    normal = np.cross(b - a, c - a)
    length = np.linalg.norm(normal, axis=1)
    cos = np.abs(normal @ axis) / np.where(length > 0, length, 1.0)
    tilted = faces[(cos < np.cos(np.radians(max_tilt_deg))) | (length <= 0)].ravel()
    flat = np.ones(len(positions), dtype=bool)
    flat[tilted] = False
    return flat


def estimate_layer_gap(positions, faces, spacing: float, axis: np.ndarray | None = None,
                       rings: int = 1, max_gap: float = 4.0, reach: float = 1.0,
                       max_tilt_deg: float = 30.0, min_stacked: float = 0.02) -> LayerGap:
    """The distance between the stacked layers of a folded cloth goal (see the module doc).

    Args:
        positions: ``(N, 3)`` goal positions, metres.
        faces: ``(F, 3)`` triangles of the cloth mesh.
        spacing: the particle spacing (median rest edge length), metres.
        axis: ``(3,)`` stacking axis; ``None`` uses :func:`stacking_axis`.
        rings: particles joined by at most this many mesh edges are on the same layer (a
            fold puts the layer above a particle at least about two rows away along the
            sheet, more the farther from the crease).
        max_gap: largest gap looked for, in particle spacings.
        reach: largest offset across the axis between a particle and the particle of another
            layer it is compared with, in spacings (the grid of another layer may be shifted
            by up to ``sqrt(2) / 2`` spacings).
        max_tilt_deg: only particles whose faces all lie within this angle of the layers'
            plane take part (:func:`flat_particles`): a rounded crease's particles lie between
            two layers and would shorten the gap.
        min_stacked: fewer stacked particles than this fraction of N (and than 8) mean a
            single-layer goal.

    Returns:
        :class:`LayerGap` (``gap`` is ``nan`` when no layers are stacked).

    Raises:
        TypeError / ValueError: bad positions or faces, or an option out of range (named).
    """
    goal = check_positions(positions)
    tri = check_faces(faces, len(goal))
    check_real(spacing, "spacing", positive=True)
    check_int(rings, "rings", 1)
    check_real(max_gap, "max_gap", positive=True)
    check_real(reach, "reach", positive=True)
    check_real(max_tilt_deg, "max_tilt_deg", positive=True, maximum=90.0)
    check_real(min_stacked, "min_stacked", minimum=0.0, maximum=1.0)
    if axis is None:
        axis = stacking_axis(goal, tri)
    else:
        axis = np.asarray(axis, dtype=float)
        if axis.shape != (3,) or not np.all(np.isfinite(axis)) or not np.linalg.norm(axis) > 0:
            raise ValueError(f"axis must be a finite non-zero (3,) vector, got {axis!r}")
        axis = axis / np.linalg.norm(axis)
    n = len(goal)
    flat = np.flatnonzero(flat_particles(goal, tri, axis, max_tilt_deg))
    # neighbours across the axis: a search in the plane perpendicular to it
    basis = np.linalg.svd(axis[None])[2][1:]                                     # (2, 3)
    pairs = flat[cKDTree(goal[flat] @ basis.T).query_pairs(reach * spacing,
                                                           output_type="ndarray")]
    gaps = np.full(n, np.inf)
    if len(pairs):
        along = np.abs((goal[pairs[:, 1]] - goal[pairs[:, 0]]) @ axis)
        keep = along <= max_gap * spacing
        pairs, along = pairs[keep], along[keep]
        near = _within_rings(edges(tri), n, rings)
        same_sheet = np.asarray(near[pairs[:, 0], pairs[:, 1]]).ravel()
        pairs, along = pairs[~same_sheet], along[~same_sheet]
        np.minimum.at(gaps, pairs[:, 0], along)
        np.minimum.at(gaps, pairs[:, 1], along)
    stacked = np.isfinite(gaps)
    count = int(stacked.sum())
    if count < max(8, min_stacked * n):
        logger.info("layer gap: %d of %d particles have a layer above or below them; no "
                    "stacked layers", count, n)
        return LayerGap(float("nan"), axis, count)
    gap = float(np.median(gaps[stacked]))
    logger.info("layer gap: %.3g spacings over %d of %d stacked particles", gap / spacing,
                count, n)
    return LayerGap(gap, axis, count)
