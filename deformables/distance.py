"""Exact point-to-surface distances and the Hausdorff distance between triangle meshes.

Shape letters: Q query points, V vertices, F faces of a mesh.

Point-triangle distances come from ``trimesh.triangles.closest_point``. Candidate triangles are
found with a k-d tree over triangle centroids and made exact with the bound
``dist(p, T) >= |p - centroid(T)| - radius(T)``, where ``radius(T)`` is the largest
centroid-vertex distance of T: no triangle that could be nearer than the best one found is
skipped.

The largest distance of many points (the Hausdorff distance) needs exact distances for few of
them: a dense sample of the surface whose covering radius ``rho`` is known (every surface point
lies within ``rho`` of a sample) bounds each point's distance ``d`` by ``u - rho <= d <= u``,
with ``u`` the distance to the nearest sample (one k-d tree query). Only points whose upper
bound exceeds every other point's lower bound can hold the maximum.
"""
from __future__ import annotations

import numpy as np
import trimesh
from scipy.spatial import cKDTree

#: centroids fetched per point and triangle group before falling back to a ball search
_NEIGHBOURS = 16
#: nearest centroids whose triangles give the first upper bound of a point's distance
_FIRST_GUESS = 4
#: every this many points form the probe that gives max_distance its first exact value
_PROBE_STRIDE = 16
#: probe points (largest upper bounds first) resolved exactly for that first value
_PROBE_EXACT = 32


class _TriangleGroup:
    """Triangles of similar size: their centroids in a k-d tree and their largest radius."""

    def __init__(self, ids: np.ndarray, centroids: np.ndarray, radius: np.ndarray):
        self.ids = ids
        self.tree = cKDTree(centroids[ids])
        self.max_radius = float(radius[ids].max())


class SurfaceDistance:
    """Exact distances from points to the surface of one triangle mesh, built once per mesh.

    A triangle T can only be nearer to p than ``u`` if ``|p - centroid(T)| < u + radius(T)``,
    with ``radius(T)`` the largest centroid-vertex distance of T. Triangles are grouped by
    radius (powers of two of the median), so the tall triangles of a crease in the z-stretched
    space do not widen the search around the small ones.

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
        self.centroids = self.triangles.mean(axis=1)
        self.radius = np.linalg.norm(self.triangles - self.centroids[:, None], axis=2).max(axis=1)
        scale = max(float(np.median(self.radius)), 1e-300)
        level = np.ceil(np.log2(np.maximum(self.radius / scale, 1.0))).astype(np.int64)
        self.groups = [_TriangleGroup(np.flatnonzero(level == g), self.centroids, self.radius)
                       for g in np.unique(level)]
        self.tree = cKDTree(self.centroids)
        if cover_step is None:
            sides = np.linalg.norm(self.triangles - np.roll(self.triangles, 1, axis=1), axis=2)
            cover_step = float(np.median(sides))
        if cover is None:
            cover = sample_surface(vertices, faces, cover_step)
        self.cover_tree = cKDTree(cover)
        #: every surface point lies within this distance of a point of ``cover``
        self.cover_radius = cover_step / np.sqrt(3.0)

    def distances(self, points: np.ndarray) -> np.ndarray:
        """Exact distances ``(Q,)`` from ``points`` ``(Q, 3)`` to the surface."""
        points = np.asarray(points, dtype=float)
        # upper bound: the triangles of the nearest few centroids, then the exhaustive search
        k = min(_FIRST_GUESS, len(self.centroids))
        near = self.tree.query(points, k=k)[1].reshape(len(points), k)
        rows = np.repeat(np.arange(len(points)), k)
        best = self._pair_distance(points, rows, near.ravel()).reshape(len(points), k).min(axis=1)
        for group in self.groups:
            reach = best + group.max_radius
            k = min(_NEIGHBOURS, len(group.ids))
            _, near = group.tree.query(points, k=k, distance_upper_bound=float(reach.max()))
            near = near.reshape(len(points), k)
            rows, cols = np.nonzero(near < len(group.ids))
            tris = near[rows, cols]
            crowded = np.flatnonzero(near[:, -1] < len(group.ids))   # maybe more than k
            if len(crowded):
                balls = group.tree.query_ball_point(points[crowded], reach[crowded])
                extra = [np.asarray(b, dtype=np.int64) for b in balls]
                rows = np.concatenate([rows, np.repeat(crowded, [len(b) for b in extra])])
                tris = np.concatenate([tris] + extra)
            tris = group.ids[tris]
            lower = np.linalg.norm(points[rows] - self.centroids[tris], axis=1) - self.radius[tris]
            keep = lower < best[rows]
            rows, tris = rows[keep], tris[keep]
            if len(rows):
                np.minimum.at(best, rows, self._pair_distance(points, rows, tris))
        return best

    def _pair_distance(self, points: np.ndarray, rows: np.ndarray, tris: np.ndarray) -> np.ndarray:
        """Distances ``(P,)`` from ``points[rows]`` to ``triangles[tris]``."""
        closest = trimesh.triangles.closest_point(self.triangles[tris], points[rows])
        return np.linalg.norm(closest - points[rows], axis=1)

    def max_distance(self, points: np.ndarray, chunk: int = 256,
                     limit: float = np.inf) -> float:
        """``max_q dist(points[q], surface)`` for ``points`` ``(Q, 3)``, exact below ``limit``.

        Each point's distance lies in ``[u - rho, u]`` (``u``: distance to the nearest cover
        sample, ``rho``: the covering radius). A first exact value ``best`` comes from the
        points of a coarse probe with the largest ``u``; the nearest-sample query of all points
        is then cut off at ``best`` (points nearer than that cannot beat it). The remaining
        points are resolved exactly from the largest ``u`` down, in chunks, until no remaining
        ``u`` exceeds the largest value known to be reached: the best exact distance, or the
        best lower bound ``L`` (if the maximum hides among the skipped points it is at most
        ``L`` and at least ``L``, so it equals ``L``).

        With a finite ``limit`` the search stops as soon as some point is known to be at least
        ``limit`` away and returns that point's distance (or the lower bound ``L``): a value
        ``>= limit`` is then a lower bound of the maximum, which is all a threshold test needs.
        """
        points = np.asarray(points, dtype=float)
        probe = points[::_PROBE_STRIDE]
        upper = self.cover_tree.query(probe)[0]
        best = float(self.distances(probe[np.argsort(-upper)[:_PROBE_EXACT]]).max())
        if best >= limit:
            return best
        cut = self.cover_tree.query(points, distance_upper_bound=best)[0]
        candidates = points[~(cut <= best)]                 # cut is inf beyond the bound
        if len(candidates) == 0:
            return best
        upper = self.cover_tree.query(candidates)[0]
        best = max(best, float(upper.max()) - self.cover_radius)
        if best >= limit:
            return best
        order = np.argsort(-upper, kind="stable")
        for begin in range(0, len(order), chunk):
            batch = order[begin:begin + chunk]
            batch = batch[upper[batch] > best]
            if len(batch) == 0:
                break
            best = max(best, float(self.distances(candidates[batch]).max()))
            if best >= limit:
                break
        return best


def sample_surface(vertices: np.ndarray, faces: np.ndarray, step: float) -> np.ndarray:
    """Deterministic samples ``(Q, 3)`` of a mesh: on each triangle a barycentric grid whose
    spacing along the longest edge is at most ``step`` (vertices and edges included).

    The grid splits each triangle into copies of itself scaled by ``1 / m`` with longest edge
    at most ``step``, so every surface point lies within ``step / sqrt(3)`` of a sample."""
    triangles = np.asarray(vertices, dtype=float)[np.asarray(faces)]                 # (F, 3, 3)
    longest = np.linalg.norm(triangles - np.roll(triangles, 1, axis=1), axis=2).max(axis=1)
    splits = np.maximum(1, np.ceil(longest / step)).astype(np.int64)
    samples = []
    for m in np.unique(splits):
        i, j = np.meshgrid(np.arange(m + 1), np.arange(m + 1), indexing="ij")
        inside = i + j <= m
        u, v = i[inside] / m, j[inside] / m                                             # (G,)
        a, b, c = (triangles[splits == m, k][:, None] for k in range(3))                # (T, 1, 3)
        samples.append((a + u[:, None] * (b - a) + v[:, None] * (c - a)).reshape(-1, 3))
    return np.concatenate(samples, axis=0)


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
    samples = sample_surface(vertices, faces, step)
    to_original = original.max_distance(samples, limit=limit)
    if to_original >= limit:
        return to_original, float("nan")
    simplified = SurfaceDistance(vertices, faces, cover_step=step, cover=samples)
    return to_original, simplified.max_distance(original_points, limit=limit)
