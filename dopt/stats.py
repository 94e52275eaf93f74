"""Summary statistics of trial results (mean and Student-t interval)."""

from __future__ import annotations

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
