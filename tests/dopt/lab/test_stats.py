"""Intervals of dopt.lab.stats against their textbook formulas and their coverage."""

import math
import warnings

import numpy as np
import pytest
from scipy import stats

from dopt.lab.stats import difference_ci, mean_ci


def test_mean_ci_is_the_student_t_interval():
    x = [1.0, 2.0, 4.0, 7.0]
    mean, half = mean_ci(x)
    s = math.sqrt(sum((v - 3.5) ** 2 for v in x) / 3)
    assert mean == pytest.approx(3.5)
    assert half == pytest.approx(stats.t.ppf(0.975, 3) * s / 2)


def test_difference_ci_is_welchs_interval():
    a, b = [1.0, 2.0, 4.0], [3.0, 5.0, 6.0, 9.0, 11.0]
    va, vb = np.var(a, ddof=1) / 3, np.var(b, ddof=1) / 5
    dof = (va + vb) ** 2 / (va ** 2 / 2 + vb ** 2 / 4)       # Welch-Satterthwaite
    diff, half = difference_ci(a, b)
    assert diff == pytest.approx(np.mean(b) - np.mean(a))
    assert half == pytest.approx(stats.t.ppf(0.975, dof) * math.sqrt(va + vb))


def test_difference_ci_covers_the_true_difference_at_its_level():
    rng = np.random.default_rng(3)
    trials, covered = 2000, 0
    for _ in range(trials):
        a = rng.normal(0.0, 1.0, 10)
        b = rng.normal(0.5, 3.0, 10)              # unequal spreads: Welch's case
        diff, half = difference_ci(a, b)
        covered += abs(diff - 0.5) <= half
    # binomial sd at 2000 trials is 0.5 %: 93-97 % holds a correct 95 % interval
    assert 0.93 <= covered / trials <= 0.97


def test_difference_ci_of_one_value_has_no_interval_and_of_none_raises():
    diff, half = difference_ci([1.0], [2.0, 3.0])
    assert diff == pytest.approx(1.5) and math.isnan(half)
    with pytest.raises(ValueError, match="both sides"):
        difference_ci([], [1.0])


def test_difference_ci_to_a_repeated_value_is_the_other_sides_interval_without_warning():
    """A deterministic method (one value repeated) has no spread: Welch's interval is then
    the other side's Student-t interval (degrees of freedom n - 1)."""
    a = [0.0575] * 10
    b = [0.0327, 0.0266, 0.0357, 0.0362, 0.0396, 0.0283, 0.0265, 0.0224, 0.0402, 0.0220]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        diff, half = difference_ci(a, b)
    assert diff == pytest.approx(np.mean(b) - 0.0575)
    assert half == pytest.approx(mean_ci(b)[1])
