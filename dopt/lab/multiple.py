"""Multiple comparisons: Holm's step-down correction of a family of p-values.

Source: S. Holm, "A simple sequentially rejective multiple test procedure", Scandinavian
Journal of Statistics 6(2), 65-70 (1979). Given m hypotheses with p-values sorted
p_(1) <= ... <= p_(m), reject H_(1), ..., H_(k) where k is the largest index such that
p_(j) <= alpha / (m - j + 1) for every j <= k (step down: stop at the first that fails). The
family-wise error rate is at most alpha under any dependence between the tests, and the
procedure rejects everything Bonferroni's (p <= alpha / m) does, and possibly more.

The adjusted p-value of H_(i) is max over j <= i of min(1, (m - j + 1) p_(j)): H_(i) is
rejected at level alpha exactly when its adjusted p-value is <= alpha, so one adjustment
serves every alpha. Pure Python (no numpy), like ``dopt.lab.stats``.

Slope tests (does an effect grow with a size?) get a three-way verdict, "grows" / "shrinks" /
``NO_TREND``, from the slope's sign and its Holm-adjusted p (``slope_verdict``); a claim that
spans several groups of tests (folds) judges all of them as one family (``holm_slopes``).
"""

from __future__ import annotations

import math
from numbers import Real

__all__ = ["NO_TREND", "TREND_LEVEL", "holm", "holm_named", "holm_reject", "holm_slopes",
           "slope_verdict"]

#: the family-wise confidence level of a slope test's verdict
TREND_LEVEL = 0.95
#: the verdict of a slope test whose adjusted p-value is above 1 - ``TREND_LEVEL``
NO_TREND = "no trend detected at 95 %"


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


def holm_named(pvalues) -> dict:
    """Holm-adjusted p-values of a named family: {name: p or None} -> {name: adjusted p} over
    the names whose p is not None (a test too small to give one is left out of the family and
    of the result), in the order given; the one way the summaries and reports adjust a family.

    Raises:
        TypeError: ``pvalues`` is not a mapping; a p-value as ``holm``.
        ValueError: as ``holm``.
    """
    if not hasattr(pvalues, "items"):
        raise TypeError(f"pvalues must be a mapping of name to p-value, got "
                        f"{type(pvalues).__name__}")
    tested = [k for k, p in pvalues.items() if p is not None]
    return dict(zip(tested, holm([pvalues[k] for k in tested]), strict=True))


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


def slope_verdict(slope: float | None, p_adjusted: float | None) -> str:
    """"grows" / "shrinks" (the slope's sign) where the adjusted p is at most 1 - TREND_LEVEL,
    else ``NO_TREND`` (also where either is None: too few points to fit)."""
    if slope is None or p_adjusted is None or p_adjusted > 1 - TREND_LEVEL:
        return NO_TREND
    return "grows" if slope > 0 else "shrinks"


def holm_slopes(groups: dict) -> dict:
    """Several groups of slope tests judged as one family: Holm over every p-value together, so
    a claim that spans the groups keeps its family-wise level.

    ``groups``: {group: {test: {"slope": float | None, "p": float | None, ...}}} (a scaling
    summary's "trend" per fold). Returns {(group, test): {"p_holm": adjusted over the whole
    family (None where the test had no p), "verdict": ``slope_verdict`` at that p, "m": the
    family's size}}."""
    adjusted = holm_named({(g, k): t.get("p") for g, tests in groups.items()
                           for k, t in tests.items()})
    return {(g, k): {"p_holm": adjusted.get((g, k)),
                     "verdict": slope_verdict(t.get("slope"), adjusted.get((g, k))),
                     "m": len(adjusted)}
            for g, tests in groups.items() for k, t in tests.items()}
