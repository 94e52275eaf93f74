"""Intervals of dopt.lab.stats against their textbook formulas and their coverage; the
summaries' None-where-undefined forms (``finite``, ``finite_mean_ci``, ``median_or_none``)
against the standard library's statistics."""

import math
import statistics
import warnings

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy import stats

from dopt.lab.stats import difference_ci, finite, finite_mean_ci, mean_ci, median_or_none


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


FLOATS = st.floats(min_value=-1e6, max_value=1e6, allow_nan=False)


@given(st.lists(FLOATS, min_size=2, max_size=30))
def test_finite_mean_ci_is_the_standard_librarys_mean_and_t_half_width(values):
    mean, half = finite_mean_ci(values)
    assert mean == pytest.approx(statistics.fmean(values), abs=1e-6)
    s = statistics.stdev(values)
    want = stats.t.ppf(0.975, len(values) - 1) * s / math.sqrt(len(values))
    assert half == pytest.approx(want, rel=1e-6, abs=1e-6)


@given(FLOATS)
def test_one_value_has_its_mean_and_no_half_width(value):
    assert finite_mean_ci([value]) == (pytest.approx(value), None)


def test_no_value_or_a_non_finite_one_gives_none():
    assert finite_mean_ci([]) == (None, None)
    assert finite_mean_ci([1.0, math.inf]) == (None, None)
    assert finite_mean_ci([1.0, math.nan, 2.0]) == (None, None)
    assert [finite(x) for x in (None, math.nan, -math.inf, 2)] == [None, None, None, 2.0]
    assert type(finite(np.float32(0.5))) is float


@given(st.lists(FLOATS, max_size=30))
def test_median_or_none_is_the_standard_librarys_median(values):
    got = median_or_none(values)
    if not values:
        assert got is None
    else:
        assert got == pytest.approx(statistics.median(values), abs=1e-9)
        assert median_or_none(np.asarray(values)) == got
