"""Alg. 1 of the key-particle paper, generic over the simplifier and the error, and its result.

Shape letters: N particles of the original model, M vertices and E elements (segments or
triangles) of the simplified model, K key particles, S model sizes tried.
"""
from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from typing import Generic, TypeVar

import numpy as np

logger = logging.getLogger(__name__)

Model = TypeVar("Model")


@dataclass(frozen=True)
class Reduction(Generic[Model]):
    """Outcome of the Alg. 1 loop.

    Attributes:
        size: the accepted model size: the first one whose error is below the threshold, or,
            when none is (``reached`` false), the one with the least error.
        model: the simplified model of that size.
        sizes: ``(S,)`` model sizes tried, in order.
        errors: ``(S,)`` error of each size tried.
        reached: whether the accepted model's error is below the threshold.
        error: the accepted model's error.
    """

    size: int
    model: Model
    sizes: np.ndarray
    errors: np.ndarray
    reached: bool
    error: float


def grow_until_below(simplify: Callable[[int], Model], error: Callable[[Model], float],
                     threshold: float, max_size: int, min_size: int = 2, *,
                     strict: bool = True,
                     exact: Callable[[Model], Model] | None = None) -> Reduction[Model]:
    """Alg. 1, lines 1-6: simplify to size ``min_size, min_size + 1, ...`` until the error of the
    simplified model is below ``threshold``.

    Args:
        simplify: size -> simplified model of that size.
        error: simplified model -> its distance to the original goal.
        threshold: accept the first model with ``error < threshold``.
        max_size: the largest size tried.
        strict: when no size up to ``max_size`` reaches the threshold, raise (True) or return
            the model with the least error, ``reached=False``, with a logged warning (False).
        exact: when no size reaches the threshold, each model is replaced by ``exact(model)``,
            whose ``error`` is exact, and ranked by that (for an ``error`` that stops early and
            then gives only a lower bound); the accepted model is the exact one.

    Raises:
        ValueError: ``max_size < min_size``, or, with ``strict``, no size up to ``max_size``
            reaches the threshold (the message gives the best error seen and its size).
    """
    if max_size < min_size:
        raise ValueError(f"max_size {max_size} is below the smallest model size {min_size}")
    sizes: list[int] = []
    errors: list[float] = []
    models: list[Model] = []

    def frozen(values, dtype=None) -> np.ndarray:
        arr = np.array(values, dtype=dtype)
        arr.setflags(write=False)
        return arr

    for size in range(min_size, max_size + 1):
        model = simplify(size)
        err = float(error(model))
        sizes.append(size)
        errors.append(err)
        models.append(model)
        logger.debug("size %d: error %.6g (threshold %.6g)", size, err, threshold)
        if err < threshold:
            return Reduction(size, model, frozen(sizes, np.int64), frozen(errors), True, err)
    if exact is not None:
        models = [exact(m) for m in models]
    ranking = errors if exact is None else [float(error(m)) for m in models]
    ranking = np.where(np.isfinite(ranking), ranking, np.inf)
    best = int(np.argmin(ranking))
    message = (f"the error never fell below the threshold {threshold:.6g} for model sizes "
               f"{min_size}..{max_size} (best {ranking[best]:.6g} at size {sizes[best]})")
    if strict:
        raise ValueError(f"{message}; raise the threshold or the size cap")
    logger.warning("%s; returning the size-%d model, flagged as not reaching the threshold",
                   message, sizes[best])
    return Reduction(sizes[best], models[best], frozen(sizes, np.int64), frozen(errors), False,
                     float(ranking[best]))


@dataclass(frozen=True)
class KeyParticles:
    """Key particles of a goal and the simplified model they come from.

    Attributes:
        indices: ``(K,)`` sorted particle indices (the reduced action space).
        n_elements: segments (rope) or triangles (cloth) of the accepted simplified model.
        vertices: ``(M, 3)`` vertices of the simplified model, metres.
        elements: ``(E, 2)`` segments or ``(E, 3)`` triangles of the simplified model.
        sizes: ``(S,)`` model sizes tried by Alg. 1 (vertices for rope, triangles for cloth).
        errors: ``(S,)`` error at each size tried, metres (cloth: in the z-scaled space).
        error: the accepted model's error.
        threshold: the threshold used, metres (cloth: in the z-scaled space).
        seconds: wall time of the whole reduction, seconds.
        reached_threshold: whether ``error`` is below ``threshold``. False only when no model
            size up to the cap reached it and the reduction was not strict: the model is then
            the one with the least error, and a warning was logged (cloth: its ``error`` is
            then computed in full, where ``errors`` may hold lower bounds, see
            ``ClothConfig.exact_errors``).
        layer_gap: cloth: the layer gap the threshold is relative to, metres (given by
            ``ClothConfig.layer_gap``, estimated from the goal after any panel projection, or
            the flat default); None for rope.
    """

    indices: np.ndarray
    n_elements: int
    vertices: np.ndarray
    elements: np.ndarray
    sizes: np.ndarray
    errors: np.ndarray
    error: float
    threshold: float
    seconds: float
    reached_threshold: bool = True
    layer_gap: float | None = None

    def __post_init__(self):
        for name in ("indices", "vertices", "elements", "sizes", "errors"):
            arr = np.array(getattr(self, name), copy=True)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @property
    def n_keys(self) -> int:
        """K, the number of key particles."""
        return int(len(self.indices))
