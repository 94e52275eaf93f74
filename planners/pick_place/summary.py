"""Summaries of finished pick-and-place trials (the sweep's records, each result
``PickPlaceResult.to_dict()``, as every summarize of the house takes them): per method the
mean, 95 % interval and per-seed values of each metric, the difference to CEM(Simple), and
where each trial's CEM last improved (``summarize``, ``last_improvement``)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from dopt.lab.stats import difference_ci, finite, finite_mean_ci


def summarize(records: Sequence[dict], methods: Sequence[str],
              metric_names: Sequence[str]) -> dict:
    """Per method (in ``methods`` order, those with results): the mean, 95 % CI half-width
    (None with one seed) and per-seed values of each metric, the candidates (last stage and
    per stage), the mean seconds per CEM iteration (None when scripted), the seeds, each
    seed's ``last_improvement`` (None when scripted), the
    rollouts simulated and flagged unstable, and the trials whose executed plan was unstable.
    The means and intervals are over the stable trials only; the per-seed values list every
    trial (``unstable_seeds`` marks the others). Every method beside "simple" also holds each
    metric's difference to CEM(Simple), ``<metric>_minus_simple_mean`` and ``_ci95`` (its mean
    minus Simple's and the Welch 95 % half-width, ``dopt.lab.stats.difference_ci``): whether the
    two differ where their own intervals overlap.

    records: {"params", "result"} of finished trials as ``dopt.lab.sweep`` stores them, each
    result ``PickPlaceResult.to_dict()`` (its own "method" and "seed" group and order them).
    """
    results = [r["result"] for r in records]
    out, stable_values = {}, {}
    for m in methods:
        runs = sorted((r for r in results if r["method"] == m), key=lambda r: r["seed"])
        if not runs:
            continue
        entry: dict = {}
        stable = [r for r in runs if not r["unstable"]]
        for name in metric_names:
            entry[f"{name}_mean"], entry[f"{name}_ci95"] = finite_mean_ci([r[name]
                                                                           for r in stable])
            entry[f"{name}s"] = [r[name] for r in runs]
            stable_values[m, name] = [r[name] for r in stable]
        entry["n_candidates"] = int(runs[0]["n_candidates"][-1])
        entry["n_candidates_per_stage"] = runs[0]["n_candidates"]
        secs = [r["s_per_iteration"] for r in runs if r["s_per_iteration"] is not None]
        entry["s_per_iteration"] = float(np.mean(secs)) if secs else None
        entry["seeds"] = [r["seed"] for r in runs]
        entry["last_improvements"] = [last_improvement(r) for r in runs]
        entry["n"] = len(runs)
        entry["n_stable"] = len(stable)
        entry["n_unstable_trials"] = len(runs) - len(stable)
        entry["unstable_seeds"] = [r["seed"] for r in runs if r["unstable"]]
        entry["n_rollouts"] = int(sum(r["n_rollouts"] for r in runs))
        entry["n_unstable_rollouts"] = int(sum(r["n_unstable_rollouts"] for r in runs))
        entry["n_infeasible_rollouts"] = int(sum(r.get("n_infeasible_rollouts", 0)
                                                 for r in runs))
        out[m] = entry
    for m, entry in out.items():
        for name in metric_names if m != "simple" and "simple" in out else ():
            xs, ys = stable_values["simple", name], stable_values[m, name]
            diff, half = difference_ci(xs, ys) if xs and ys else (None, None)
            entry[f"{name}_minus_simple_mean"] = finite(diff)
            entry[f"{name}_minus_simple_ci95"] = finite(half)
    return out


def last_improvement(result: dict) -> int | None:
    """The CEM iteration (1-based, within the last stage) after which that stage's best cost
    last fell: the stage's iteration count means it was still falling at the end. None for a
    trial without CEM iterations (scripted).

    result: ``PickPlaceResult.to_dict()``."""
    if result.get("s_per_iteration") is None:
        return None
    stages = result["stage_of_iteration"]
    last = [c for c, k in zip(result["cost_history"], stages, strict=True) if k == stages[-1]]
    falls = [i for i in range(1, len(last)) if last[i] < last[i - 1]]
    return (falls[-1] if falls else 0) + 1
