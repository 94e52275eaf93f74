"""Holm's step-down correction (dopt.lab.multiple) against hand-computed references and against the
procedure's definition, computed here by brute force (no statsmodels, no scipy); slope tests
over several groups judged as one family."""

import random

import pytest

from dopt.lab.multiple import NO_TREND, holm, holm_named, holm_reject, holm_slopes


def test_the_worked_example_by_hand():
    """m = 4, p = (0.01, 0.04, 0.03, 0.005). Sorted: 0.005 x 4 = 0.02, 0.01 x 3 = 0.03,
    0.03 x 2 = 0.06, 0.04 x 1 = 0.04 -> 0.06 (kept monotone). At alpha 0.05: 0.005 <= 0.0125
    and 0.01 <= 0.05/3 are rejected, 0.03 > 0.025 stops the procedure."""
    p = [0.01, 0.04, 0.03, 0.005]
    assert holm(p) == pytest.approx([0.03, 0.06, 0.06, 0.02], abs=1e-15)
    assert holm_reject(p, 0.05) == [True, False, False, True]
    assert holm_reject(p, 0.07) == [True, True, True, True]
    assert holm_reject(p, 0.01) == [False, False, False, False]    # 0.005 > 0.01 / 4


def test_clipped_at_one_monotone_and_ties_by_hand():
    # 0.001 x 3 = 0.003; 0.5 x 2 = 1.0; 0.9 x 1 = 0.9 -> 1.0
    assert holm([0.5, 0.9, 0.001]) == pytest.approx([1.0, 1.0, 0.003], abs=1e-15)
    assert holm([0.02, 0.02]) == pytest.approx([0.04, 0.04], abs=1e-15)
    assert holm([0.3]) == [0.3] and holm([]) == [] and holm_reject([]) == []
    assert holm((0.0, 1.0)) == [0.0, 1.0]


def _by_definition(p, alpha):
    """Reject set of the step-down procedure: the largest k with p_(j) <= alpha/(m-j+1) for
    every j <= k, sorted ascending (1-based j), by trying every k."""
    m = len(p)
    ranked = sorted(range(m), key=lambda i: (p[i], i))
    k = max((k for k in range(m + 1)
             if all(p[ranked[j]] <= alpha / (m - j) for j in range(k))), default=0)
    return {ranked[j] for j in range(k)}


def _adjusted_by_definition(p):
    """The smallest alpha at which each hypothesis is rejected: the largest threshold ratio
    (m - j) p_(j) along its path, clipped at 1, computed pair by pair."""
    m = len(p)
    rank = {i: r for r, i in enumerate(sorted(range(m), key=lambda i: (p[i], i)))}
    return [min(1.0, max((m - rank[j]) * p[j] for j in range(m) if rank[j] <= rank[i]))
            for i in range(m)]


def test_against_the_definition_on_random_families():
    rng = random.Random(1979)
    for _ in range(300):
        m = rng.randint(1, 12)
        p = [rng.random() ** rng.choice([1, 3, 6]) for _ in range(m)]
        adjusted = holm(p)
        assert adjusted == pytest.approx(_adjusted_by_definition(p), rel=1e-12, abs=0)
        for alpha in (0.01, 0.05, 0.1, rng.random()):
            expected = _by_definition(p, alpha)
            assert {i for i, r in enumerate(holm_reject(p, alpha)) if r} == expected
            assert {i for i, a in enumerate(adjusted) if a <= alpha} == expected
            bonferroni = {i for i in range(m) if p[i] <= alpha / m}
            assert bonferroni <= expected                      # never rejects less


def test_a_named_family_leaves_out_the_untested_and_keeps_its_order():
    """holm_named: the names with a p, adjusted as one family by the definition, in the order
    given; a None (too few points for a test) neither joins the family nor appears."""
    rng = random.Random(1)
    for _ in range(200):
        names = rng.sample(range(100), rng.randint(0, 10))
        family = {(n, "t"): (None if rng.random() < 0.3 else rng.random() ** 3) for n in names}
        out = holm_named(family)
        tested = [k for k, p in family.items() if p is not None]
        assert list(out) == tested
        assert list(out.values()) == pytest.approx(
            _adjusted_by_definition([family[k] for k in tested]), rel=1e-12, abs=0)
    with pytest.raises(TypeError, match="pvalues must be a mapping"):
        holm_named([0.1, 0.2])
    with pytest.raises(ValueError, match=r"pvalues\[1\] must be a probability"):
        holm_named({"a": 0.1, "b": 1.5})


def test_slope_tests_over_folds_are_one_holm_family():
    """Four tests over two folds, Holm by hand: p (0.01, 0.04, 0.03, 0.5) adjust to (0.04,
    0.09, 0.09, 0.5). The diagonal's Original test (p 0.04) passes within its fold (Holm over
    two: 0.04) but not in the family of four."""

    def t(slope, p):
        return {"slope": slope, "p": p}

    fam = holm_slopes({
        "diagonal": {"original_minus_simple": t(0.01, 0.04), "random_minus_simple": t(-0.01, 0.01)},
        "side": {"original_minus_simple": t(-0.02, 0.03), "random_minus_simple": t(0.0, 0.5)}})
    expected = {("diagonal", "original_minus_simple"): (0.09, NO_TREND),
                ("diagonal", "random_minus_simple"): (0.04, "shrinks"),
                ("side", "original_minus_simple"): (0.09, NO_TREND),
                ("side", "random_minus_simple"): (0.5, NO_TREND)}
    assert set(fam) == set(expected)
    for key, (p, word) in expected.items():
        assert fam[key]["p_holm"] == pytest.approx(p) and fam[key]["verdict"] == word, key
        assert fam[key]["m"] == 4
    alone = holm_slopes({"diagonal": {"original_minus_simple": t(0.01, 0.04),
                                      "random_minus_simple": t(-0.01, 0.01)}})
    assert alone[("diagonal", "original_minus_simple")]["verdict"] == "grows"
    untested = holm_slopes({"side": {"original_minus_simple": t(None, None)}})
    assert untested[("side", "original_minus_simple")] == {"p_holm": None,
                                                           "verdict": NO_TREND, "m": 0}


@pytest.mark.parametrize("pvalues, alpha, error, message", [
    ("0.1", 0.05, TypeError, "pvalues must be a sequence of numbers"),
    (0.1, 0.05, TypeError, "pvalues must be a sequence of numbers"),
    ([0.1, "0.2"], 0.05, TypeError, r"pvalues\[1\] must be a real number, got str"),
    ([True], 0.05, TypeError, r"pvalues\[0\] must be a real number, got bool"),
    ([0.1, float("nan")], 0.05, ValueError, r"pvalues\[1\] must be a probability"),
    ([-0.1], 0.05, ValueError, r"pvalues\[0\] must be a probability in \[0, 1\], got -0.1"),
    ([1.5], 0.05, ValueError, "got 1.5"),
    ([0.1], 0.0, ValueError, r"alpha must be in \(0, 1\), got 0.0"),
    ([0.1], 1, ValueError, "alpha must be in"),
    ([0.1], "0.05", TypeError, "alpha must be a real number"),
])
def test_bad_input_names_the_problem(pvalues, alpha, error, message):
    with pytest.raises(error, match=message):
        holm_reject(pvalues, alpha)
    if "alpha" not in message:
        with pytest.raises(error, match=message):
            holm(pvalues)
