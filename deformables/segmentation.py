"""Optimal segmentations of a rope into a polyline with its vertices on particles, by dynamic
programming in O(N) memory (the ``fit="breakpoints"`` knots of :mod:`deformables.rope`).

Shape letters: N particles, NE samples along the rope, S segment counts computed, I x B a block
of the cost table (rows: first particles, columns: last particles).

``cost(i, j)`` is the summed squared distance of the samples in ``[s_i, s_j)`` (``s_i``: the
first sample at or after particle i along the chain) to the chord from particle i to particle
j, each sample at the same relative position along it: the polyline QP's objective with the
vertices held on particles. It comes in closed form from prefix sums over the samples:

    cost = sum |q - a|^2 - 2 d . sum w (q - a) + |d|^2 sum w^2,    w = (t - c_i) / (c_j - c_i)

with ``a = p_i``, ``d = p_j - p_i`` and ``c`` the chain positions; the dot products between a
row's and a column's vectors are small matrix products, so a block of the table needs no
``(I, B, 3)`` temporary. The table is never stored whole: it is computed block by block, the
columns in order, and each block updates every segment count at once (a column's best
polyline of s segments needs the best of s - 1 segments at the rows above it, all in earlier
blocks or earlier in this one). Memory is O(N S) plus a block of ``BLOCK`` entries; time is
O(N^2) per pass, and a pass computes several segment counts (4 at first, then twice as many as
before when more are asked for). Tables of up to ``CACHE`` entries are kept between passes.

The positions must be in a frame of about unit size (:class:`deformables.frame.Frame`): the
prefix sums then cancel to about 1e-14 of a segment's samples, far below any cost the fit tells
apart (one hundredth of a spacing at 20,000 particles is a cost of 2.5e-13 per sample).
"""
from __future__ import annotations

import numpy as np

#: entries of the cost table computed at once (each temporary of a block is 512 KiB: it stays
#: in cache, and a block of 2 ** 19 entries took 25 % longer)
BLOCK = 2 ** 16
#: cost tables of at most this many entries (32 MiB) are kept between passes
CACHE = 2 ** 22
#: segment counts of the first pass
FIRST_PASS = 4


class Segmentation:
    """Optimal segmentations of the rope with vertices on particles.

    Args:
        positions: ``(N, 3)`` particle positions, in a frame of about unit size.
        chain: ``(N,)`` increasing chain position of each particle.
        t: ``(NE,)`` chain positions of the samples, increasing.
        q: ``(NE, 3)`` the samples.
        max_segments: the most segments ever asked for (at most N - 1).

    ``breakpoints(m)`` returns the ``(m,)`` particle indices of the best polyline with m
    vertices, computing more segment counts on demand.
    """

    def __init__(self, positions: np.ndarray, chain: np.ndarray, t: np.ndarray, q: np.ndarray,
                 max_segments: int):
        n = len(positions)
        lo = np.searchsorted(t, chain, side="left")          # first sample of each particle

        def at_particles(values: np.ndarray) -> np.ndarray:
            """Sums of ``values`` over the samples before each particle's first, ``(N, ...)``."""
            return np.concatenate([np.zeros((1,) + values.shape[1:]),
                                   np.cumsum(values, axis=0)])[lo]

        self.n = n
        self.max_segments = min(max_segments, n - 1)
        self.chain = chain
        self.p = positions
        self.count = lo.astype(float)
        self.t1, self.t2 = at_particles(t), at_particles(t * t)
        self.qq = at_particles(np.einsum("kd,kd->k", q, q))
        self.q, self.tq = at_particles(q), at_particles(t[:, None] * q)       # (N, 3)
        self.pp = np.einsum("nd,nd->n", positions, positions)
        self.qp = np.einsum("nd,nd->n", self.q, positions)                    # Q_i . p_i
        self.tqp = np.einsum("nd,nd->n", self.tq, positions)                  # U_i . p_i
        self.blocks = _column_blocks(n)
        self.cache: list[np.ndarray] | None = [] if n * n // 2 <= CACHE else None
        self.best = np.empty((0, n))                      # best[s - 1, j]: s segments, 0..j
        self.parent = np.empty((0, n), dtype=np.int64)

    def cost(self, j0: int, j1: int) -> np.ndarray:
        """The cost table's block ``(j1, j1 - j0)``: rows ``0..j1 - 1``, columns
        ``j0..j1 - 1``; ``inf`` where the row is not before the column."""
        i, j = slice(0, j1), slice(j0, j1)
        s0 = self.count[j][None] - self.count[i][:, None]
        s1 = self.t1[j][None] - self.t1[i][:, None]
        s2 = self.t2[j][None] - self.t2[i][:, None]
        c = self.chain[i][:, None]
        length = np.maximum(self.chain[j][None] - c, 1e-15)
        p_i, p_j = self.p[i], self.p[j]
        pq, pu, pp = p_i @ self.q[j].T, p_i @ self.tq[j].T, p_i @ p_j.T
        qp, up = self.q[i] @ p_j.T, self.tq[i] @ p_j.T
        a_sq = pq - self.qp[i][:, None]                                   # a . sum q
        s1c = s1 - c * s0                                                 # sum (t - c)
        squared = (self.qq[j][None] - self.qq[i][:, None]) - 2 * a_sq + s0 * self.pp[i][:, None]
        x_b = (self.tqp[j][None] - up) - c * (self.qp[j][None] - qp)      # sum (t - c) q . b
        x_a = (pu - self.tqp[i][:, None]) - c * a_sq                      # sum (t - c) q . a
        a_d = pp - self.pp[i][:, None]
        cross = ((x_b - x_a) - a_d * s1c) / length                        # sum w (q - a) . d
        w2 = (s2 - c * (s1 + s1c)) / length ** 2                          # sum w^2
        d_d = self.pp[j][None] - 2 * pp + self.pp[i][:, None]             # |d|^2
        block = np.maximum(squared - 2 * cross + d_d * w2, 0.0)
        below = np.arange(j0, j1)[:, None] >= np.arange(j0, j1)[None]
        block[j0:j1][below] = np.inf
        return block

    def _pass(self, segments: int) -> None:
        """Extend ``best`` and ``parent`` to ``segments`` segment counts, in one pass over the
        cost table."""
        done = len(self.best)
        self.best = np.concatenate([self.best, np.full((segments - done, self.n), np.inf)])
        self.parent = np.concatenate([self.parent,
                                      np.zeros((segments - done, self.n), dtype=np.int64)])
        for number, (j0, j1) in enumerate(self.blocks):
            if self.cache is not None and number < len(self.cache):
                block = self.cache[number]
            else:
                block = self.cost(j0, j1)
                if self.cache is not None:
                    self.cache.append(block)
            columns = np.arange(j1 - j0)
            if done == 0:
                self.best[0, j0:j1] = block[0]
            for s in range(max(done, 1), segments):          # s + 1 segments
                total = self.best[s - 1, :j1, None] + block
                rows = np.argmin(total, axis=0)
                self.parent[s, j0:j1] = rows
                self.best[s, j0:j1] = total[rows, columns]

    def breakpoints(self, m: int) -> np.ndarray:
        """The ``(m,)`` particle indices (0 first, N - 1 last) of the best polyline of m
        vertices (``2 <= m <= max_segments + 1``)."""
        segments = m - 1
        if segments == 1:
            return np.array([0, self.n - 1], dtype=np.int64)
        if segments > len(self.best):
            self._pass(min(self.max_segments,
                           max(segments, 2 * len(self.best), FIRST_PASS)))
        idx = [self.n - 1]
        for s in range(segments, 1, -1):
            idx.append(int(self.parent[s - 1, idx[-1]]))
        idx.append(0)
        return np.array(idx[::-1], dtype=np.int64)


def _column_blocks(n: int) -> list[tuple[int, int]]:
    """Column ranges ``[j0, j1)`` covering ``1..n - 1`` with ``j1 * (j1 - j0) <= BLOCK`` (at
    least one column each)."""
    blocks, j0 = [], 1
    while j0 < n:
        width = int((np.sqrt(j0 * j0 + 4.0 * BLOCK) - j0) / 2)
        j1 = min(n, j0 + max(width, 1))
        blocks.append((j0, j1))
        j0 = j1
    return blocks
