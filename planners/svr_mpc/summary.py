"""Many finished iLQR-SVR MPC trials of one task -> the rows of Table 1 (``summarize``), paired
comparisons with baseline (``paired``), whether each SVR row beats rand and baseline under
Holm's correction (``versus``) and the effects of feedback and derivative variants.

records: lists of {"params", "result"} as ``dopt.lab.sweep`` stores them.
"""

from __future__ import annotations

import numpy as np
from scipy import stats

from dopt.lab.multiple import holm_named
from dopt.lab.stats import mean_ci, median_or_none
from planners.ilqr import Derivatives
from planners.svr_mpc.authors_data import authors_statistic
from planners.svr_mpc.choice import choice_fields
from planners.svr_mpc.settings import TABLE1_ROWS, row_label

#: a goal object that ends farther than this from the goal (m) was knocked over and rolled away;
#: the paper removes such outliers from its clutter means, and so do we (they are counted)
OUTLIER_DISTANCE = 0.5


def summarize(records: list[dict], baseline: str = "baseline", level: float = 0.90) -> dict:
    """Per row (``row_label``), over the trials of one task:

    - ``mpc_cost_normalised_mean``, ``_ci90``: MPC cost over the ``baseline`` row's on the
      same task instance (seed), mean and Student-t half-width at ``level`` over the trials
      that are neither outliers (goal object ending > ``OUTLIER_DISTANCE`` from the goal, as
      the paper's clutter means leave out; counted in ``outliers``) nor unstable (the executed
      episode broke a stability bound: its cost is not that of a physical push; counted in
      ``n_unstable_trials``), on either side of the ratio;
    - ``mpc_cost_normalised_median``: median of the same per-seed ratios over all trials;
    - ``mpc_cost_median_ratio``: median cost of the row over median cost of baseline (all
      trials, unpaired; the authors' own statistic is ``authors_data.authors_statistic``);
    - ``opt_ms_mean`` (duration on the episode's clock), ``n_dofs_mean``, ``lag_steps_mean``,
      ``success_rate``, ``goal_distance_end_median``, ``n_trials``, ``n_unstable_trials``,
      ``n_unstable_rollouts``;
    - ``travel_median``: median over the trials of how far the goal object came toward its
      goal (start distance - end distance, m; the authors' files give the same per episode);
      ``held_steps_mean``: steps the authors' executor held the arm (0 under Alg. 1).

    records: {"params", "result"} of finished trials of one task.
    """
    by: dict = {}
    for r in records:
        by.setdefault(row_label(r["params"]), {})[r["params"]["seed"]] = r["result"]

    def outlier(v):
        return v["goal_distance_end"] > OUTLIER_DISTANCE

    base_all = {k: v["mpc_cost"] for k, v in by.get(baseline, {}).items()}
    base = {k: c for k, c in base_all.items() if not _excluded(by[baseline][k])}
    out = {}
    for row, trials in by.items():
        res = list(trials.values())
        norm_all = [v["mpc_cost"] / base_all[k] for k, v in trials.items() if k in base_all]
        norm = [v["mpc_cost"] / base[k] for k, v in trials.items()
                if k in base and not _excluded(v)]
        mean, ci = mean_ci(norm, level) if norm else (float("nan"), float("nan"))
        costs = [v["mpc_cost"] for v in res]
        out[row] = {
            "mpc_cost_normalised_mean": mean,
            "mpc_cost_normalised_ci90": ci,
            "mpc_cost_normalised_median": median_or_none(norm_all),
            "mpc_cost_median_ratio": (float(np.median(costs) / np.median(list(base_all.values())))
                                      if base_all else None),
            "mpc_cost_median": float(np.median(costs)),
            "opt_ms_mean": float(np.mean([v["opt_ms_mean"] for v in res])),
            "n_dofs_mean": float(np.mean([v["dofs_mean"] for v in res])),
            "success_rate": float(np.mean([v["success"] for v in res])),
            "goal_distance_end_median": float(np.median([v["goal_distance_end"] for v in res])),
            "goal_distance_end_mean": float(np.mean([v["goal_distance_end"] for v in res])),
            "lag_steps_mean": float(np.mean([v["lag_steps_mean"] for v in res])),
            "travel_median": median_or_none([v["goal_distance_start"] - v["goal_distance_end"]
                                      for v in res if "goal_distance_start" in v]),
            "held_steps_mean": float(np.mean([v.get("held_steps", 0) for v in res])),
            "outliers": int(sum(outlier(v) for v in res)),
            "n_trials": len(res),
            "n_unstable_trials": int(sum(v.get("unstable", False) for v in res)),
            "n_unstable_rollouts": int(sum(v.get("n_unstable_rollouts", 0) for v in res)),
        }
    return out


def paired_ratio(numerator: dict, denominator: dict, level: float = 0.90) -> dict:
    """Cost ratios on the same seeds: {seed: cost} x 2 -> {"ratio_geomean", "ratio_ci90":
    [lo, hi], "better", "pairs"}: the geometric mean of the per-seed ratios with a t-interval
    on their logs (cost ratios are skewed), and the pairs where the numerator cost less."""
    seeds = sorted(set(numerator) & set(denominator))
    logs = [np.log(numerator[k] / denominator[k]) for k in seeds]
    if not logs:
        return {"ratio_geomean": None, "ratio_ci90": None, "better": 0, "pairs": 0}
    mean, ci = mean_ci(logs, level)
    return {"ratio_geomean": float(np.exp(mean)),
            "ratio_ci90": [float(np.exp(mean - ci)), float(np.exp(mean + ci))],
            "better": int(sum(x < 0 for x in logs)), "pairs": len(logs)}


def paired(records: list[dict], baseline: str = "baseline", level: float = 0.90) -> dict:
    """Per row other than ``baseline``: ``paired_ratio`` of its MPC costs over baseline's on
    the same seeds (all trials, outliers included)."""
    by: dict = {}
    for r in records:
        by.setdefault(row_label(r["params"]), {})[r["params"]["seed"]] = r["result"]["mpc_cost"]
    return {row: paired_ratio(costs, by.get(baseline, {}), level)
            for row, costs in by.items() if row != baseline}


#: the rows every SVR row is compared with by ``versus``: the full-state baseline and random
#: selection of theta DoFs (the paper's "Rand" row)
VERSUS_REFERENCES = ("baseline", "rand-t5")


def versus(records: list[dict], references: tuple[str, ...] = VERSUS_REFERENCES,
           alpha: float = 0.05, keep_unstable: bool = False) -> dict:
    """Does each SVR row (method ``svr-*``) cost less than each of ``references``, seed by seed?

    One family: every (SVR row, reference) pair present. Per pair, on the seeds both ran
    where neither trial is an outlier or unstable (as ``summarize``'s mean; counted in
    "excluded"; ``keep_unstable``: outliers only, the sensitivity of a verdict to the
    stability bounds): the per-seed log cost ratios, their geometric mean, a two-sided one-sample
    t-test of mean log ratio 0 (``p``), Holm's adjusted p over the family (``p_holm``), and a
    simultaneous (Bonferroni) interval of the ratio at family-wise level 1 - ``alpha``
    (``ratio_ci_simultaneous``: each pair's t-interval at 1 - alpha / m; it excludes 1 only
    where Holm also rejects). ``verdict``: "cheaper" or "dearer" where Holm rejects at
    ``alpha`` (by the sign of the mean log ratio), else "no difference shown". With fewer than
    3 pairs or no spread a pair has no test, no interval and no verdict.

    Raises ValueError for ``alpha`` outside (0, 1) or a cost that is not positive and finite.

    Returns {"alpha", "family_size", "references", "pairs": {"<row> vs <reference>":
    {"row", "reference", "ratio_geomean", "ratio_ci_simultaneous": [lo, hi] | None, "p",
    "p_holm", "better", "pairs", "excluded", "verdict"}}}.
    """
    if not 0.0 < alpha < 1.0:
        raise ValueError(f"alpha must be in (0, 1), got {alpha}")
    by: dict = {}
    dropped: dict = {}
    for r in records:
        row, seed, res = row_label(r["params"]), r["params"]["seed"], r["result"]
        if not (np.isfinite(res["mpc_cost"]) and res["mpc_cost"] > 0):
            raise ValueError(f"versus compares cost ratios: the MPC cost of {row} on seed "
                             f"{seed} is {res['mpc_cost']!r}, not a positive number")
        by.setdefault(row, {})[seed] = res["mpc_cost"]
        if _excluded(res, keep_unstable):
            dropped.setdefault(row, set()).add(seed)
    svr_rows = sorted(row for row in by
                      if any(row.startswith(m) for m in ("sum-", "svd-")))
    logs, excluded = {}, {}
    for row in svr_rows:
        for ref in references:
            both = set(by[row]) & set(by.get(ref, {}))
            seeds = sorted(both - dropped.get(row, set()) - dropped.get(ref, set()))
            excluded[row, ref] = len(both) - len(seeds)
            if seeds:
                logs[row, ref] = np.log([by[row][k] / by[ref][k] for k in seeds])
    m = len(logs)
    pvals = {k: _t_test_p(x) for k, x in logs.items()}
    adjusted = holm_named(pvals)
    pairs = {}
    for (row, ref), x in logs.items():
        p_holm = adjusted.get((row, ref))
        mean = float(x.mean())
        ci = None
        if pvals[(row, ref)] is not None:              # 3 pairs or more, with spread
            half = float(stats.t.ppf(1 - alpha / (2 * m), x.size - 1)
                         * x.std(ddof=1) / np.sqrt(x.size))
            ci = [float(np.exp(mean - half)), float(np.exp(mean + half))]
        verdict = ("no difference shown" if p_holm is None or p_holm > alpha
                   else "cheaper" if mean < 0 else "dearer")
        pairs[f"{row} vs {ref}"] = {
            "row": row, "reference": ref, "ratio_geomean": float(np.exp(mean)),
            "ratio_ci_simultaneous": ci, "p": pvals[(row, ref)], "p_holm": p_holm,
            "better": int((x < 0).sum()), "pairs": int(x.size),
            "excluded": excluded[row, ref], "verdict": verdict}
    return {"alpha": alpha, "family_size": m, "references": list(references), "pairs": pairs}


def _excluded(result: dict, keep_unstable: bool = False) -> bool:
    """A trial left out of the normalised means and of ``versus``: an outlier (goal object
    farther than ``OUTLIER_DISTANCE`` from the goal) or (unless ``keep_unstable``) an
    unstable episode."""
    return (result["goal_distance_end"] > OUTLIER_DISTANCE
            or (not keep_unstable and bool(result.get("unstable", False))))


def _t_test_p(x: np.ndarray) -> float | None:
    """Two-sided p of a one-sample t-test of mean 0; None with fewer than 3 values or no
    spread (no test is possible)."""
    if x.size < 3 or not x.std(ddof=1) > 0:
        return None
    return float(stats.ttest_1samp(x, 0.0).pvalue)


def _variant_pairs(records: list[dict], plain) -> dict:
    """{row label: (plain row label, {seed: result}, {seed: plain result})} for every row
    (``row_label``) that differs from its ``plain(params)`` row, over the seeds both ran."""
    by: dict = {}
    plain_of: dict = {}
    for r in records:
        p = r["params"]
        label, base = row_label(p), plain(p)
        by.setdefault(label, {})[p["seed"]] = r["result"]
        if base != label:
            plain_of[label] = base
    out = {}
    for label, base in plain_of.items():
        seeds = sorted(set(by[label]) & set(by.get(base, {})))
        if seeds:
            out[label] = (base, {k: by[label][k] for k in seeds}, {k: by[base][k] for k in seeds})
    return out


def _costs(results: dict) -> dict:
    return {k: v["mpc_cost"] for k, v in results.items()}


def feedback_effect(records: list[dict], level: float = 0.90) -> dict:
    """Per row with both variants: MPC cost with feedback over open loop on the same seed.

    Returns {row: {"ratio_geomean", "ratio_ci90": [lo, hi], "better", "pairs",
    "success_open_loop", "success_feedback"}} (``paired_ratio``; "better": pairs where
    feedback cost less).
    """
    pairs = _variant_pairs(records, lambda p: row_label({**p, "feedback": False}))
    return {base: {**paired_ratio(_costs(fb), _costs(open_loop), level),
                   "success_open_loop": int(sum(v["success"] for v in open_loop.values())),
                   "success_feedback": int(sum(v["success"] for v in fb.values()))}
            for base, fb, open_loop in pairs.values()}


def derivatives_effect(records: list[dict], level: float = 0.90) -> dict:
    """Per row run with a derivative variant (``derivatives_tag``: central differences, key
    timesteps, box QP) or a fix beyond the paper (``fixes_tag``) and without it: the
    variant's MPC cost over the plain row's on the same seeds.

    Returns {row label: {"versus": the plain row's label, "ratio_geomean", "ratio_ci90",
    "better", "pairs" (``paired_ratio``; "better": pairs where the variant cost less),
    "lag_steps_mean", "versus_lag_steps_mean", "opt_ms_mean", "versus_opt_ms_mean" (means
    over the paired trials)}}.
    """
    def plain(p):
        return row_label({**p, **Derivatives().fields(), "keep_costed": False,
                          "mu_reset": False})

    def mean(results, field):
        return float(np.mean([v[field] for v in results.values()]))

    return {label: {"versus": base, **paired_ratio(_costs(var), _costs(ref), level),
                    **{f"{who}{field}": mean(res, field)
                       for field in ("lag_steps_mean", "opt_ms_mean")
                       for who, res in (("", var), ("versus_", ref))}}
            for label, (base, var, ref) in _variant_pairs(records, plain).items()}


def table1_fields(records: list[dict], baseline: str = "baseline") -> dict:
    """Everything a Table 1 summary computes from its trials: "methods" (``summarize``, rows
    in ``TABLE1_ROWS`` order, variants after their row), "paired", "authors_statistic",
    "versus", "lag_cost_tau" (``lag_cost_tau``), "versus_unstable_kept" (``versus`` with the
    episodes flagged unstable kept) where any is, "choice" (``choice.choice_fields``: how
    often each row's C held the goal object) where the trials have active sets, and where
    the trials hold them "feedback_effect" (both feedback settings ran) and
    "derivatives_effect" (a derivative variant ran)."""
    order = {name: i for i, name in enumerate(TABLE1_ROWS)}
    rows = dict(sorted(summarize(records, baseline=baseline).items(),
                       key=lambda kv: (order.get(kv[0].split()[0], 99), kv[0])))
    out = {"methods": rows, "paired": paired(records, baseline=baseline),
           "authors_statistic": authors_statistic(records, baseline=baseline),
           "versus": versus(records)}
    out["lag_cost_tau"] = lag_cost_tau(rows)
    if choice := choice_fields(records, baseline=baseline):
        out["choice"] = choice
    if any(r["result"].get("unstable") for r in records):
        out["versus_unstable_kept"] = versus(records, keep_unstable=True)
    if len({bool(r["params"].get("feedback")) for r in records}) == 2:
        out["feedback_effect"] = feedback_effect(records)
    if variants := derivatives_effect(records):
        out["derivatives_effect"] = variants
    return out


def lag_cost_tau(rows: dict) -> dict:
    """Do the rows' costs order by their lag? Kendall's tau (and its p) between the rows' mean
    lag (steps) and mean normalised cost, over the rows of ``summarize`` that optimise (not
    ``unoptimised``) and have a cost; None for fewer than 3 rows."""
    pts = [(v["lag_steps_mean"], v["mpc_cost_normalised_mean"]) for k, v in rows.items()
           if not k.startswith("unoptimised") and np.isfinite(v["mpc_cost_normalised_mean"])]
    if len(pts) < 3:
        return {"tau": None, "p": None, "rows": len(pts)}
    tau, p = stats.kendalltau(*zip(*pts, strict=True))
    return {"tau": float(tau), "p": float(p), "rows": len(pts)}


def fig4_fields(records: list[dict], method: str, baseline: str = "baseline") -> dict:
    """Everything a Fig. 4 summary computes from its trials: "points", one per (theta, rho)
    of ``method``'s trials in that order, each {"rho", "theta", **``summarize``'s row
    normalised by ``baseline``'s trials}; "versus", every point's row against ``baseline``
    paired by seed, one Holm family over the grid (``versus``); "cost_dofs_r", Pearson's r of
    the points' mean |C| and mean normalised cost (the authors' data: -0.70; None for fewer
    than 3 finite points or a constant coordinate)."""
    base = [r for r in records if r["params"]["method"] == "baseline"]
    mine = [r for r in records if r["params"]["method"] == method]
    points = []
    for theta, rho in sorted({(r["params"]["theta"], r["params"]["rho"]) for r in mine}):
        group = [r for r in mine if r["params"]["rho"] == rho and r["params"]["theta"] == theta]
        points.append(dict(rho=rho, theta=theta, **summarize(base + group, baseline=baseline)[
            row_label(group[0]["params"])]))
    pts = [(p["n_dofs_mean"], p["mpc_cost_normalised_mean"]) for p in points
           if np.isfinite(p["mpc_cost_normalised_mean"])]
    xs, ys = np.asarray(pts, dtype=float).reshape(-1, 2).T
    # Pearson's r needs 3 points and neither coordinate constant (undefined otherwise: None)
    r = (float(stats.pearsonr(xs, ys)[0])
         if len(pts) >= 3 and np.ptp(xs) > 0 and np.ptp(ys) > 0 else None)
    return {"points": points, "versus": versus(base + mine, references=(baseline,)),
            "cost_dofs_r": r}
