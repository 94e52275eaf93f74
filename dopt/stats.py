"""Summary statistics of trial results (mean and Student-t interval, Welch interval of a
difference)."""

from __future__ import annotations

import warnings

import numpy as np
from scipy import stats


def mean_ci(values, level: float = 0.95) -> tuple[float, float]:
    """Mean and the half-width of its Student-t confidence interval at ``level``.

    One value gives a half-width of nan (no spread can be estimated).
    """
    x = np.asarray(values, dtype=float)
    if x.size == 0:
        raise ValueError("mean_ci of no values")
    mean = float(x.mean())
    if x.size < 2:
        return mean, float("nan")
    sem = float(x.std(ddof=1) / np.sqrt(x.size))
    return mean, float(stats.t.ppf(0.5 + level / 2, x.size - 1) * sem)


def difference_ci(a, b, level: float = 0.95) -> tuple[float, float]:
    """``mean(b) - mean(a)`` and the half-width of its Welch t-interval at ``level``.

    Welch's interval (unequal variances, Welch-Satterthwaite degrees of freedom) is scipy's
    ``ttest_ind(b, a, equal_var=False).confidence_interval``: it answers whether two
    methods' means differ, which two overlapping per-method intervals (``mean_ci``) cannot.
    Fewer than two values on either side give a half-width of nan.
    """
    x, y = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if x.size == 0 or y.size == 0:
        raise ValueError("difference_ci needs values on both sides")
    diff = float(y.mean() - x.mean())
    if x.size < 2 or y.size < 2:
        return diff, float("nan")
    with warnings.catch_warnings():
        # a deterministic method (the scripted policy) repeats one value: scipy warns of
        # "precision loss" in its variance, which is zero, as Welch's interval takes it
        warnings.filterwarnings("ignore", "Precision loss", RuntimeWarning)
        low, high = stats.ttest_ind(y, x, equal_var=False).confidence_interval(level)
    return diff, float(high - low) / 2
