"""p-values of the differences the report judges, and Holm's correction of a family.

The distributions are in pure Python (the numbers of the committed pages depend on them to the
last digit, so they stay these functions):

- ``t_sf2(t, df)``: the two-sided tail P(|T| >= |t|) of Student's t with ``df`` (real) degrees
  of freedom, from the regularized incomplete beta function (continued fraction, as in
  Numerical Recipes' ``betacf``); ``t_ppf(q, df)`` its quantile, by bisection;
- ``welch_p(a, b)``: Welch's two-sided test of mean(b) = mean(a) on two samples (what
  ``dopt.lab.stats.difference_ci`` turns into an interval: the interval excludes zero exactly when
  p < 1 - level);
- ``welch_p_from_intervals``: the same from each side's mean, Student-t half-width at a level
  and count (the standard error is the half-width over the t quantile);
- ``normal_p_from_intervals``: a z-test from two means and normal half-widths (the SVR authors'
  Table 1 statistic, 1.645 std / sqrt(n)).

``kendall_tau_b(x, y)``: Kendall's tau-b rank correlation (how two columns order the same
rows). ``holm_family`` applies ``dopt.lab.multiple.holm_named`` (pure Python) to a family of
p-values. The tests check every function against scipy.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from dopt.lab.multiple import holm_named

#: the family-wise error rate the report's families are judged at
FAMILY_ALPHA = 0.05
#: the name of the correction, as the generated sentences give it
CORRECTION = "Holm's correction"


def _betacf(a: float, b: float, x: float) -> float:
    """The continued fraction of the incomplete beta function (modified Lentz)."""
    tiny, qab, qap, qam = 1e-300, a + b, a + 1.0, a - 1.0
    c, d = 1.0, 1.0 - qab * x / qap
    d = 1.0 / (d if abs(d) > tiny else tiny)
    h = d
    for m in range(1, 400):
        m2 = 2 * m
        aa = m * (b - m) * x / ((qam + m2) * (a + m2))
        d = 1.0 + aa * d
        d = 1.0 / (d if abs(d) > tiny else tiny)
        c = 1.0 + aa / c
        c = c if abs(c) > tiny else tiny
        h *= d * c
        aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2))
        d = 1.0 + aa * d
        d = 1.0 / (d if abs(d) > tiny else tiny)
        c = 1.0 + aa / c
        c = c if abs(c) > tiny else tiny
        delta = d * c
        h *= delta
        if abs(delta - 1.0) < 1e-15:
            break
    return h


def betainc(a: float, b: float, x: float) -> float:
    """The regularized incomplete beta function I_x(a, b), a, b > 0, x in [0, 1]."""
    if x <= 0.0:
        return 0.0
    if x >= 1.0:
        return 1.0
    log_front = (math.lgamma(a + b) - math.lgamma(a) - math.lgamma(b)
                 + a * math.log(x) + b * math.log1p(-x))
    if x < (a + 1.0) / (a + b + 2.0):
        return math.exp(log_front) * _betacf(a, b, x) / a
    return 1.0 - math.exp(log_front) * _betacf(b, a, 1.0 - x) / b


def t_sf2(t: float, df: float) -> float:
    """P(|T| >= |t|) for Student's t with ``df`` > 0 degrees of freedom."""
    if math.isinf(t):
        return 0.0
    return betainc(df / 2.0, 0.5, df / (df + t * t))


def t_ppf(q: float, df: float) -> float:
    """The ``q`` quantile (0.5 < q < 1) of Student's t with ``df`` degrees of freedom."""
    lo, hi = 0.0, 1.0
    while 1.0 - t_sf2(hi, df) / 2.0 < q:
        hi *= 2.0
    for _ in range(200):
        mid = (lo + hi) / 2.0
        if 1.0 - t_sf2(mid, df) / 2.0 < q:
            lo = mid
        else:
            hi = mid
    return (lo + hi) / 2.0


def normal_sf2(z: float) -> float:
    """P(|Z| >= |z|) for a standard normal Z."""
    return math.erfc(abs(z) / math.sqrt(2.0))


def _welch(diff: float, va: float, vb: float, na: int, nb: int) -> float:
    """Welch's two-sided p of a difference ``diff`` whose sides have squared standard errors
    ``va``, ``vb`` (variance over count) from ``na``, ``nb`` values."""
    se2 = va + vb
    if se2 <= 0.0:
        return 1.0 if diff == 0 else 0.0
    df = se2 * se2 / (va * va / (na - 1) + vb * vb / (nb - 1))
    return t_sf2(diff / math.sqrt(se2), df)


def welch_p(a: Sequence[float], b: Sequence[float]) -> float | None:
    """Welch's two-sided p-value of mean(b) - mean(a) = 0; None with fewer than two values
    on either side."""
    if len(a) < 2 or len(b) < 2:
        return None
    ma, mb = sum(a) / len(a), sum(b) / len(b)
    va = sum((x - ma) ** 2 for x in a) / (len(a) - 1) / len(a)
    vb = sum((x - mb) ** 2 for x in b) / (len(b) - 1) / len(b)
    return _welch(mb - ma, va, vb, len(a), len(b))


def welch_p_from_intervals(a: tuple, b: tuple, level: float) -> float | None:
    """Welch's p-value from (mean, Student-t half-width at ``level``, count) of each side (the
    half-width of ``n`` values is t_{(1+level)/2, n-1} s / sqrt(n)); None without a count of
    at least two or a half-width on either side."""
    (ma, ha, na), (mb, hb, nb) = a, b
    if None in (ma, ha, na, mb, hb, nb) or na < 2 or nb < 2:
        return None
    q = (1.0 + level) / 2.0
    va, vb = (ha / t_ppf(q, na - 1)) ** 2, (hb / t_ppf(q, nb - 1)) ** 2
    return _welch(mb - ma, va, vb, na, nb)


def normal_p_from_intervals(a: tuple, b: tuple, level: float) -> float | None:
    """A z-test's two-sided p-value from (mean, normal half-width at ``level``) of each side;
    None without both."""
    (ma, ha), (mb, hb) = a[:2], b[:2]
    if None in (ma, ha, mb, hb):
        return None
    z_q = _normal_ppf((1.0 + level) / 2.0)
    se = math.hypot(ha / z_q, hb / z_q)
    if se == 0.0:
        return 1.0 if ma == mb else 0.0
    return normal_sf2((mb - ma) / se)


def _normal_ppf(q: float) -> float:
    lo, hi = 0.0, 40.0
    for _ in range(200):
        mid = (lo + hi) / 2.0
        if 1.0 - normal_sf2(mid) / 2.0 < q:
            lo = mid
        else:
            hi = mid
    return (lo + hi) / 2.0


def holm_family(pvalues: dict, alpha: float = FAMILY_ALPHA) -> dict:
    """{name: (p, Holm-adjusted p, rejected at family-wise ``alpha``)} of a family {name: p};
    names whose p is None are left out of the family (and of the result)."""
    adjusted = holm_named(pvalues)
    return {k: (pvalues[k], adj, adj <= alpha) for k, adj in adjusted.items()}


def pval(p: float | None) -> str:
    """A p-value as the sentences print it: three decimals, "< 0.001" below."""
    if p is None:
        return "n/a"
    return "< 0.001" if p < 0.001 else f"{p:.3f}"


def kendall_tau_b(x: list[float], y: list[float]) -> float | None:
    """Kendall's tau-b rank correlation of two equally long lists (ties in either count as
    neither concordant nor discordant); None with fewer than two values or all tied."""
    n = len(x)
    c = d = tx = ty = 0
    for i in range(n):
        for j in range(i + 1, n):
            sx, sy = (x[i] > x[j]) - (x[i] < x[j]), (y[i] > y[j]) - (y[i] < y[j])
            if sx == 0 or sy == 0:
                tx, ty = tx + (sx == 0), ty + (sy == 0)
            elif sx == sy:
                c += 1
            else:
                d += 1
    pairs = n * (n - 1) // 2
    denom = math.sqrt((pairs - tx) * (pairs - ty))
    return (c - d) / denom if denom else None
