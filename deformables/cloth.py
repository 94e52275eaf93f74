"""Cloth branch of Alg. 1: mesh decimation (the paper's Sec. III-C) and key particles.

Shape letters: N particles, F faces of the goal mesh, M vertices and NS faces of the simplified
mesh, K key particles.

* Simplify: quadric edge-collapse decimation of the goal mesh to NS faces
  (:mod:`deformables.decimation`, pymeshlab by default), restarted under a few numberings of
  the mesh (QECD breaks its many ties by numbering); the first model under the threshold wins.
* Error: the symmetric Hausdorff distance between simplified and goal mesh. The paper's
  one-sided distance (simplified -> goal, Eq. 4) is blind to missing parts: two triangles lying
  inside a side-folded sheet are close to it everywhere although they cover half of it. The
  other side (goal particles -> simplified surface) sees them.
* Both run in a space whose z axis is stretched by ``z_scale``: stacked layers a few mm apart
  then differ by far more than the rounding of a crease, so the error separates "a layer is
  missing" from "a crease is drawn as a chord".
* Extract: the goal particle nearest each simplified vertex (in the stretched space), then a
  greedy filter by geodesic distance on the flat rest sheet: a candidate is dropped if a kept
  one lies within ``geodesic_radius``. Both corners of a fold (close in space, far along the
  cloth) survive; near-duplicates along a crease collapse.
"""
from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra
from scipy.spatial import cKDTree

from dopt.validation import check_config

from .decimation import BACKENDS, EmptyDecimationError, decimate
from .distance import SurfaceDistance, hausdorff
from .goals import CLOTH_LAYER_GAP
from .mesh import canonical_triangulation, edges
from .panels import project_on_panels
from .reduction import KeyParticles, grow_until_below
from .validation import (
    check_areas,
    check_faces,
    check_positions,
    check_rest_matches,
    check_threshold,
    warn_non_manifold,
)

logger = logging.getLogger(__name__)

PANEL_MODES = ("auto", "on", "off")


@dataclass(frozen=True)
class ClothConfig:
    """Options of the cloth reduction.

    Attributes:
        backend: decimation back-end, ``"pymeshlab"`` or ``"trimesh"``.
        z_scale: stretch of the z axis for decimation and error.
        layer_gap: the distance the cloth keeps between stacked layers (its thickness, about
            a particle radius), metres; sets the default threshold.
        threshold_gaps: the default threshold as a multiple of ``layer_gap * z_scale`` (the
            error is measured in the stretched space). A model that misses a layer is off by
            at least ``layer_gap * z_scale``; one that draws a crease joining two layers as a
            single edge by just under half of it; one with every layer and crease only by
            in-plane errors, which do not shrink with the particle spacing. Over the 112
            noise-free goals of the resolution sweep in ``experiments/key_particles.py``
            (``exact_errors=True``), accepted models are at most 11.8 mm off and the model one
            size smaller at least 23.0 mm; 0.35 gaps (17.5 mm) sits between at every resolution.
        geodesic_radius: key particles closer than this fraction of the rest sheet's extent
            (largest side of its bounding box), along the sheet, are merged: the vertices of
            both layers at a crease end become one key, the ends of creases a quarter of the
            side apart stay two.
        geodesic_spacings: ... or this many particle spacings if that is more: the two layers'
            vertices at a crease end lie about a spacing apart on the rest sheet, more than
            0.1 of the extent below 11 per side (8 x 8 side fold: 8 keys without it, 6 with) ...
        geodesic_cap: ... but never more than this fraction of the extent: at 12 per side
            crease ends a quarter apart are under 3 spacings apart and must stay two keys.
        sample_spacings: sampling step on the simplified surface, in particle spacings.
        max_faces: cap on NS.
        restarts: decimations per size, each of the goal mesh under another numbering of its
            vertices and faces: the given one, then ``restarts - 1`` permutations drawn from
            ``numpy.random.default_rng(restart_seed)``. QECD is greedy and breaks ties between
            equal-cost collapses (every collapse inside a flat panel costs nothing) by that
            numbering, so one numbering can miss the small model another finds (32 x 32
            diagonal fold, alternating diagonals: 8 faces and 6 keys with 1 restart, 4 and 4
            with 4). The first model under the threshold is taken; a size's error is the least
            over its restarts. Measured on the 112 noise-free goals of the resolution sweep in
            ``experiments/key_particles.py`` (12-40 per side x 4 triangulations x 4 folds):
            key counts hold on 107 with 1 restart, on all with 4 (restart seeds 0, 1 and 2
            alike).
        restart_seed: seed of the permutations.
        coarse_faces: each numbering is decimated once to this many faces, and every size
            from there: the collapses inside flat panels, nearly all of QECD's work (16 ms of
            it at 40 x 40), are then done once per numbering instead of once per size. The
            quadrics restart from the coarse mesh, whose distance to the goal is far below
            the threshold; measured on the same 112 goals, the counts are those of decimating
            from the goal every time. Must exceed ``max_faces``.
        exact_errors: compute every size's error in full. By default the Hausdorff distance
            stops as soon as it reaches the threshold, so the errors recorded for rejected
            sizes are lower bounds (at least the threshold); the accepted model and its error
            are the same either way. The error-vs-NS curves (Fig. 4) need it.
        canonical_triangulation: with rest positions, first set every grid-square diagonal to
            the one the fold compresses least (:func:`deformables.mesh.canonical_triangulation`),
            so the result does not depend on how the grid was split into triangles.
        panels: with rest positions, project the goal onto its flat panels first
            (:func:`deformables.panels.project_on_panels`): ``"on"`` (default) always,
            ``"auto"`` when the goal's estimated noise exceeds ``panel_noise_floor``, ``"off"``
            never. Decimation alone fails from about 0.05 mm of goal noise; with restarts,
            projecting exact goals too keeps all 112 noise-free counts and fixes the goals
            that 0.02 mm of noise, below the floor, throws off under ``"auto"``
            (docs/DESIGN-NOTES.md, "Key particles").
        panel_noise_floor: estimated noise (metres; :attr:`deformables.panels.PanelFit.noise`,
            about 1.55 sigma of per-coordinate Gaussian noise, 0 on an exact fold) above which
            ``"auto"`` projects (sigma ~0.03 mm): it skips the projection's boundary fit on
            exact goals.
    """

    backend: str = "pymeshlab"
    z_scale: float = 10.0
    layer_gap: float = CLOTH_LAYER_GAP
    threshold_gaps: float = 0.35
    geodesic_radius: float = 0.1
    geodesic_spacings: float = 2.5
    geodesic_cap: float = 0.15
    sample_spacings: float = 1.0
    max_faces: int = 40
    restarts: int = 4
    restart_seed: int = 0
    coarse_faces: int = 200
    exact_errors: bool = False
    canonical_triangulation: bool = True
    panels: str = "on"
    panel_noise_floor: float = 5e-5

    def __post_init__(self):
        if self.backend not in BACKENDS:
            raise ValueError(f"unknown decimation backend {self.backend!r}; choose from {BACKENDS}")
        if self.panels not in PANEL_MODES:
            raise ValueError(f"panels must be one of {PANEL_MODES}, got {self.panels!r}")
        for name in ("z_scale", "layer_gap", "threshold_gaps", "geodesic_radius",
                     "geodesic_spacings", "geodesic_cap", "sample_spacings", "panel_noise_floor"):
            check_threshold(getattr(self, name), f"ClothConfig.{name}")
        check_config(self, minimum={"restart_seed": 0})
        if self.max_faces < 2:
            raise ValueError(f"max_faces must be at least 2, got {self.max_faces}")
        if self.restarts < 1:
            raise ValueError(f"restarts must be at least 1, got {self.restarts}")
        if self.coarse_faces <= self.max_faces:
            raise ValueError(f"coarse_faces ({self.coarse_faces}) must exceed max_faces "
                             f"({self.max_faces})")


@dataclass(frozen=True)
class Mesh:
    """A simplified mesh: ``vertices`` ``(M, 3)``, ``faces`` ``(NS, 3)`` and its ``error``."""

    vertices: np.ndarray
    faces: np.ndarray
    error: float


def renumberings(vertices: np.ndarray, faces: np.ndarray, count: int,
                 seed: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """The mesh ``(V, 3)``, ``(F, 3)`` as given, then under ``count - 1`` random numberings of
    its vertices and faces drawn from ``numpy.random.default_rng(seed)``: ``count`` pairs of
    ``(V, 3)`` vertices and ``(F, 3)`` faces describing the same surface."""
    rng = np.random.default_rng(seed)
    meshes = [(vertices, faces)]
    for _ in range(count - 1):
        order = rng.permutation(len(vertices))
        position = np.empty_like(order)
        position[order] = np.arange(len(order))
        meshes.append((vertices[order], position[faces[rng.permutation(len(faces))]]))
    return meshes


def _geodesic(candidates: np.ndarray, goal: np.ndarray, faces: np.ndarray,
              rest: np.ndarray | None, radius: float) -> np.ndarray:
    """Geodesic distances ``(C, C)`` between candidate particles ``(C,)``.

    On a flat rest sheet the geodesic distance is the straight-line rest distance; without a
    rest shape it is the shortest path along the goal mesh's edges (exact on a developable
    goal up to the graph's detour), searched no farther than ``radius``.
    """
    if rest is not None:
        r = rest[candidates]
        return np.linalg.norm(r[:, None] - r[None], axis=2)
    pairs = edges(faces)
    length = np.linalg.norm(goal[pairs[:, 0]] - goal[pairs[:, 1]], axis=1)
    n = len(goal)
    graph = coo_matrix((np.concatenate([length, length]),
                        (np.concatenate([pairs[:, 0], pairs[:, 1]]),
                         np.concatenate([pairs[:, 1], pairs[:, 0]]))), shape=(n, n)).tocsr()
    return dijkstra(graph, indices=candidates, limit=radius)[:, candidates]


def extract_keys(goal: np.ndarray, faces: np.ndarray, rest: np.ndarray | None,
                 scaled_goal: np.ndarray, scaled_vertices: np.ndarray,
                 radius: float) -> np.ndarray:
    """Alg. 1 line 7 for cloth: sorted key particles ``(K,)``.

    The goal particle nearest each simplified vertex (both ``(N, 3)`` / ``(M, 3)`` in the
    stretched space) is a candidate; candidates are visited from the best-matching one and
    dropped when a kept one lies within ``radius`` geodesically (see :func:`_geodesic`)."""
    dist, nearest = cKDTree(scaled_goal).query(scaled_vertices)
    order = np.argsort(dist, kind="stable")
    candidates = np.unique(nearest[order], return_index=True)
    candidates = candidates[0][np.argsort(candidates[1])]     # unique, best match first
    geo = _geodesic(candidates, goal, faces, rest, radius)
    kept: list[int] = []
    for i in range(len(candidates)):
        if all(geo[i, j] >= radius for j in kept):
            kept.append(i)
    return np.sort(candidates[kept])


def cloth_key_particles(positions, faces, threshold: float | None = None,
                        rest_positions=None, config: ClothConfig = ClothConfig()) -> KeyParticles:
    """Key particles of a cloth goal by mesh decimation (Alg. 1, cloth branch).

    Args:
        positions: ``(N, 3)`` goal particle positions, metres.
        faces: ``(F, 3)`` triangles of the cloth mesh. Duplicate faces are removed (logged).
        threshold: Alg. 1's threshold on the symmetric Hausdorff distance, in metres of the
            z-stretched space; ``None`` uses ``config.threshold_gaps * layer_gap * z_scale``.
        rest_positions: ``(N, 3)`` flat rest positions, for the geodesic filter and the particle
            spacing; ``None`` uses the goal mesh's edges for both. Particle i of the rest shape
            is particle i of the goal: the goal's edges must keep about their rest length.
        config: back-end, stretch and threshold options.

    Returns:
        :class:`KeyParticles` with ``vertices`` ``(M, 3)`` (metres, unstretched) and
        ``elements`` ``(NS, 3)`` of the simplified mesh, ``n_elements = NS`` and ``sizes``
        counted in target faces.

    A non-manifold mesh (an edge of more than two faces, sheets meeting at a vertex) is
    reduced as it is, with a warning.

    Raises:
        TypeError: non-numeric positions or faces, a config that is not a ClothConfig, a
            threshold that is not a number.
        ValueError: bad positions or faces (NaN/inf, fewer than 3 particles, zero extent,
            indices out of range, particles in no face, zero-area faces), rest positions that
            do not match the goal (edge lengths disagree far beyond what a fold does), a
            non-positive threshold, or a threshold that no model up to ``config.max_faces``
            reaches.
    """
    start = time.perf_counter()
    if not isinstance(config, ClothConfig):
        raise TypeError(f"config must be a ClothConfig, got {type(config).__name__}")
    goal = check_positions(positions)
    rest = None if rest_positions is None else check_positions(rest_positions, "rest_positions")
    if rest is not None and rest.shape != goal.shape:
        raise ValueError(f"rest_positions {rest.shape} and positions {goal.shape} differ in shape")
    reference = goal if rest is None else rest
    tri = check_faces(faces, len(goal), require_all=True)
    warn_non_manifold(tri, len(goal))
    if rest is not None:
        check_rest_matches(goal, rest, tri)
    check_areas(tri, reference)
    if rest is not None and config.panels != "off":
        floor = config.panel_noise_floor if config.panels == "auto" else None
        goal = project_on_panels(goal, rest, tri, config.layer_gap, min_noise=floor).positions
    if rest is not None and config.canonical_triangulation:
        tri = canonical_triangulation(goal, tri, rest)
    pairs = edges(tri)
    spacing = float(np.median(np.linalg.norm(reference[pairs[:, 0]] - reference[pairs[:, 1]],
                                             axis=1)))
    stretch = np.array([1.0, 1.0, config.z_scale])
    thr = (check_threshold(threshold) if threshold is not None
           else config.threshold_gaps * config.layer_gap * config.z_scale)
    scaled = goal * stretch
    original = SurfaceDistance(scaled, tri)
    step = config.sample_spacings * spacing

    coarse = [decimate(vertices, faces, config.coarse_faces, config.backend)
              for vertices, faces in renumberings(scaled, tri, config.restarts,
                                                  config.restart_seed)]

    limit = np.inf if config.exact_errors else thr

    def simplify(n_faces: int) -> Mesh:
        best = Mesh(np.empty((0, 3)), np.empty((0, 3), dtype=np.int64), np.inf)
        for vertices, faces in coarse:
            try:
                v, f = decimate(vertices, faces, n_faces, config.backend)
            except EmptyDecimationError:
                logger.debug("restart decimated to nothing at %d faces", n_faces)
                continue
            err = float(np.nanmax(hausdorff(original, scaled, v, f, step, limit=limit)))
            if err < best.error:
                best = Mesh(v, f, err)
            if err < thr:
                break
        return best

    reduction = grow_until_below(simplify, lambda mesh: mesh.error, thr, config.max_faces)
    mesh = reduction.model
    extent = float(np.ptp(reference, axis=0).max())
    radius = max(config.geodesic_radius * extent,
                 min(config.geodesic_spacings * spacing, config.geodesic_cap * extent))
    keys = extract_keys(goal, tri, rest, scaled, mesh.vertices, radius)
    result = KeyParticles(
        indices=keys, n_elements=len(mesh.faces), vertices=mesh.vertices / stretch,
        elements=mesh.faces, sizes=reduction.sizes, errors=reduction.errors,
        error=reduction.error, threshold=thr, seconds=time.perf_counter() - start)
    logger.info("cloth (%d particles, %d faces): %d faces, error %.4g < %.4g, %d keys",
                len(goal), len(tri), result.n_elements, result.error, thr, result.n_keys)
    return result
