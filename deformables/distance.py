"""Exact point-to-surface distances and the Hausdorff distance between triangle meshes.

Shape letters: Q query points, V vertices, F faces of a mesh, P pieces of its triangles.

Point-triangle distances come from ``trimesh.triangles.closest_point``. Candidate triangles are
found with a k-d tree over small pieces of the triangles and made exact with the bound
``dist(p, T) >= min_i |p - centre_i| - radius_i`` over the pieces ``i`` of T (each piece, a
sub-triangle of a barycentric grid on T, lies in the ball of its ``centre`` and ``radius``): no
triangle that could be nearer than the best one found is skipped.

The largest distance of many points (the Hausdorff distance) needs exact distances for few of
them: a dense sample of the surface whose covering radius ``rho`` is known (every surface point
lies within ``rho`` of a sample) bounds each point's distance ``d`` by ``u - rho <= d <= u``,
with ``u`` the distance to the nearest sample (one k-d tree query). Only points whose upper
bound exceeds every other point's lower bound can hold the maximum. Where the maximum must be
exact (a model under the threshold), the distance to each point's nearest triangles is a far
tighter upper bound than ``u``.

The pieces, the tightened bounds, the copies dropped from the cover, the shape of the k-d
trees, the probe sampled and resolved on its own (only its maximum, from the largest guess
down) change the time, not the values: distances, maxima and the lower bounds returned at a
limit are those of the plain search, whose order is documented (:func:`surface_to_surface`'s
scout, then the probe, then the points by their nearest cover sample; docs/DESIGN-NOTES.md,
"Key particles at the paper's size"; tests/deformables/test_distance_properties.py checks
them against a brute-force reference of that search).
"""
from __future__ import annotations

import numpy as np
import trimesh
from scipy.spatial import cKDTree

#: pieces fetched per point before falling back to a ball search
_NEIGHBOURS = 16
#: nearest pieces whose triangles give the first upper bound of a point's distance
_FIRST_GUESS = 2
#: every this many points form the probe that gives max_distance its first exact value
_PROBE_STRIDE = 16
#: probe points (largest upper bounds first) whose largest distance is that first value
_PROBE_EXACT = 32
#: of those, resolved exactly at a time, from the largest guess down
_PROBE_CHUNK = 4
#: every this many rows of a simplified surface's sample form the scout that
#: :func:`surface_to_surface` resolves before its probe under a finite limit: a model that
#: misses a layer is off over much of its surface, and a few dozen points show it at a
#: sixteenth of the probe's cost (the probe's k-d tree query of points far from the sheets
#: is most of a rejected size's time at 100 x 100)
_SCOUT_STRIDE = 256
#: points nearer than the probe's value to a cover sample cannot hold the maximum; they are
#: dropped first (one query) only when that value is at least this many covering radii
#: (below, they are too few to pay for the query: a model that fits, value ~1e-16)
_CUT_RADII = 0.1
#: a triangle is cut into pieces whose radius is at most this many times the median
#: triangle radius, or this many cover steps if that is less
_PIECE_SCALE = 2.0
#: pieces per triangle on average at most (beyond a few thousand): a mesh of a few huge
#: triangles among small ones gets larger pieces (looser bounds, the same distances)
_PIECE_BUDGET = 16


def _tree(points: np.ndarray) -> cKDTree:
    """k-d tree of ``points`` ``(Q, 3)`` for the searches here. Cells split at the midpoint of
    the points' extent and not shrunk to them: a sampled surface lies in thin sheets, and
    shrunk cells or median splits made the nearest-sample queries of points far from the
    sheets about twice as slow (a 100 x 100 fold). The tree's shape changes the time only, not
    which points are found nor their distances."""
    return cKDTree(points, leafsize=32, compact_nodes=False, balanced_tree=False)


def _grid(m: int) -> np.ndarray:
    """Barycentric corners ``(m * m, 3, 3)`` (weights of a triangle's vertices) of the
    sub-triangles of an ``m``-grid on a triangle: ``m (m + 1) / 2`` upright, ``m (m - 1) / 2``
    turned; together they tile the triangle."""
    i, j = (a.ravel() for a in np.meshgrid(np.arange(m), np.arange(m), indexing="ij"))
    up = i + j <= m - 1
    down = i + j <= m - 2
    corners = [np.stack([i[up], j[up]], 1) + np.array(d)[None] for d in ((0, 0), (1, 0), (0, 1))]
    turned = [np.stack([i[down], j[down]], 1) + np.array(d)[None]
              for d in ((1, 0), (0, 1), (1, 1))]
    ij = np.concatenate([np.stack(corners, 1), np.stack(turned, 1)]) / m        # (m*m, 3, 2)
    return np.concatenate([1.0 - ij.sum(axis=2, keepdims=True), ij], axis=2)


def triangle_pieces(triangles: np.ndarray, scale: float
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bounding balls of pieces of ``triangles`` ``(F, 3, 3)``: each triangle whose centroid
    radius exceeds ``scale`` is cut by a barycentric grid into sub-triangles of radius at most
    ``scale`` (a larger scale if that gives more than ``_PIECE_BUDGET`` pieces per triangle
    beyond a few thousand), the others are one piece.

    Returns:
        ``(centres, radii, parents)``: ``(P, 3)`` piece centroids, ``(P,)`` their largest
        centroid-corner distances and ``(P,)`` the triangle each piece belongs to.
    """
    centroids = triangles.mean(axis=1)
    radius = np.linalg.norm(triangles - centroids[:, None], axis=2).max(axis=1)
    splits = np.maximum(1, np.ceil(radius / scale)).astype(np.int64)
    budget = _PIECE_BUDGET * len(triangles) + _PIECE_BUDGET ** 3
    while int((splits ** 2).sum()) > budget:         # a few huge triangles: coarser pieces
        scale *= 2.0
        splits = np.maximum(1, np.ceil(radius / scale)).astype(np.int64)
    centres, radii, parents = [centroids[splits == 1]], [radius[splits == 1]], \
        [np.flatnonzero(splits == 1)]
    for m in np.unique(splits[splits > 1]):
        ids = np.flatnonzero(splits == m)
        corners = np.einsum("gkv,tvd->tgkd", _grid(int(m)), triangles[ids])   # (T, G, 3, 3)
        mid = corners.mean(axis=2)
        centres.append(mid.reshape(-1, 3))
        radii.append(np.linalg.norm(corners - mid[:, :, None], axis=3).max(axis=2).ravel())
        parents.append(np.repeat(ids, m * m))
    return np.concatenate(centres), np.concatenate(radii), np.concatenate(parents)


class SurfaceDistance:
    """Exact distances from points to the surface of one triangle mesh, built once per mesh.

    A triangle T can only be nearer to p than ``u`` if one of its pieces (sub-triangles, see
    :func:`triangle_pieces`) has ``|p - centre| - radius < u``. Pieces are small (about the
    median triangle, or the cover step), so the tall triangles of a crease in the z-stretched
    space and the large faces of a simplified mesh are searched only where p is close to them.

    Args:
        vertices: ``(V, 3)`` mesh vertices.
        faces: ``(F, 3)`` triangles.
        cover_step: sampling step of the surface sample that bounds distances in
            :meth:`max_distance` (covering radius ``cover_step / sqrt(3)``); ``None`` uses the
            median edge length.
        cover: ``(C, 3)`` a sample of the surface taken with :func:`sample_surface` at
            ``cover_step``, when the caller already has it.
    """

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, cover_step: float | None = None,
                 cover: np.ndarray | None = None):
        vertices = np.asarray(vertices, dtype=float)
        faces = np.asarray(faces, dtype=np.int64)
        self.triangles = vertices[faces]                                       # (F, 3, 3)
        if cover_step is None:
            sides = np.linalg.norm(self.triangles - np.roll(self.triangles, 1, axis=1), axis=2)
            cover_step = float(np.median(sides))
        centroids = self.triangles.mean(axis=1)
        median = float(np.median(np.linalg.norm(self.triangles - centroids[:, None],
                                                axis=2).max(axis=1)))
        scale = max(_PIECE_SCALE * min(median, cover_step), 1e-300)
        self.centres, self.radii, self.parents = triangle_pieces(self.triangles, scale)
        self.max_radius = float(self.radii.max())
        self.tree = _tree(self.centres)
        if cover is None:
            cover = sample_surface(vertices, faces, cover_step)
        # the grids of neighbouring triangles share their corners: without the copies the
        # tree is smaller and its nearest-sample distances the same
        self.cover_tree = _tree(unique_points(cover))
        #: every surface point lies within this distance of a point of ``cover``
        self.cover_radius = cover_step / np.sqrt(3.0)

    def distances(self, points: np.ndarray) -> np.ndarray:
        """Exact distances ``(Q,)`` from ``points`` ``(Q, 3)`` to the surface."""
        points = np.asarray(points, dtype=float)
        return self._refine(points, *self._guess(points))

    def _guess(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Upper bounds ``(Q,)`` of the distances of ``points`` ``(Q, 3)``: the distance to the
        nearest of the triangles ``(Q, k)`` (also returned) of their ``k`` nearest pieces."""
        k = min(_FIRST_GUESS, len(self.centres))
        near = self.parents[self.tree.query(points, k=k)[1].reshape(len(points), k)]
        rows = np.repeat(np.arange(len(points)), k)
        guess = self._pair_distance(points, rows, near.ravel()).reshape(len(points), k)
        return guess.min(axis=1), near

    def _refine(self, points: np.ndarray, best: np.ndarray, near: np.ndarray) -> np.ndarray:
        """Exact distances ``(Q,)`` of ``points`` ``(Q, 3)`` from their :meth:`_guess`
        ``best`` ``(Q,)`` and the triangles ``near`` ``(Q, k)`` it came from: every triangle
        with a piece that could hold a nearer point is measured."""
        best = np.array(best, dtype=float)
        reach = best + self.max_radius
        k = min(_NEIGHBOURS, len(self.centres))
        dist, found = self.tree.query(points, k=k, distance_upper_bound=float(reach.max()))
        dist, found = dist.reshape(len(points), k), found.reshape(len(points), k)
        rows, cols = np.nonzero(dist < reach[:, None])
        pieces = found[rows, cols]
        crowded = np.flatnonzero(dist[:, -1] < reach)             # maybe more within reach
        if len(crowded):
            balls = self.tree.query_ball_point(points[crowded], reach[crowded])
            extra = [np.asarray(b, dtype=np.int64) for b in balls]
            rows = np.concatenate([rows, np.repeat(crowded, [len(b) for b in extra])])
            pieces = np.concatenate([pieces] + extra)
        lower = np.linalg.norm(points[rows] - self.centres[pieces], axis=1) - self.radii[pieces]
        keep = lower < best[rows]
        n = len(self.triangles)
        pairs = np.unique(rows[keep] * n + self.parents[pieces[keep]])
        pairs = pairs[~np.isin(pairs, (np.arange(len(points))[:, None] * n + near).ravel())]
        rows, tris = np.divmod(pairs, n)
        if len(rows):
            np.minimum.at(best, rows, self._pair_distance(points, rows, tris))
        return best

    def _pair_distance(self, points: np.ndarray, rows: np.ndarray, tris: np.ndarray) -> np.ndarray:
        """Distances ``(P,)`` from ``points[rows]`` to ``triangles[tris]``."""
        points = points[rows]
        closest = trimesh.triangles.closest_point(self.triangles[tris], points)
        return np.linalg.norm(closest - points, axis=1)

    def probe_distance(self, probe: np.ndarray) -> float:
        """The first exact value of :meth:`max_distance`: the largest distance of the
        ``_PROBE_EXACT`` points of ``probe`` ``(Q, 3)`` (its ``points[::_PROBE_STRIDE]``) with
        the largest distances to the nearest cover sample. Only the maximum is exact: the
        points are resolved from the largest :meth:`_guess` down, ``_PROBE_CHUNK`` at a time,
        while a guess exceeds it (far from the surface, where the exact search is costly,
        the guess is nearly exact, so a first few points settle it)."""
        upper = self.cover_tree.query(probe)[0]
        top = probe[np.argsort(-upper)[:_PROBE_EXACT]]
        guess, near = self._guess(top)
        return _max_from_top(guess, -np.inf, _PROBE_CHUNK,
                             lambda batch: self._refine(top[batch], guess[batch], near[batch]))

    def max_distance(self, points: np.ndarray, chunk: int = 256, limit: float = np.inf,
                     probe: float | None = None) -> float:
        """``max_q dist(points[q], surface)`` for ``points`` ``(Q, 3)``, exact below ``limit``.

        Each point's distance lies in ``[u - rho, u]`` (``u``: distance to the nearest cover
        sample, ``rho``: the covering radius). A first exact value ``best`` comes from the
        points of a coarse probe with the largest ``u`` (:meth:`probe_distance`; ``probe``
        passes it when already known); the nearest-sample query of all points is then cut off
        at ``best`` (points nearer than that cannot beat it; not done when ``best`` is far
        below the covering radius, ``_CUT_RADII``: hardly a point would go). Each remaining
        point's distance to its nearest triangles (:meth:`_guess`, nearly exact on a close
        model) is a second upper bound. If none reaches ``limit`` (always without one),
        nothing can stop the search early and the maximum is wanted exactly: the points are
        resolved from the largest bound down, in chunks, until no remaining bound exceeds the
        best exact distance, which on a model that fits the surface leaves a handful of points
        to resolve.

        Otherwise the remaining points are resolved from the largest ``u`` down until no
        remaining ``u`` exceeds the largest value known to be reached: the best exact distance,
        or the best lower bound ``L`` (if the maximum hides among the skipped points it is at
        most ``L`` and at least ``L``, so it equals ``L``), stopping as soon as some point is
        known to be at least ``limit`` away and returning that point's distance (or ``L``): a
        value ``>= limit`` is then a lower bound of the maximum, which is all a threshold test
        needs. Below ``limit`` every route gives the exact maximum; at or above it, the value
        is that of the order by ``u`` (the triangle bounds only prove that no point reaches
        ``limit``, they never reorder the search).
        """
        points = np.asarray(points, dtype=float)
        best = self.probe_distance(points[::_PROBE_STRIDE]) if probe is None else probe
        if best >= limit:
            return best
        candidates = points
        if best >= _CUT_RADII * self.cover_radius:     # else few points are that near a sample
            cut = self.cover_tree.query(points, distance_upper_bound=best)[0]
            candidates = points[~(cut <= best)]             # cut is inf beyond the bound
            if len(candidates) == 0:
                return best
        guess, near = self._guess(candidates)

        def exact(batch: np.ndarray) -> np.ndarray:
            return self._refine(candidates[batch], guess[batch], near[batch])

        if float(guess.max()) < limit:         # no early stop: the exact maximum is wanted
            return _max_from_top(guess, best, chunk, exact)
        upper = self.cover_tree.query(candidates)[0]
        best = max(best, float(upper.max()) - self.cover_radius)
        if best >= limit:
            return best
        if float(upper.max()) < limit:
            return _max_from_top(np.minimum(upper, guess), best, chunk, exact)
        return _max_from_top(upper, best, chunk, exact, limit)


def _max_from_top(upper: np.ndarray, best: float, chunk: int, distances,
                  limit: float = np.inf) -> float:
    """``max(best, ...)`` of the exact distances ``distances(batch)`` of the points with upper
    bounds ``upper`` ``(Q,)``, resolved ``chunk`` at a time from the largest bound down while
    it exceeds the best so far, stopping once the best reaches ``limit``."""
    order = np.argsort(-upper, kind="stable")
    for begin in range(0, len(order), chunk):
        batch = order[begin:begin + chunk]
        batch = batch[upper[batch] > best]
        if len(batch) == 0:
            break
        best = max(best, float(distances(batch).max()))
        if best >= limit:
            break
    return best


def unique_points(points: np.ndarray) -> np.ndarray:
    """``points`` ``(Q, 3)`` without exact copies, sorted lexicographically: ``(U, 3)``."""
    points = np.asarray(points, dtype=float)
    ordered = points[np.lexsort(points.T[::-1])]
    keep = np.ones(len(ordered), dtype=bool)
    keep[1:] = np.any(ordered[1:] != ordered[:-1], axis=1)
    return ordered[keep]


def sample_surface(vertices: np.ndarray, faces: np.ndarray, step: float,
                   stride: int = 1) -> np.ndarray:
    """Deterministic samples ``(Q, 3)`` of a mesh: on each triangle a barycentric grid whose
    spacing along the longest edge is at most ``step`` (vertices and edges included); with a
    ``stride``, only the rows ``[::stride]`` of that sample, bit for bit, computed alone.

    The grid splits each triangle into copies of itself scaled by ``1 / m`` with longest edge
    at most ``step``, so every surface point lies within ``step / sqrt(3)`` of a sample."""
    triangles = np.asarray(vertices, dtype=float)[np.asarray(faces)]                 # (F, 3, 3)
    longest = np.linalg.norm(triangles - np.roll(triangles, 1, axis=1), axis=2).max(axis=1)
    splits = np.maximum(1, np.ceil(longest / step)).astype(np.int64)
    samples, offset = [], 0
    for m in np.unique(splits):
        i, j = np.meshgrid(np.arange(m + 1), np.arange(m + 1), indexing="ij")
        inside = i + j <= m
        u, v = i[inside] / m, j[inside] / m                                             # (G,)
        ids = np.flatnonzero(splits == m)                                               # (T,)
        block = len(ids) * len(u)                     # the block's rows: (T, G) flattened
        if stride == 1:
            a, b, c = (triangles[ids, k][:, None] for k in range(3))                    # (T, 1, 3)
            u, v = u[:, None], v[:, None]                                               # (G, 1)
        else:                                         # its rows among the sample's [::stride]
            t, g = np.divmod(np.arange(-offset % stride, block, stride), len(u))        # (R,)
            a, b, c = (triangles[ids[t], k] for k in range(3))                          # (R, 3)
            u, v = u[g, None], v[g, None]                                               # (R, 1)
        offset += block
        samples.append((a + u * (b - a) + v * (c - a)).reshape(-1, 3))
    return np.concatenate(samples, axis=0)


def surface_to_surface(original: SurfaceDistance, vertices: np.ndarray, faces: np.ndarray,
                       step: float, limit: float = np.inf) -> tuple[float, np.ndarray | None]:
    """The largest distance from the surface ``(V, 3)``, ``(F, 3)`` sampled at ``step`` to
    ``original`` (:meth:`SurfaceDistance.max_distance` of the sample, limit ``limit``), and the
    sample ``(Q, 3)``. Under a finite limit the scout's rows (``[::_SCOUT_STRIDE]``) are
    sampled and resolved like a probe first, then the probe's: when either alone reaches
    ``limit`` (a model far from the original) its value, a lower bound of the maximum, is
    returned, and the full sample is never made and comes back as None."""
    if np.isfinite(limit):
        scout = original.probe_distance(sample_surface(vertices, faces, step, _SCOUT_STRIDE))
        if scout >= limit:
            return scout, None
    best = original.probe_distance(sample_surface(vertices, faces, step, _PROBE_STRIDE))
    if best >= limit:
        return best, None
    samples = sample_surface(vertices, faces, step)
    return original.max_distance(samples, limit=limit, probe=best), samples


def hausdorff(original: SurfaceDistance, original_points: np.ndarray, vertices: np.ndarray,
              faces: np.ndarray, step: float, limit: float = np.inf) -> tuple[float, float]:
    """The two one-sided Hausdorff distances between an original and a simplified mesh.

    Args:
        original: distance to the original surface.
        original_points: ``(N, 3)`` points of the original (its vertices).
        vertices, faces: the simplified mesh ``(V, 3)``, ``(F, 3)``.
        step: sampling step on the simplified surface.
        limit: stop as soon as either distance is known to reach it (a threshold test).

    Returns:
        ``(simplified_to_original, original_to_simplified)``: the largest distance from the
        simplified surface (sampled at ``step``) to the original surface, and from the original
        points to the simplified surface; both exact for these point sets while below
        ``limit``. A value ``>= limit`` is a lower bound; once the first one reaches ``limit``
        the second is not computed and returned as ``nan``.
    """
    to_original, samples = surface_to_surface(original, vertices, faces, step, limit)
    if to_original >= limit:
        return to_original, float("nan")
    simplified = SurfaceDistance(vertices, faces, cover_step=step, cover=samples)
    return to_original, simplified.max_distance(original_points, limit=limit)
