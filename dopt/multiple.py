"""Multiple comparisons: Holm's step-down correction of a family of p-values.

Source: S. Holm, "A simple sequentially rejective multiple test procedure", Scandinavian
Journal of Statistics 6(2), 65-70 (1979). Given m hypotheses with p-values sorted
p_(1) <= ... <= p_(m), reject H_(1), ..., H_(k) where k is the largest index such that
p_(j) <= alpha / (m - j + 1) for every j <= k (step down: stop at the first that fails). The
family-wise error rate is at most alpha under any dependence between the tests, and the
procedure rejects everything Bonferroni's (p <= alpha / m) does, and possibly more.

The adjusted p-value of H_(i) is max over j <= i of min(1, (m - j + 1) p_(j)): H_(i) is
rejected at level alpha exactly when its adjusted p-value is <= alpha, so one adjustment
serves every alpha. Pure Python (no numpy), like ``dopt.stats``.
"""

from __future__ import annotations

import math
from numbers import Real

__all__ = ["holm", "holm_reject"]


def _pvalues(pvalues) -> list[float]:
    """``pvalues`` as a list of floats, each a real number in [0, 1]."""
    if isinstance(pvalues, (str, bytes)) or not hasattr(pvalues, "__iter__"):
        raise TypeError(f"pvalues must be a sequence of numbers, got {type(pvalues).__name__}")
    out = []
    for i, p in enumerate(pvalues):
        if isinstance(p, bool) or not isinstance(p, Real):
            raise TypeError(f"pvalues[{i}] must be a real number, got {type(p).__name__}")
        p = float(p)
        if not (math.isfinite(p) and 0.0 <= p <= 1.0):
            raise ValueError(f"pvalues[{i}] must be a probability in [0, 1], got {p}")
        out.append(p)
    return out


def holm(pvalues) -> list[float]:
    """Holm-adjusted p-values, in the order given.

    Args:
        pvalues: the family's p-values (a sequence of real numbers in [0, 1]; any length, an
            empty family gives []).

    Returns:
        adjusted[i] = max over the j ranked at or below i (ascending p, ties by position) of
        min(1, (m - rank_j) p_j), rank from 0: reject hypothesis i at level alpha iff
        adjusted[i] <= alpha.

    Raises:
        TypeError: ``pvalues`` is not a sequence of real numbers.
        ValueError: a p-value is not finite or outside [0, 1].
    """
    p = _pvalues(pvalues)
    m = len(p)
    order = sorted(range(m), key=lambda i: (p[i], i))
    adjusted = [0.0] * m
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (m - rank) * p[i]))
        adjusted[i] = running
    return adjusted


def holm_reject(pvalues, alpha: float = 0.05) -> list[bool]:
    """Which hypotheses Holm's procedure rejects at family-wise level ``alpha``, in the order
    given: the step-down procedure itself (ascending p, reject while p_(j) <= alpha / (m - j + 1),
    stop at the first that fails), which agrees with ``holm(pvalues)[i] <= alpha`` except where
    rounding puts a p-value on a threshold.

    Raises:
        TypeError, ValueError: as ``holm``; ValueError also for ``alpha`` outside (0, 1).
    """
    if isinstance(alpha, bool) or not isinstance(alpha, Real):
        raise TypeError(f"alpha must be a real number, got {type(alpha).__name__}")
    if not 0.0 < float(alpha) < 1.0:
        raise ValueError(f"alpha must be in (0, 1), got {alpha}")
    p = _pvalues(pvalues)
    m = len(p)
    reject = [False] * m
    for rank, i in enumerate(sorted(range(m), key=lambda i: (p[i], i))):
        if p[i] > alpha / (m - rank):
            break
        reject[i] = True
    return reject
