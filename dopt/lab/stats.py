"""Summary statistics of trial results (mean and Student-t interval, Welch interval of a
difference; ``finite``, ``finite_mean_ci`` and ``median_or_none``: the same with None where a
summary has no number, as the pick-and-place summaries write it) and the
state-vector-reduction authors' Table 1 statistic (an outlier fence, then a normal 90 %
interval)."""

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


#: the authors' outlier rule (``authors_kept``): their upper fence's quantile and multiplier
AUTHORS_QUANTILE, AUTHORS_FENCE = 0.6, 1.5
#: the authors' normal quantile for their 90 % interval (``authors_mean_ci``)
AUTHORS_Z = 1.645


def finite(x) -> float | None:
    """``x`` as a float; None for None, NaN or an infinity (JSON has no such number)."""
    return None if x is None or not np.isfinite(x) else float(x)


def finite_mean_ci(values, level: float = 0.95) -> tuple[float | None, float | None]:
    """``mean_ci`` of ``values`` (n,) with each number ``finite`` (one value: no half-width);
    (None, None) for no values or a value that is not finite."""
    if len(values) == 0 or not np.all(np.isfinite(values)):
        return None, None
    mean, half = mean_ci(values, level)
    return finite(mean), finite(half)


def median_or_none(values) -> float | None:
    """The median of ``values`` (n,); None for no values."""
    return float(np.median(values)) if len(values) else None


def authors_kept(values) -> np.ndarray:
    """The values the state-vector-reduction authors keep before averaging, shape (k,).

    Their Table 1 statistic (DMackRus/iLQR_SVR, ``PaperData/scripts/plot_SVR.py``,
    ``generate_table_data``; pandas ``Series.quantile``, linear interpolation) keeps the values
    in ``[0, Q + 1.5 (Q - min)]`` with ``Q`` the 0.6 quantile: an interquartile-style fence
    with the minimum as the lower "quartile" and no lower fence but zero.

    Parameters
    ----------
    values : array_like, shape (n,)
        One column of one run folder (e.g. the final costs of its episodes), finite.

    Returns
    -------
    np.ndarray, shape (k,), k <= n
        The kept values, in their input order.

    Raises
    ------
    ValueError
        ``values`` is empty, not one-dimensional or holds a non-finite value.
    """
    x = np.asarray(values, dtype=float)
    if x.ndim != 1:
        raise ValueError(f"authors_kept takes one column of values, shape (n,), got {x.shape}")
    if x.size == 0:
        raise ValueError("authors_kept of no values")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"authors_kept: {int(np.sum(~np.isfinite(x)))} non-finite value(s)")
    q = float(np.quantile(x, AUTHORS_QUANTILE, method="linear"))
    upper = q + AUTHORS_FENCE * (q - float(x.min()))
    return x[(x >= 0.0) & (x <= upper)]


def authors_mean_ci(values) -> tuple[float, float]:
    """The authors' Table 1 cell of one column: mean and half-width of the kept values.

    Over ``authors_kept(values)`` (k of them): the mean and ``1.645 s / sqrt(k)`` with ``s``
    the sample standard deviation (ddof 1, pandas ``Series.std``), a normal-approximation
    90 % interval (their ``plot_SVR.py``, ``generate_table_data``). A cost cell of their
    table is both numbers divided by the baseline row's kept mean. One kept value gives a
    half-width of nan.

    Parameters
    ----------
    values : array_like, shape (n,)
        One column of one run folder, finite.

    Returns
    -------
    (mean, half_width) : tuple of float

    Raises
    ------
    ValueError
        As ``authors_kept``, or no value is kept (all are negative).
    """
    kept = authors_kept(values)
    if kept.size == 0:
        raise ValueError("authors_mean_ci: no value kept (the rule keeps none below 0)")
    if kept.size < 2:
        return float(kept[0]), float("nan")
    return float(kept.mean()), float(AUTHORS_Z * kept.std(ddof=1) / np.sqrt(kept.size))
