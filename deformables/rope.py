"""Rope branch of Alg. 1: piecewise-line fitting (the paper's Sec. III-B) and key particles.

Shape letters: N particles, NE evenly spaced samples along the rope, M polyline vertices
(the model size NS of the paper), K key particles.

The polyline is fitted by a QP over its vertices ``V`` ``(M, 3)``: NE samples ``Q`` are taken
evenly along the particle chain, and sample k corresponds to the point of the polyline at the
same relative position inside its segment, ``S = A V`` with a fixed correspondence matrix
``A`` ``(NE, M)``. The QP minimises ``||A V - Q||^2``; the error of Alg. 1 is the mean distance
``mean_k ||(A V - Q)_k||`` (the paper's Eq. 3).

"Evenly along the chain" is by arc length with every edge between neighbouring particles
counted at most ``EDGE_CAP`` (2) times the particle spacing (the median edge length). A rope's
particles are about evenly spaced, and then this is plain arc length; but one particle 2 m off
the rope, or a 5 m gap in the chain, would otherwise take nine tenths of the samples and dilute
the error of a missing corner elsewhere below the threshold. Such an edge weighs as two
spacings: it is still a feature the fit must model, and no more.

The polyline's end vertices correspond to the chain's ends (the first and last samples), so the
two end particles are always key particles.

``A`` depends on where the segments start and end along the chain (the knots):

* ``fit="fixed"``: knots evenly spaced, every segment owns the same share of the samples. This
  is the paper's linear parametrisation; it finds a corner only where the corner happens to sit
  at a multiple of ``1 / (M - 1)`` of the chain.
* ``fit="breakpoints"`` (default): knots at particles, chosen by dynamic programming as the
  optimal segmentation of the rope under the QP's objective with vertices on particles
  (:mod:`deformables.segmentation`, O(N) memory); the QP then places the vertices. This finds
  corners at any position along the chain.

The default threshold is half the fit's resolution: the coarser of the particle spacing and
the samples' spacing. The fit sees the rope only at its NE samples, so detail between them is
below what it can model; a threshold of half a particle spacing alone fell below the residual
of real but tiny features once the particles were denser than the samples: the crossing of
the library's fold lifts the rope by its diameter over 2 cm, a mean residual of 0.7-0.9 mm
whatever the density, and at 300 / 500 / 1000 / 2000 particles the fold got 5 / 6 / 6 / 7
keys instead of its 4 corners. With the samples' spacing as a floor the threshold is the same
fraction of the rope's length at any density above NE particles.

Everything runs in the goal's own frame (:class:`deformables.frame.Frame`): the closed-form
segment costs cancel catastrophically on raw coordinates (the fold 1e6 m from the origin got
12 keys), and squares of 1e200 m overflow.
"""
from __future__ import annotations

import functools
import logging
import threading
import time
from dataclasses import dataclass

import cvxpy as cp
import numpy as np

from dopt.validation import check_config

from .frame import Frame, check_coordinates, check_range
from .reduction import KeyParticles, grow_until_below
from .segmentation import Segmentation
from .validation import check_positions, check_threshold

logger = logging.getLogger(__name__)

FITS = ("breakpoints", "fixed")
#: longest an edge between neighbouring particles counts along the chain, in particle spacings
EDGE_CAP = 2.0
#: fewest samples NE: half the spacing of 8 samples (0.071 of the length) exceeds the error of
#: a model that misses a corner of the library's folds (0.074 of the length for 3 vertices)
#: and 2 samples fit any rope with one segment; 20 keeps a factor of two above that
MIN_SAMPLES = 20


@dataclass(frozen=True)
class RopeConfig:
    """Options of the rope reduction.

    Attributes:
        fit: ``"breakpoints"`` (knots chosen among particles) or ``"fixed"`` (equal shares).
        n_samples: NE, samples along the rope for the fit and the error, at least
            ``MIN_SAMPLES`` (20): a polyline of M vertices fits M samples exactly, and half
            the spacing of fewer than 10 samples (the threshold's floor) exceeds the error of a
            missing corner of the library's folds.
        threshold_spacings: the default threshold (used when no threshold in metres is given),
            as a multiple of the fit's resolution: the coarser of the particle spacing and the
            spacing of the samples (chain length / (NE - 1)). The particle spacing is the median
            distance between neighbouring particles, so that an outlier particle or a gap in
            the chain does not inflate it. 0.5 (6.4 mm for 40 particles on 0.5 m, 2.5 mm for
            any number above 100) sits between the error of a resolved shape (below 1.5 mm on
            clean goals, 0.7-0.9 mm for the library's fold, whose crossing lifts the rope;
            about 1.6 sigma under Gaussian noise of std sigma) and the error of a missing
            corner (above 20 mm for the folding goals).
        max_vertices: cap on M; ``None`` means N. M is also capped at NE - 1.
        strict: raise ``ValueError`` when no model up to the cap reaches the threshold (only
            possible with a threshold in metres or a cap below N). By default the model with
            the least error is returned with ``reached_threshold=False`` and a logged warning.
    """

    fit: str = "breakpoints"
    n_samples: int = 100
    threshold_spacings: float = 0.5
    max_vertices: int | None = None
    strict: bool = False

    def __post_init__(self):
        if self.fit not in FITS:
            raise ValueError(f"unknown rope fit {self.fit!r}; choose from {FITS}")
        check_config(self)
        if self.n_samples < MIN_SAMPLES:
            raise ValueError(f"RopeConfig.n_samples must be at least {MIN_SAMPLES}, got "
                             f"{self.n_samples}: a polyline of M vertices fits M samples "
                             f"exactly, and fewer samples lose the corners of a fold")
        check_threshold(self.threshold_spacings, "RopeConfig.threshold_spacings")
        if self.max_vertices is not None and self.max_vertices < 2:
            raise ValueError(f"RopeConfig.max_vertices must be at least 2, got "
                             f"{self.max_vertices}")


@dataclass(frozen=True)
class Polyline:
    """A fitted polyline: ``vertices`` ``(M, 3)``, ``knots`` ``(M,)`` chain position of each
    vertex (capped arc length, see the module docstring), and the Eq. 3 ``error``."""

    vertices: np.ndarray
    knots: np.ndarray
    error: float


def correspondence(t: np.ndarray, knots: np.ndarray) -> np.ndarray:
    """Correspondence matrix ``A`` ``(NE, M)``: sample at chain position ``t[k]`` ``(NE,)`` maps
    to the point at the same relative position of the segment between the knots around it."""
    m = len(knots)
    seg = np.clip(np.searchsorted(knots, t, side="right") - 1, 0, m - 2)
    length = np.maximum(knots[seg + 1] - knots[seg], 1e-15)
    w = np.clip((t - knots[seg]) / length, 0.0, 1.0)
    a = np.zeros((len(t), m))
    rows = np.arange(len(t))
    a[rows, seg] = 1.0 - w
    a[rows, seg + 1] += w
    return a


class _PolylineQP:
    """``min_V ||A V - Q||^2`` as a cvxpy problem with ``A`` and ``Q`` as Parameters (compiled
    once per (NE, M), then re-solved with new data)."""

    def __init__(self, n_samples: int, n_vertices: int):
        self.a = cp.Parameter((n_samples, n_vertices))
        self.q = cp.Parameter((n_samples, 3))
        self.v = cp.Variable((n_vertices, 3))
        self.problem = cp.Problem(cp.Minimize(cp.sum_squares(self.a @ self.v - self.q)))
        self.lock = threading.Lock()

    def solve(self, a: np.ndarray, q: np.ndarray) -> np.ndarray:
        with self.lock:
            self.a.value, self.q.value = a, q
            self.problem.solve(solver=cp.CLARABEL)
            if self.problem.status != cp.OPTIMAL:
                raise RuntimeError(f"polyline QP ended with status {self.problem.status}")
            return np.array(self.v.value)


@functools.lru_cache(maxsize=64)
def _polyline_qp(n_samples: int, n_vertices: int) -> _PolylineQP:
    return _PolylineQP(n_samples, n_vertices)


def _key_particles(positions: np.ndarray, chain: np.ndarray, vertices: np.ndarray,
                   knots: np.ndarray, resolution: float, spacing: float) -> np.ndarray:
    """Key particles ``(K,)``: the two end particles for the end vertices (they correspond to
    the chain's ends), and for each inner vertex the nearest particle among those between the
    neighbouring knots along the chain (so a crossing strand is never picked). Where the fit's
    ``resolution`` (its samples' spacing) is coarser than the particle ``spacing``, each is
    moved to the corner particle near it (:func:`_corner_particle`); where it is not, the fit
    already sees every particle."""
    lo, hi = knots[:-2], knots[2:]
    keys = [0]
    for vertex, a, b in zip(vertices[1:-1], lo, hi, strict=True):
        window = np.flatnonzero((chain >= a - 1e-12) & (chain <= b + 1e-12))
        if len(window) == 0:     # knots between two particles: the nearest along the chain
            window = np.array([int(np.argmin(np.abs(chain - 0.5 * (a + b))))])
        keys.append(window[np.argmin(np.linalg.norm(positions[window] - vertex, axis=1))])
    keys.append(len(positions) - 1)
    if resolution > spacing * (1 + 1e-9):          # samples sparser than the particles
        keys[1:-1] = [_corner_particle(positions, chain, keys[k], chain[keys[k - 1]],
                                       chain[keys[k + 1]], resolution, spacing)
                      for k in range(1, len(keys) - 1)]
    return np.unique(np.array(keys, dtype=np.int64))


def _corner_particle(positions: np.ndarray, chain: np.ndarray, key: int, low: float,
                     high: float, resolution: float, spacing: float) -> int:
    """The particle within ``resolution`` of ``key`` along the chain (strictly between the
    chain positions ``low`` and ``high`` of its neighbouring keys) where the rope splits best
    into two straight arms: the least summed squared distance of the particles within two
    ``resolution`` (at least four ``spacing``) on either side, not past a neighbour, to the
    best line through the candidate, on each side. The fit sees the rope at its samples only,
    and its vertex is a least-squares point that a feature elsewhere on either leg pulls along
    (the fold's crossing moves its third vertex 0.7 mm: 7 particles at 5,000); the corner
    itself is where the particles turn. Among equal splits the one nearest ``key`` wins (a
    smooth bend keeps its key)."""
    near = np.flatnonzero((np.abs(chain - chain[key]) <= resolution + 1e-12)
                          & (chain > low) & (chain < high))
    if len(near) < 2:
        return key
    residual = np.empty(len(near))
    reach = max(2 * resolution, 4 * spacing)
    for i, b in enumerate(near):
        total = 0.0
        for arm in ((chain >= max(chain[b] - reach, low)) & (chain < chain[b]),
                    (chain > chain[b]) & (chain <= min(chain[b] + reach, high))):
            offset = positions[arm] - positions[b]
            scatter = offset.T @ offset
            total += np.trace(scatter) - np.linalg.eigvalsh(scatter)[-1]
        residual[i] = total
    tied = residual <= residual.min() + 1e-12 * resolution ** 2
    return int(near[tied][np.argmin(np.abs(near[tied] - key))])


def _fit_frame(positions) -> tuple[Frame, np.ndarray, float]:
    """Check the goal, then its working frame, the positions in it ``(N, 3)`` and the particle
    spacing (median edge length) in its units; ValueError outside the supported range."""
    p = check_positions(positions)
    check_coordinates(p)
    frame = Frame.of(p)
    unit = frame.to_unit(p)
    edge = np.linalg.norm(np.diff(unit, axis=0), axis=1)
    spacing = float(np.median(edge[edge > 0]))       # positive: the extent is not zero
    check_range(p, spacing * frame.scale)
    return frame, unit, spacing


def rope_key_particles(positions, threshold: float | None = None,
                       config: RopeConfig = RopeConfig()) -> KeyParticles:
    """Key particles of a rope goal by piecewise-line fitting (Alg. 1, rope branch).

    The fit runs in the goal's own frame (:class:`deformables.frame.Frame`: centred, unit the
    extent), so the keys do not depend on where the goal lies, how it is turned or its size.

    Args:
        positions: ``(N, 3)`` goal positions of the particles, in order along the rope, metres.
        threshold: Alg. 1's error threshold in metres (mean distance, Eq. 3); ``None`` uses
            ``config.threshold_spacings`` times the fit's resolution: the coarser of the
            particle spacing (the median distance between neighbouring particles: an outlier
            particle or a gap does not move it) and the spacing of the samples (see
            :class:`RopeConfig`).
        config: fit and threshold options.

    Returns:
        :class:`KeyParticles` with ``vertices`` ``(M, 3)``, ``elements`` ``(M - 1, 2)`` segments,
        ``n_elements = M - 1`` and ``sizes`` counted in vertices (M, at most
        ``config.n_samples - 1``: a polyline through every sample fits them exactly). The
        indices always hold both end particles, 0 and N - 1.

    Raises:
        TypeError: non-numeric positions, a threshold that is not a number, a config that is
            not a RopeConfig.
        ValueError: bad positions (NaN/inf, fewer than 3 particles, zero extent, outside the
            supported range of :mod:`deformables.frame`), a non-positive threshold, or, with
            ``config.strict``, a threshold that no model up to the cap reaches.
    """
    start = time.perf_counter()
    if not isinstance(config, RopeConfig):
        raise TypeError(f"config must be a RopeConfig, got {type(config).__name__}")
    frame, p, spacing = _fit_frame(positions)
    edge = np.linalg.norm(np.diff(p, axis=0), axis=1)
    # position of each particle along the chain: arc length, long edges capped
    chain = np.concatenate([[0.0], np.cumsum(np.minimum(edge, EDGE_CAP * spacing))])
    resolution = max(spacing, chain[-1] / (config.n_samples - 1))
    thr = (check_threshold(threshold) if threshold is not None
           else config.threshold_spacings * resolution * frame.scale)
    t = np.linspace(0.0, chain[-1], config.n_samples)
    q = np.stack([np.interp(t, chain, p[:, d]) for d in range(3)], axis=1)
    max_vertices = min(config.max_vertices or len(p), len(p), config.n_samples - 1)
    segmentation = (Segmentation(p, chain, t, q, max_vertices - 1)
                    if config.fit == "breakpoints" else None)

    def simplify(m: int) -> Polyline:
        if segmentation is not None:
            knots = chain[segmentation.breakpoints(m)]
        else:
            knots = np.linspace(0.0, chain[-1], m)
        a = correspondence(t, knots)
        vertices = _polyline_qp(config.n_samples, m).solve(a, q)
        error = float(np.mean(np.linalg.norm(a @ vertices - q, axis=1)))
        return Polyline(vertices, knots, error)

    reduction = grow_until_below(simplify, lambda model: model.error * frame.scale, thr,
                                 max_vertices, strict=config.strict)
    line = reduction.model
    keys = _key_particles(p, chain, line.vertices, line.knots, resolution, spacing)
    m = reduction.size
    result = KeyParticles(
        indices=keys, n_elements=m - 1, vertices=frame.to_metres(line.vertices),
        elements=np.stack([np.arange(m - 1), np.arange(1, m)], axis=1),
        sizes=reduction.sizes, errors=reduction.errors, error=reduction.error,
        threshold=thr, seconds=time.perf_counter() - start,
        reached_threshold=reduction.reached)
    logger.info("rope (%d particles, fit=%s): %d vertices, error %.4g m (threshold %.4g m%s), "
                "keys %s", len(p), config.fit, m, result.error, thr,
                "" if reduction.reached else ", not reached", keys.tolist())
    return result
