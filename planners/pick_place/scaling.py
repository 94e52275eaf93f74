"""The gain of key particles against the particle count: the Fig. 7 trials
of one cloth goal at several sizes (``scaling_trials``) and their statistics
(``scaling_summary``).

A size is the paper protocol's settings (``PickPlaceSettings.preset(task="cloth", goal,
protocol="paper")``: its CEM budget and its physics preset, "default", at every size) with
``n`` (particles per side) changed, in one of two modes (``SCALING_MODES``): "resolution", only
n, the sheet's side fixed and its spacing shrinking; "size", the preset's spacing kept and the
sheet grown with n (as SoftGym's cloths, whose particles lie a radius apart at any size), the
picker's bound, the workspace (the side) and the mass scaled with it, so the areal density
and the reach relative to the sheet stay those of the preset. Either way the preset's own n
gives the preset itself, so the 20 x 20 trials of the Fig. 7 sweep
(docs/results/runs/fig7-cloth-<goal>/) have the same keys and count here.

Costs are in m, and also normalised by the flat sheet's cost to the goal (``flat_cost``:
the start's cost, what SoftGym's normalised performance divides by), which a sheet's size
alone does not change; the trend test runs on both.

The trend test: the paired difference of the final cost, method minus CEM(Simple), per seed
common to both at each size, regressed on log N (N = n * n particles) by ordinary least squares
(``scipy.stats.linregress``; the slope's 95 % interval from the t quantile with n_points - 2
degrees of freedom); the p-values of Original - Simple and Random - Simple are Holm-adjusted
together (``dopt.lab.multiple.holm_named``); a claim over several folds judges all their tests
as one family (``dopt.lab.multiple.holm_slopes``). A positive slope: the gain of CEM(Simple)
grows with the particle count. Means and differences are over the stable trials only (as
``summarize``).
"""

from __future__ import annotations

import functools
from collections.abc import Iterable, Sequence
from dataclasses import replace

import numpy as np
from scipy import stats

from dopt.lab.multiple import NO_TREND, TREND_LEVEL, holm_named, slope_verdict
from dopt.lab.stats import mean_ci
from dopt.lab.sweep import Trial
from planners.pick_place.settings import PickPlaceSettings
from planners.pick_place.trial_names import trial_key

#: the methods compared to CEM(Simple) by the trend test
COMPARED = ("original", "random")
#: what a sweep varies with n (module docstring): the resolution of a fixed sheet, or the
#: size of a sheet at a fixed spacing
SCALING_MODES = ("resolution", "size")


def scaling_settings(goal: str, n: int, threads: int = 0, move: str | None = None,
                     mode: str = "resolution", quick: bool = False,
                     base: PickPlaceSettings | None = None) -> PickPlaceSettings:
    """The paper protocol's cloth settings of ``goal`` with ``n`` particles per side (and the
    simulation ``threads``, not part of a trial's identity; ``move``: the picker's move rule,
    ``PickPlaceSettings.picker_move``, None the fixed move), by ``mode`` (``SCALING_MODES``):
    "size" scales the side, the bound and the mass with (n - 1) / (n0 - 1), the side in the
    preset's spacings (n0 the preset's n; at n0 the preset itself). ``quick``: the preset's
    smoke-sized CEM budget (``PickPlaceSettings.preset(quick=True)``). ``base``: the settings
    a size starts from in place of that preset (a --config file's changes of it)."""
    if mode not in SCALING_MODES:
        raise ValueError(f"unknown scaling mode {mode!r}; choose from "
                         f"{', '.join(SCALING_MODES)}")
    if base is None:
        base = PickPlaceSettings.preset("cloth", goal, quick=quick, protocol="paper")
    base = replace(base, threads=int(threads), picker_move=move)
    if mode == "resolution" or int(n) == base.n:
        return replace(base, n=int(n))
    scale = (int(n) - 1) / (base.n - 1)
    return replace(base, n=int(n), side=base.side * scale, bound=base.bound * scale,
                   mass=base.scene_config().mass * scale ** 2)


@functools.lru_cache(maxsize=32)
def fold_costs(goal: str, n: int, side: float) -> tuple[float, float | None]:
    """(the flat sheet's Eq. 2 cost to the final goal of cloth fold ``goal`` on an n x n sheet
    of ``side`` m, m; the previous fold's goal's, None for a one-fold goal), from the goals'
    own geometry (``deformables.goals``): the mean distance of the goal's rest shape, and of
    the previous goal, to the final goal."""
    from deformables.goals import goal_sequence

    seq = goal_sequence(f"cloth_{goal}", n=n, side=side)
    final = seq[-1].positions

    def cost(x):
        return float(np.linalg.norm(x - final, axis=1).mean())

    return cost(seq[-1].rest_positions), (cost(seq[-2].positions) if len(seq) > 1 else None)


def flat_cost(settings: PickPlaceSettings) -> float:
    """The Eq. 2 cost (m) of the flat sheet to the final goal of the cloth ``settings``
    (``fold_costs``), the start's cost that SoftGym's normalised performance divides by (the
    settled start lies within a fraction of a millimetre of it)."""
    return fold_costs(settings.goal, settings.n, settings.side)[0]


def scaling_trials(goal: str, sizes: Sequence[int], seeds: Iterable[int],
                   methods: Sequence[str], threads: int = 0,
                   move: str | None = None, mode: str = "resolution",
                   quick: bool = False, base: PickPlaceSettings | None = None) -> list[Trial]:
    """The ``dopt.lab.sweep`` trials of every (size, seed, method): key ``trial_key(method, seed,
    settings)`` and params {"settings": settings.to_dict(), "method", "seed"}, exactly as the
    Fig. 7 sweep (``planners.pick_place.experiments.fig7``) builds them, so ``run_trial`` runs them;
    each size's settings are ``scaling_settings``' (``base``: where they start).

    Returns len(sizes) * len(seeds) * len(methods) trials, size-major."""
    out = []
    seeds = [int(s) for s in seeds]
    for n in sizes:
        settings = scaling_settings(goal, n, threads, move, mode, quick, base)
        out += [Trial(trial_key(m, s, settings),
                      {"settings": settings.to_dict(), "method": m, "seed": s})
                for s in seeds for m in methods]
    return out


def _by_size(records: Iterable[dict]) -> dict[int, dict[str, dict[int, float]]]:
    """{n: {method: {seed: final cost}}} of the stable trials of sweep ``records`` ({"params":
    {"settings", "method", "seed"}, "result": ``PickPlaceResult.to_dict()``})."""
    out: dict = {}
    for rec in records:
        p, r = rec["params"], rec["result"]
        if r.get("unstable"):
            continue
        cost = r["final_cost"]
        if cost is None or not np.isfinite(cost):
            continue
        out.setdefault(int(p["settings"]["n"]), {}).setdefault(p["method"], {})[
            int(p["seed"])] = float(cost)
    return out


def _ci(values) -> tuple[float | None, float | None]:
    if not values:
        return None, None
    mean, half = mean_ci(values, TREND_LEVEL)   # intervals at the verdict's level
    return mean, (half if np.isfinite(half) else None)


def trend(sizes: Sequence[int], diffs: Sequence[float]) -> dict:
    """OLS of the paired differences ``diffs`` (k,) on log N, N = n * n for the sizes ``sizes``
    (k,): {"slope" (per unit log N), "slope_ci95" (half-width), "intercept", "p" (two-sided,
    unadjusted), "n_points", "n_sizes"}; slope and p None with fewer than 2 sizes or 3 points."""
    x = np.log(np.asarray(sizes, dtype=float) ** 2)
    y = np.asarray(diffs, dtype=float)
    out = {"n_points": int(y.size), "n_sizes": int(len(set(sizes))), "slope": None,
           "slope_ci95": None, "intercept": None, "p": None}
    if out["n_sizes"] < 2 or y.size < 3:
        return out
    fit = stats.linregress(x, y)
    half = float(stats.t.ppf(0.5 + TREND_LEVEL / 2, y.size - 2) * fit.stderr)
    p = float(fit.pvalue) if np.isfinite(fit.pvalue) else 1.0
    return {**out, "slope": float(fit.slope), "slope_ci95": half,
            "intercept": float(fit.intercept), "p": p}


def scaling_summary(records: Iterable[dict], flat_costs: dict | None = None) -> dict:
    """The statistics of the scaling sweep's records (``dopt.lab.sweep`` records: {"params",
    "result"}).

    Returns {"sizes": [n, ...] ascending, "n_particles": [n * n, ...],
    "per_size": {n: {"methods": {method: {"final_cost_mean", "final_cost_ci95" (half-width,
    None with one seed), "seeds", "n"}}, "<m>_minus_simple": {"mean", "ci95", "seeds",
    "values"} for m in ``COMPARED`` (paired over the common seeds)}},
    "trend": {"<m>_minus_simple": {"slope", "slope_ci95", "intercept", "p", "p_holm",
    "n_points", "n_sizes", "verdict"}}, "verdict": one line}. Costs in m; keys of "per_size"
    are str(n) (JSON). With ``flat_costs`` ({n: the flat sheet's cost, m; ``flat_cost``}, every
    size of the records) the same on the costs divided by it, beside them: per size
    "flat_cost", per method "final_cost_normalised_mean" / "_ci95", "<m>_minus_simple_normalised",
    and "trend_normalised", "verdict_normalised" (Holm over their own two tests)."""
    data = _by_size(records)
    sizes = sorted(data)
    per_size, out_trend = _statistics(data, {n: 1.0 for n in sizes})
    out = {"sizes": sizes, "n_particles": [n * n for n in sizes], "per_size": per_size,
           "trend": out_trend, "verdict": verdict_line(out_trend)}
    if flat_costs is None:
        return out
    missing = [n for n in sizes if n not in flat_costs]
    if missing:
        raise ValueError(f"flat_costs has no cost for the sizes {missing}")
    normalised, norm_trend = _statistics(data, {n: 1.0 / flat_costs[n] for n in sizes})
    for n in sizes:
        entry, norm = per_size[str(n)], normalised[str(n)]
        entry["flat_cost"] = float(flat_costs[n])
        for m, e in entry["methods"].items():
            e["final_cost_normalised_mean"] = norm["methods"][m]["final_cost_mean"]
            e["final_cost_normalised_ci95"] = norm["methods"][m]["final_cost_ci95"]
        for m in COMPARED:
            entry[f"{m}_minus_simple_normalised"] = norm[f"{m}_minus_simple"]
    return {**out, "trend_normalised": norm_trend,
            "verdict_normalised": verdict_line(norm_trend, unit="of the flat cost",
                                                      scale=1.0, digits=3)}


def _statistics(data: dict, scale: dict) -> tuple[dict, dict]:
    """(per_size, trend) of ``scaling_summary`` on the costs of ``data`` ({n: {method: {seed:
    cost}}}) times ``scale[n]``."""
    per_size, points = {}, {m: ([], []) for m in COMPARED}
    for n in sorted(data):
        costs_at = {m: {s: c * scale[n] for s, c in costs.items()}
                    for m, costs in sorted(data[n].items())}
        entry = {"methods": {}}
        for m, costs in costs_at.items():
            mean, half = _ci(list(costs.values()))
            entry["methods"][m] = {"final_cost_mean": mean, "final_cost_ci95": half,
                                   "seeds": sorted(costs), "n": len(costs)}
        simple = costs_at.get("simple", {})
        for m in COMPARED:
            other = costs_at.get(m, {})
            seeds = sorted(set(simple) & set(other))
            values = [other[s] - simple[s] for s in seeds]
            mean, half = _ci(values)
            entry[f"{m}_minus_simple"] = {"mean": mean, "ci95": half, "seeds": seeds,
                                          "values": values}
            points[m][0].extend([n] * len(values))
            points[m][1].extend(values)
        per_size[str(n)] = entry
    fits = {m: trend(*points[m]) for m in COMPARED}
    adjusted = holm_named({m: fits[m]["p"] for m in COMPARED})
    out_trend = {}
    for m in COMPARED:
        p_holm = adjusted.get(m)
        out_trend[f"{m}_minus_simple"] = {**fits[m], "p_holm": p_holm,
                                          "verdict": slope_verdict(fits[m]["slope"], p_holm)}
    return per_size, out_trend


def verdict_line(trends: dict, unit: str = "mm", scale: float = 1e3, digits: int = 2) -> str:
    """One line: per compared method, whether the gap over CEM(Simple) grows with log N, its
    slope (times ``scale``, in ``unit`` to ``digits`` decimals: mm of a cost in m by default)
    with the 95 % interval and the Holm-adjusted p."""
    parts = []
    for m in COMPARED:
        t = trends[f"{m}_minus_simple"]
        if t["slope"] is None:
            parts.append(f"{m} - simple: {NO_TREND} (too few sizes or seeds)")
            continue
        parts.append(f"{m} - simple {t['verdict']} (slope {t['slope'] * scale:+.{digits}f} "
                     f"{unit} per log N +- {t['slope_ci95'] * scale:.{digits}f}, Holm p "
                     f"{t['p_holm']:.3g})")
    return "; ".join(parts)
