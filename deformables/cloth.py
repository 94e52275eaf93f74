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
* Both run in a space stretched by ``z_scale`` along the goal's stacking axis (the normal of
  its layers, :func:`deformables.layers.stacking_axis`; z for a cloth on a table): stacked
  layers then differ by far more than the rounding of a crease, so the error separates "a layer
  is missing" from "a crease is drawn as a chord".
* Threshold: relative to the goal's own layer gap, which is estimated from the goal
  (:func:`deformables.layers.estimate_layer_gap`) unless ``ClothConfig.layer_gap`` gives it:
  ``threshold_gaps * gap * z_scale``, the stretch reduced (never below 1) so that the
  stretched gap is at most ``max_stretched_gap`` of the sheet's shorter side. Nothing in it is
  in absolute units, so it holds for any gap, particle spacing, sheet size or placement.
* Extract: the goal particle nearest each simplified vertex (in the stretched space), then a
  greedy filter by geodesic distance on the flat rest sheet: a candidate is dropped if a kept
  one lies within ``geodesic_radius``. Both corners of a fold (close in space, far along the
  cloth) survive; near-duplicates along a crease collapse.
* A goal no model size up to ``max_faces`` fits within the threshold still gets its key
  particles: those of the model with the least error, ``reached_threshold=False`` and a logged
  warning (``ClothConfig.strict`` raises instead).

Everything runs in the goal's own frame (:class:`deformables.frame.Frame`: centred, a
power-of-two unit; plain metres for goals of 0.25-0.5 m): pymeshlab decimates in single
precision, and the side fold 1e5 m above the origin got 13 keys and no model under the
threshold. Keys, errors and threshold come back in metres.

``ClothConfig.paper()`` is the paper's own pipeline (one-sided error in metres, one decimation
per size from the goal, no restarts, no panel projection, no re-triangulation) for comparison:
``python -m deformables.bench compare``.
"""
from __future__ import annotations

import logging
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra
from scipy.spatial import ConvexHull, cKDTree

from dopt.validation import check_config, check_real

from .decimation import BACKENDS, EmptyDecimationError, decimate
from .distance import SurfaceDistance, hausdorff, surface_to_surface
from .frame import Frame, check_coordinates, check_range
from .layers import estimate_layer_gap, stacking_axis
from .mesh import canonical_triangulation, edges
from .panels import project_on_panels
from .reduction import KeyParticles, grow_until_below
from .remesh import nearest_particles, resample_on_grid
from .validation import (
    check_areas,
    check_faces,
    check_positions,
    check_rest_matches,
    check_threshold,
    triangle_areas,
    warn_non_manifold,
)

logger = logging.getLogger(__name__)

PANEL_MODES = ("auto", "on", "off", "fold")
ERRORS = ("symmetric", "one-sided")


@dataclass(frozen=True)
class ClothConfig:
    """Options of the cloth reduction.

    Attributes:
        backend: decimation back-end, ``"pymeshlab"`` or ``"trimesh"``.
        error: ``"symmetric"`` Hausdorff distance (default) or the paper's ``"one-sided"``
            one (simplified -> goal, Eq. 4), which accepts two triangles inside a side fold.
        z_scale: stretch along the goal's stacking axis (the normal of its layers) for
            decimation and error ...
        max_stretched_gap: ... but the stretched gap (``gap * z_scale``) is at most this
            fraction of the sheet's shorter side (and the stretch at least 1): stretched far
            beyond the width of a panel, a model whose faces slant from one layer to the next
            across a narrow flap lies close to both layers and passes the threshold (a 12 x 12
            side fold with a 45 mm gap and 0.56 mm of noise: 2 faces and 4 keys under a
            stretch of 10, 6 and 6 under the cap). 1/6 is
            the stretch 10 of a 5 mm gap on a 0.3 m sheet. On 200 goals of the property tests
            (tests/deformables/test_key_particles_properties.py, seed 16) 1/12 and 1/6 hold
            every count, 1/3 loses 13 and no cap (a stretch of 10 whatever the gap) 21; on
            the 128 library goals of 16-40 per side with 0.02 mm of noise and no projection
            (``panels="auto"``, seeds 0 and 1), 1/6 and no cap keep 127, 1/12 keeps 122.
        layer_gap: the distance between the goal's stacked layers (its thickness), metres;
            sets the default threshold. ``None`` (default): estimated from the goal
            (:func:`deformables.layers.estimate_layer_gap`; with rest positions and the panel
            projection, again from the projected goal, which is free of noise).
        flat_gap_spacings: the gap used, in particle spacings, for a goal without stacked
            layers (a flat or single-layer goal) when ``layer_gap`` is ``None``; an estimate
            below a tenth of it (layers that touch) is raised to that tenth.
        threshold_gaps: the default threshold as a multiple of ``gap * z_scale`` (the error
            is measured in the stretched space), with ``gap`` the goal's layer gap. A model
            that misses a layer is off by at least ``gap * z_scale``; one that draws a crease
            joining two layers as a single edge by just under half of it; one with every layer
            and crease only by in-plane errors (a crease's bulge, about half a gap, and where
            QECD puts a vertex along a straight free edge). Over the 112 noise-free goals of
            the resolution sweep in ``experiments/key_particles.py`` (gap 5 mm,
            ``exact_errors=True``), accepted models fit the projected goal exactly and the
            model one size smaller is at least 19.3 mm off; the threshold is 17.5 mm at every
            resolution. On 200 goals of the property tests
            (tests/deformables/test_key_particles_properties.py: gaps from a quarter to two
            spacings, sharp and rounded creases, noise to 1 mm; seed 16) 0.2, 0.25 and 0.35
            hold every count, 0.5 loses two.
        geodesic_radius: key particles closer than this fraction of the rest sheet's extent
            (its shorter side, along its principal axes, whatever its placement; without rest
            positions the goal's largest extent), along the sheet, are merged: the vertices of
            both layers at a crease end become one key, the ends of creases a quarter of a
            side apart stay two (a 12 x 40 sheet given the reflective fold across its short
            side: 8 keys; 6 with a radius from the long side, which merges crease ends 2.75
            spacings apart).
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
            numbering, so one numbering can miss the small model another finds; which ties
            go wrong depends on the machine's floating point (a 25 x 25 diagonal fold on
            alternating diagonals gave 5 keys with 1 restart on one machine, 4 on another;
            ``test_restarts_find_the_model_one_numbering_misses``). The first model under the
            threshold is taken; a size's error is the least over its restarts. On the 112
            noise-free goals of the resolution sweep in ``experiments/key_particles.py``
            (12-40 per side x 4 triangulations x 4 folds) key counts hold on all with 4
            restarts.
        restart_seed: seed of the permutations.
        coarse_faces: each numbering is decimated once to this many faces, and every size
            from there: the collapses inside flat panels, nearly all of QECD's work (16 ms of
            it at 40 x 40), are then done once per numbering instead of once per size. The
            quadrics restart from the coarse mesh, whose distance to the goal is far below
            the threshold; measured on the same 112 goals, the counts are those of decimating
            from the goal every time. Must exceed ``max_faces``; ``None`` decimates from the
            goal at every size (the paper's loop).
        shared_faces: a goal of more faces is first decimated once, under its own numbering,
            to this many, and the restarts renumber that mesh: the first collapses, inside
            flat panels and most of QECD's work at the paper's 100 x 100, are done once
            instead of once per restart, and enough faces are left for the numberings to
            break the later ties differently. Must exceed ``coarse_faces`` (or ``max_faces``
            without it); ``None``: every restart starts from the goal (the separate-restarts
            pipeline of ``python -m deformables.bench compare``, which measures the
            difference).
        exact_errors: compute every size's error in full. By default the Hausdorff distance
            stops as soon as it reaches the threshold, so the errors recorded for rejected
            sizes are lower bounds (at least the threshold); the accepted model and its error
            are the same either way. The error-vs-NS curves (Fig. 4) need it.
        resample: with rest positions, first resample a rectangular sheet's goal on the
            regular grid of its rest sheet (:func:`deformables.remesh.resample_on_grid`) and
            give each key node back as its nearest particle: the keys of an irregular mesh
            are then those of the same surface on a grid (docs/DESIGN-NOTES.md, "Key
            particles on any triangulation").
        canonical_triangulation: with rest positions, first set every grid-square diagonal to
            the one whose length the fold changes least
            (:func:`deformables.mesh.canonical_triangulation`), so the result does not depend
            on how the grid was split into triangles.
        panels: with rest positions, project the goal onto its flat panels first
            (:func:`deformables.panels.project_on_panels`): ``"on"`` (default) always,
            ``"auto"`` when the goal's estimated noise exceeds ``panel_noise_floor``, ``"off"``
            never, ``"fold"`` every particle onto its panel: for a goal that is a fold made by
            a simulator or seen by a camera, whose crease stands as a loop and whose panels
            sag and wrinkle by centimetres (neighbouring panels turned by less than
            ``fold_merge_deg`` are one panel). The default moves only particles within a
            layer gap plus the noise of their panel and keeps the rest as structure.
            Decimation alone fails from about 0.05 mm of goal noise; with restarts,
            projecting exact goals too keeps all 112 noise-free counts and fixes the goals
            that 0.02 mm of noise, below the floor, throws off under ``"auto"``
            (docs/DESIGN-NOTES.md, "Key particles").
        panel_noise_floor: estimated noise (metres; :attr:`deformables.panels.PanelFit.noise`,
            about 1.55 sigma of per-coordinate Gaussian noise, 0 on an exact fold) above which
            ``"auto"`` projects (sigma ~0.03 mm): it skips the projection's boundary fit on
            exact goals.
        fold_merge_deg: under ``panels="fold"``, neighbouring panels whose rigid fits turn
            by less than this (degrees) are one panel: a fold turns one panel against the next
            by 90-180 degrees, a wrinkle by tens. Measured on the simulated goals of
            ``experiments/key_particles.py`` (docs/DESIGN-NOTES.md, "Goals made by the
            simulator").
        strict: raise ``ValueError`` when no model up to ``max_faces`` reaches the threshold.
            By default the model with the least error is returned with
            ``reached_threshold=False`` and a logged warning.
    """

    backend: str = "pymeshlab"
    error: str = "symmetric"
    z_scale: float = 10.0
    max_stretched_gap: float = 1 / 6
    layer_gap: float | None = None
    flat_gap_spacings: float = 0.5
    threshold_gaps: float = 0.35
    geodesic_radius: float = 0.1
    geodesic_spacings: float = 2.5
    geodesic_cap: float = 0.15
    sample_spacings: float = 1.0
    max_faces: int = 40
    restarts: int = 4
    restart_seed: int = 0
    coarse_faces: int | None = 200
    shared_faces: int | None = 2000
    exact_errors: bool = False
    resample: bool = True
    canonical_triangulation: bool = True
    panels: str = "on"
    panel_noise_floor: float = 5e-5
    fold_merge_deg: float = 60.0
    strict: bool = False

    def __post_init__(self):
        if self.backend not in BACKENDS:
            raise ValueError(f"unknown decimation backend {self.backend!r}; choose from {BACKENDS}")
        if self.panels not in PANEL_MODES:
            raise ValueError(f"panels must be one of {PANEL_MODES}, got {self.panels!r}")
        if self.error not in ERRORS:
            raise ValueError(f"ClothConfig.error must be one of {ERRORS}, got {self.error!r}")
        for name in ("z_scale", "max_stretched_gap", "threshold_gaps", "flat_gap_spacings",
                     "geodesic_radius", "geodesic_spacings", "geodesic_cap", "sample_spacings",
                     "panel_noise_floor"):
            check_threshold(getattr(self, name), f"ClothConfig.{name}")
        check_real(self.fold_merge_deg, "ClothConfig.fold_merge_deg", positive=True,
                   maximum=180.0)
        if self.layer_gap is not None:
            check_threshold(self.layer_gap, "ClothConfig.layer_gap")
        check_config(self, minimum={"restart_seed": 0})
        if self.max_faces < 2:
            raise ValueError(f"max_faces must be at least 2, got {self.max_faces}")
        if self.restarts < 1:
            raise ValueError(f"restarts must be at least 1, got {self.restarts}")
        if self.coarse_faces is not None and self.coarse_faces <= self.max_faces:
            raise ValueError(f"coarse_faces ({self.coarse_faces}) must exceed max_faces "
                             f"({self.max_faces})")
        below = ("coarse_faces", self.coarse_faces) if self.coarse_faces is not None else \
            ("max_faces", self.max_faces)
        if self.shared_faces is not None and self.shared_faces <= below[1]:
            raise ValueError(f"shared_faces ({self.shared_faces}) must exceed {below[0]} "
                             f"({below[1]})")

    @classmethod
    def paper(cls, **overrides) -> ClothConfig:
        """The paper's pipeline (Sec. III-C, Alg. 1): the one-sided Hausdorff distance from the
        simplified mesh to the goal (Eq. 4) in plain metres (``z_scale=1``), one QECD per
        size from the goal itself (no restarts, no coarse or shared mesh), no panel
        projection and no re-triangulation. The threshold stays ``threshold_gaps`` layer
        gaps (the paper's is "a parameter set by the user" and not reported), and so do the
        nearest-particle extraction and the geodesic filter, which the paper describes
        without their parameters. ``overrides`` replace any field."""
        fields = dict(error="one-sided", z_scale=1.0, restarts=1, coarse_faces=None,
                      shared_faces=None, panels="off", canonical_triangulation=False,
                      resample=False)
        fields.update(overrides)
        return cls(**fields)


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
    stretched space) is a candidate; candidates are visited from the best-matching one (ties:
    the lower particle index first) and dropped when a kept one lies within ``radius``
    geodesically (see :func:`_geodesic`)."""
    dist, nearest = cKDTree(scaled_goal).query(scaled_vertices)
    # best match first; equal matches (to a millionth of the radius) by particle index, so that
    # the order of the model's vertices does not decide between two equally good particles
    order = np.lexsort((nearest, np.round(dist / (1e-6 * radius))))
    candidates = np.unique(nearest[order], return_index=True)
    candidates = candidates[0][np.argsort(candidates[1])]     # unique, best match first
    geo = _geodesic(candidates, goal, faces, rest, radius)
    kept: list[int] = []
    for i in range(len(candidates)):
        if all(geo[i, j] >= radius for j in kept):
            kept.append(i)
    return np.sort(candidates[kept])


def _stretch(points: np.ndarray, axis: np.ndarray, factor: float) -> np.ndarray:
    """``points`` ``(P, 3)`` with their component along the unit ``axis`` scaled by ``factor``."""
    return points + (factor - 1.0) * np.outer(points @ axis, axis)


def sheet_sides(rest: np.ndarray, faces: np.ndarray) -> tuple[float, float]:
    """The sides ``(long, short)`` of the rectangle with the area and the diameter of the flat
    sheet ``rest`` ``(N, 3)``, ``faces`` ``(F, 3)``: the sides of a rectangular sheet, whatever
    its rotation (a bounding box would see the diagonal of a sheet turned by 45 degrees, and the
    principal axes of a square are any two perpendicular directions)."""
    area = float(triangle_areas(rest, faces).sum())
    centred = rest - rest.mean(axis=0)
    plane = centred @ np.linalg.svd(centred, full_matrices=False)[2][:2].T
    hull = plane[ConvexHull(plane).vertices]
    diameter2 = float((np.linalg.norm(hull[:, None] - hull[None], axis=2) ** 2).max())
    total, difference = np.sqrt(diameter2 + 2 * area), np.sqrt(max(diameter2 - 2 * area, 0.0))
    return (total + difference) / 2, (total - difference) / 2


def _cloth_frame(positions, faces, rest_positions):
    """Check the goal, its faces and rest positions, then move them into the working frame
    (:class:`deformables.frame.Frame`: the rest sheet's unit, each point set's own origin).

    Returns:
        ``(frame, goal, rest, faces, spacing)``: the goal's frame, the goal ``(N, 3)`` and the
        rest positions ``(N, 3)`` (or None) in units of it, the checked faces ``(F, 3)``, and
        the particle spacing (median edge length of the rest sheet, else of the goal) in units.
    """
    goal = check_positions(positions)
    rest = None if rest_positions is None else check_positions(rest_positions, "rest_positions")
    if rest is not None and rest.shape != goal.shape:
        raise ValueError(f"rest_positions {rest.shape} and positions {goal.shape} differ in shape")
    check_coordinates(goal)
    if rest is not None:
        check_coordinates(rest, "rest_positions")
    frame = Frame.of(goal if rest is None else rest)
    goal_frame = frame.moved(goal)
    unit_goal = goal_frame.to_unit(goal)
    unit_rest = None if rest is None else frame.to_unit(rest)
    reference = unit_goal if rest is None else unit_rest
    tri = check_faces(faces, len(goal), require_all=True)
    warn_non_manifold(tri, len(goal))
    pairs = edges(tri)
    spacing = float(np.median(np.linalg.norm(reference[pairs[:, 0]] - reference[pairs[:, 1]],
                                             axis=1)))
    check_range(goal, spacing * frame.scale)
    if rest is not None:
        check_range(rest, spacing * frame.scale, "rest_positions")
        check_rest_matches(unit_goal, unit_rest, tri)
    check_areas(tri, reference)
    return goal_frame, unit_goal, unit_rest, tri, spacing


def _projected_goal_and_gap(goal: np.ndarray, rest: np.ndarray | None, tri: np.ndarray,
                            spacing: float, metres: float, config: ClothConfig,
                            resampled: float = 0.0) -> tuple[np.ndarray, float]:
    """The goal ``(N, 3)`` projected on its panels (``config.panels``, with rest positions
    ``(N, 3)``) and its layer gap, both in the working frame's units (``metres`` per unit):
    ``config.layer_gap``, else estimated from the goal (again after the projection), else
    ``config.flat_gap_spacings`` spacings. ``tri`` ``(F, 3)``; ``spacing`` in units. A goal
    resampled on a grid moves up to ``resampled`` (its round-trip error,
    :attr:`deformables.remesh.SheetGrid.error`) farther onto its panels than the default
    tolerance allows."""

    def layer_gap(points: np.ndarray) -> float | None:
        found = estimate_layer_gap(points, tri, spacing)          # on its own stacking axis
        if not found.found:
            return None
        least = 0.1 * config.flat_gap_spacings * spacing
        if found.gap < least:
            logger.info("cloth: layer gap %.3g mm raised to %.3g mm (a tenth of the flat gap)",
                        found.gap * metres * 1e3, least * metres * 1e3)
        return max(found.gap, least)

    gap = config.layer_gap / metres if config.layer_gap is not None else layer_gap(goal)
    if rest is not None and config.panels != "off":
        floor = config.panel_noise_floor / metres if config.panels == "auto" else None
        fold = config.panels == "fold"
        panel_gap = gap or config.flat_gap_spacings * spacing
        fit = project_on_panels(goal, rest, tri, panel_gap + resampled, min_noise=floor,
                                tolerance=np.inf if fold else None,
                                merge_deg=config.fold_merge_deg if fold else None)
        if fold and fit.n_panels > 1:      # the boundaries again, fitted on the panel model
            fit = project_on_panels(fit.positions, rest, tri, panel_gap)
        if fit.projected.any():
            goal = fit.positions
            if config.layer_gap is None:       # again, on the projected goal: free of noise
                gap = layer_gap(goal) or gap
    if gap is None:
        gap = config.flat_gap_spacings * spacing
        logger.info("cloth: no stacked layers; gap taken as %g spacings (%.4g mm)",
                    config.flat_gap_spacings, gap * metres * 1e3)
    return goal, gap


def cloth_key_particles(positions, faces, threshold: float | None = None,
                        rest_positions=None, config: ClothConfig = ClothConfig()) -> KeyParticles:
    """Key particles of a cloth goal by mesh decimation (Alg. 1, cloth branch).

    Args:
        positions: ``(N, 3)`` goal particle positions, metres, in any rigid placement.
        faces: ``(F, 3)`` triangles of the cloth mesh. Duplicate faces are removed (logged).
        threshold: Alg. 1's threshold on the Hausdorff distance, in metres of the stretched
            space; ``None`` uses ``config.threshold_gaps * gap * z``, with ``gap`` the goal's
            layer gap (``config.layer_gap``, or estimated from the goal) and ``z`` the stretch:
            ``config.z_scale``, reduced (to no less than 1) so that ``gap * z`` is at most
            ``config.max_stretched_gap`` times the sheet's shorter side.
        rest_positions: ``(N, 3)`` flat rest positions, in any rigid placement, for the
            geodesic filter, the particle spacing, the panel projection and the canonical
            triangulation; ``None`` uses the goal mesh's edges for the first two and skips the
            others. Particle i of the rest shape is particle i of the goal: the goal's edges
            must keep about their rest length.
        config: back-end, stretch and threshold options.

    Returns:
        :class:`KeyParticles` with ``vertices`` ``(M, 3)`` (metres, unstretched) and
        ``elements`` ``(NS, 3)`` of the simplified mesh, ``n_elements = NS`` and ``sizes``
        counted in target faces. ``reached_threshold`` is False when no size up to
        ``config.max_faces`` reached the threshold: the model is then the one with the least
        error (a warning is logged).

    A non-manifold mesh (an edge of more than two faces, sheets meeting at a vertex) is
    reduced as it is, with a warning.

    Raises:
        TypeError: non-numeric positions or faces, a config that is not a ClothConfig, a
            threshold that is not a number.
        ValueError: bad positions or faces (NaN/inf, fewer than 3 particles, zero extent,
            outside the supported range of :mod:`deformables.frame`, indices out of range,
            particles in no face, zero-area faces), rest positions that do not match the
            goal (edge lengths disagree far beyond what a fold does), no rest positions under
            ``panels="fold"``, a non-positive threshold, or, with
            ``config.strict``, a threshold that no model up to ``config.max_faces`` reaches.
    """
    start = time.perf_counter()
    if not isinstance(config, ClothConfig):
        raise TypeError(f"config must be a ClothConfig, got {type(config).__name__}")
    frame, goal, rest, tri, spacing = _cloth_frame(positions, faces, rest_positions)
    metres = frame.scale                       # metres per unit of the frame the work runs in
    if threshold is not None:
        threshold = check_threshold(threshold)
    if rest is None and config.panels == "fold":
        raise ValueError("ClothConfig(panels='fold') needs rest_positions: the panels are "
                         "rigid maps of regions of the rest sheet")

    particles = rest
    grid = resample_on_grid(goal, rest, tri) if rest is not None and config.resample else None
    if grid is not None:
        goal, rest, tri, spacing = grid.goal, grid.rest, grid.faces, grid.spacing
    goal, gap = _projected_goal_and_gap(goal, rest, tri, spacing, metres, config,
                                        0.0 if grid is None else grid.error)
    if rest is not None and config.canonical_triangulation:
        tri = canonical_triangulation(goal, tri, rest)
    axis = stacking_axis(goal, tri)
    extent, z_scale = _stretch_of(goal, rest, tri, gap, config)
    thr = threshold / metres if threshold is not None else config.threshold_gaps * gap * z_scale
    scaled = _stretch(goal, axis, z_scale)
    reduction = _decimate_below(scaled, tri, spacing, thr, metres, config)
    mesh = reduction.model
    radius = max(config.geodesic_radius * extent,
                 min(config.geodesic_spacings * spacing, config.geodesic_cap * extent))
    keys = extract_keys(goal, tri, rest, scaled, mesh.vertices, radius)
    if grid is not None:
        keys = nearest_particles(rest[keys], particles)
    result = KeyParticles(
        indices=keys, n_elements=len(mesh.faces),
        vertices=frame.to_metres(_stretch(mesh.vertices, axis, 1.0 / z_scale)),
        elements=mesh.faces, sizes=reduction.sizes, errors=reduction.errors,
        error=reduction.error, threshold=thr * metres, seconds=time.perf_counter() - start,
        reached_threshold=reduction.reached, layer_gap=float(gap * metres))
    logger.info("cloth (%d particles, %d faces, layer gap %.4g mm): %d faces, error %.4g "
                "(threshold %.4g%s), %d keys", len(goal), len(tri), result.layer_gap * 1e3,
                result.n_elements, result.error, result.threshold,
                "" if reduction.reached else ", not reached", result.n_keys)
    return result


def _stretch_of(goal: np.ndarray, rest: np.ndarray | None, tri: np.ndarray, gap: float,
                config: ClothConfig) -> tuple[float, float]:
    """``(extent, z_scale)`` of ``cloth_key_particles`` (working-frame units): the rest
    sheet's shorter side (a fold's panels are fractions of either side; without rest
    positions, the goal's largest extent), and the stretch along the stacking axis,
    ``config.z_scale`` reduced (to no less than 1) so that ``gap * z_scale`` is at most
    ``config.max_stretched_gap`` times that extent."""
    extent = (float(np.ptp(goal @ np.linalg.svd(goal - goal.mean(axis=0))[2].T, axis=0).max())
              if rest is None else sheet_sides(rest, tri)[1])
    z_scale = min(config.z_scale, max(1.0, config.max_stretched_gap * extent / gap))
    return extent, z_scale


def _decimate_below(scaled: np.ndarray, tri: np.ndarray, spacing: float, thr: float,
                    metres: float, config: ClothConfig):
    """Alg. 1's loop for cloth: decimate the stretched goal ``scaled`` ``(N, 3)``, faces
    ``tri`` ``(F, 3)``, to growing face counts (``grow_until_below``, errors in metres) until
    the surface distance to it is below ``thr`` (units). Each size tries the renumbered
    restarts (``config.restarts``, of the goal decimated to ``config.shared_faces`` if it has
    more; each decimated first to ``config.coarse_faces`` if set), stopping at the first
    below the threshold. Returns the ``Reduction`` of the accepted ``Mesh``: the one below the
    threshold, or, when no size reaches it, the restart and size of least exact error."""
    # decimations (pymeshlab, which releases the GIL) run in a thread beside the numpy work
    # that does not wait for them: the original's distance index beside the shared decimation,
    # a size's distances beside the decimations of its later restarts
    with ThreadPoolExecutor(1) as pool:
        return _grow_restarts(scaled, tri, spacing, thr, metres, config, pool)


def _grow_restarts(scaled: np.ndarray, tri: np.ndarray, spacing: float, thr: float,
                   metres: float, config: ClothConfig, pool: ThreadPoolExecutor):
    """``_decimate_below`` with its decimation thread ``pool``."""
    step = config.sample_spacings * spacing
    vertices, faces = scaled, tri
    if config.shared_faces is not None and len(tri) > config.shared_faces:
        shared = pool.submit(decimate, scaled, tri, config.shared_faces, config.backend)
        original = SurfaceDistance(scaled, tri)
        vertices, faces = shared.result()
    else:
        original = SurfaceDistance(scaled, tri)
    meshes = renumberings(vertices, faces, config.restarts, config.restart_seed)
    if config.coarse_faces is not None:
        meshes = [decimate(vertices, faces, config.coarse_faces, config.backend)
                  for vertices, faces in meshes]

    def distance(v: np.ndarray, f: np.ndarray, limit: float) -> float:
        if config.error == "one-sided":
            return surface_to_surface(original, v, f, step, limit)[0]
        return float(np.nanmax(hausdorff(original, scaled, v, f, step, limit=limit)))

    limit = np.inf if config.exact_errors else thr

    def simplify(n_faces: int) -> tuple[Mesh, ...]:
        """The restarts' models of this size tried, the least error first (the first restart
        among equals); the search stops at the first under the threshold."""
        found = []
        jobs = [pool.submit(decimate, v, f, n_faces, config.backend) for v, f in meshes]
        for job in jobs:
            try:
                v, f = job.result()
            except EmptyDecimationError:
                logger.debug("restart decimated to nothing at %d faces", n_faces)
                continue
            found.append(Mesh(v, f, distance(v, f, limit)))
            if found[-1].error < thr:
                break
        for job in jobs:                    # the restarts after the first under the threshold
            job.cancel()
        empty = Mesh(np.empty((0, 3)), np.empty((0, 3), dtype=np.int64), np.inf)
        return tuple(sorted(found, key=lambda mesh: mesh.error)) or (empty,)

    def exact(models: tuple[Mesh, ...]) -> tuple[Mesh]:
        """The restart of least exact error among a size's (their errors may be lower
        bounds)."""
        return (min((m if not np.isfinite(m.error) or config.exact_errors else
                     Mesh(m.vertices, m.faces, distance(m.vertices, m.faces, np.inf))
                     for m in models), key=lambda mesh: mesh.error),)

    reduction = grow_until_below(simplify, lambda models: models[0].error * metres,
                                 thr * metres, config.max_faces, strict=config.strict,
                                 exact=exact)
    # reached: the model under the threshold; else the restart of least exact error
    return replace(reduction, model=reduction.model[0])
