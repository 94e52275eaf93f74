"""Why the rows of Table 1 differ: which DoFs each method holds over an episode, and the
importance magnitudes that rho cuts.

For each row (``--rows``, default rand-t5, sum-t10-r1, sum-t10-r500, svd-t10-r1) and seed, one
MPC episode under the protocol of ``experiments/mpc.py``'s flags (``--preset authors`` for the
authors' problems, ``--preset paper`` for their protocol on ours) records each optimisation's
active set C and, for SVR, the importance of each DoF in C before the cut, and what shows
whether the optimiser engages: its line-search step alpha, the relative improvement dJ/J, the
regularisation mu, and whether the new nominal trajectory touches the pushed object (under
Eq. 2 the controls reach the cost only through contact). Trials are resumable files under
OUT/trials (one at a time).

Writes OUT/summary.json (experiment "svr_explain"): per row, |C| and the share of the goal
object's planar DoFs in C, each averaged over seeds in ``--bins`` bins of the episode's agent
steps; for SVR rows the importances pooled over optimisations and seeds: counts per decade,
exact zeros, and the shares below 1, in [1, 500) (what raising rho from 1 to 500 removes) and
at or above 500 (what no rho of the paper's grid below 1e6 removes); robot DoFs, never
removed, are left out; the shares of those importances that are 0, in (0, 0.1), [0.1, 1),
[1, 500) and >= 500; per row under "mechanism": the median dJ/J while the goal object is more
than 5 cm from the goal, the shares of accepted optimisations and of nominals in contact, the
median mu, the goal object's median travel and final distance, the median lag against the
horizon T, and whether an optimisation that drops the goal object's DoFs can still move it
(``goal_held_split``: dJ/J with them held and dropped; how often rho 1 cuts them with and
without contact). And OUT/svr_explain.png. Exits 1 if a trial failed, 2 on a bad flag.

    python experiments/svr_explain.py --task clutter --preset authors \\
        --layouts ../shared/external/ilqr_svr/push_mcl_layouts --trials 10 \\
        --out results/svr_explain --record docs/results/svr-explain-clutter-authors.json
"""

from __future__ import annotations

import argparse

import numpy as np

from dopt import atomic
from dopt.lab.cli import EPILOG, ArgumentParser, guarded, positive_int
from dopt.lab.console import print_outputs, sweep_session
from dopt.lab.record import write_summary
from dopt.lab.stats import median_or_none
from dopt.lab.sweep import Schema
from planners.svr_mpc import row_label, run_svr_mpc, split_params
from planners.svr_mpc.experiments import flags, mapping, runner
from planners.svr_mpc.trial_names import trial_aliases, trial_identity

DEFAULT_ROWS = ("rand-t5", "sum-t10-r1", "sum-t10-r500", "svd-t10-r1")
#: importance decades counted: 10^k <= v < 10^(k+1) for k in DECADES (and the ends beyond)
DECADES = tuple(range(-6, 7))
RHO_CUTS = (1.0, 500.0)
#: what a stored trial must hold to be reused: the fields ``summarize_rows`` and
#: ``mechanism`` read (a record of an older explain_trial lacks some: it is recomputed)
SCHEMA = Schema(result=("steps", "opt_step", "n_dofs", "goal_share", "goal_importance",
                        "importance",
                        "rel_improvement", "goal_distance_at_opt", "alpha", "contact_steps",
                        "mu", "travel", "goal_distance_end", "lag_steps_mean", "horizon"),
                identity=trial_identity, aliases=trial_aliases)


def parser() -> argparse.ArgumentParser:
    ap = ArgumentParser(prog="svr_explain.py", description=__doc__, epilog=EPILOG,
                        formatter_class=argparse.RawDescriptionHelpFormatter)
    flags.add_rows_argument(ap, DEFAULT_ROWS)
    ap.add_argument("--bins", type=positive_int, default=10,
                    help="bins of the episode's agent steps for the timelines (default "
                         "%(default)s)")
    flags.add_run_arguments(ap)
    return ap


def explain_trial(params: dict, report=None, keep_controls: bool = False) -> dict:
    """One episode with its optimisations' sets and importances, reduced to per-optimisation
    records (start step, |C|, share of the goal object's planar DoFs in C, the line-search
    step alpha, the relative improvement dJ/J, the regularisation mu, the nominal's states in
    contact with the pushed object, the goal object's distance to the goal when it started),
    the goal object's travel and the importance counts, beside the episode's own result
    (``SVRMPCResult.to_dict``: what dopt-view shows; with ``keep_controls`` its start state
    and controls, for the exact replay). ``report`` (the sweep's) is called after every agent
    step."""
    from dopt.tasks.push.task_model import planar_dofs

    settings, seed, optimiser = split_params(params)
    history: list = []
    result = run_svr_mpc(settings, seed, history=history, on_step=report, optimiser=optimiser,
                         keep_controls=keep_controls)
    task = settings.build_task(seed)
    goal = planar_dofs(task.model, task.goal_bodies)
    robot = set(task.robot_dofs.tolist())
    values = [v for h in history if h["importance"] is not None
              for d, v in zip(h["dofs"], h["importance"], strict=True) if d not in robot]
    stride = result.goal_distance_stride
    at_start = [result.goal_distance[min(s // stride, len(result.goal_distance) - 1)]
                for s in result.opt_step]
    return {**result.to_dict(), "travel": goal_travel(task, result.final_state),
            "horizon": task.horizon,
            "goal_share": [round(float(np.isin(goal, h["dofs"]).mean()), 4) for h in history],
            "goal_importance": [goal_importances(h, goal) for h in history],
            "alpha": [h["alpha"] for h in history],
            "rel_improvement": [(h["cost_before"] - h["cost_after"]) / abs(h["cost_before"])
                                if h["cost_before"] else 0.0 for h in history],
            "mu": [h["mu"] for h in history],
            "contact_steps": [h["contact_steps"] for h in history],
            "goal_distance_at_opt": at_start, "importance": importance_counts(values)}


def goal_importances(h: dict, goal) -> list[float] | None:
    """The importances (before the cut) of the goal object's planar DoFs that one optimisation
    ``h`` held in C, in ``goal``'s order ([] when it held none); None for an optimisation
    without importances (not SVR)."""
    if h["importance"] is None:
        return None
    of = dict(zip(h["dofs"], h["importance"], strict=True))
    return [float(of[d]) for d in goal if d in of]


def goal_importance_summary(results: list[dict]) -> dict | None:
    """Per row, from each optimisation that held all the goal object's planar DoFs (as many as
    its episode's most: SVR's first optimisation holds every DoF): the least of their
    importances (the first that rho cuts), at each episode's first optimisation and at the
    later ones; and the share of later optimisations that held them all. None without
    importances (not SVR, or trials recorded before the field)."""
    lists = [r.get("goal_importance") for r in results]
    lists = [v for v in lists if v and any(x is not None for x in v)]
    if not lists:
        return None
    first, later, n_later = [], [], 0
    for v in lists:
        n_goal = max(len(x) for x in v if x is not None)
        held = [min(x) if x is not None and n_goal and len(x) == n_goal else None for x in v]
        if held[0] is not None:
            first.append(held[0])
        n_later += len(v) - 1
        later += [x for x in held[1:] if x is not None]

    return {"first_median": median_or_none(first), "first_min": min(first, default=None),
            "first_max": max(first, default=None), "later_median": median_or_none(later),
            "later_held_share": len(later) / n_later if n_later else None}


def goal_travel(task, final_state) -> float:
    """How far (m, in x and y) the goal object's centre (a flex: its mean vertex) moved from
    the task's initial state to ``final_state``."""
    import mujoco

    from dopt.state import INTEGRATION

    m = task.model
    d = mujoco.MjData(m)
    xy = []
    for state in (task.initial_state, final_state):
        mujoco.mj_setState(m, d, np.asarray(state, dtype=float), INTEGRATION)
        mujoco.mj_kinematics(m, d)
        xy.append(d.xpos[task.goal_bodies, :2].mean(axis=0))
    return float(np.linalg.norm(xy[1] - xy[0]))


#: the shares of non-robot importances reported: exactly 0, (0, 0.1), [0.1, 1), [1, 500),
#: >= 500 (rho 1 and 500 are Table 1's cuts)
SHARE_BINS = {"zero": (0.0, 0.0), "lt_0.1": (0.0, 0.1), "0.1_to_1": (0.1, 1.0),
              "1_to_500": (1.0, 500.0), "ge_500": (500.0, np.inf)}


def importance_counts(values) -> dict:
    """Counts of importance values: "zero", "below" (0 < v < 10^min), per decade "k" (10^k <= v
    < 10^(k+1)), "above"; the counts below 1, in [1, 500), at or above 500; and per
    ``SHARE_BINS`` (open below for "lt_0.1", closed below elsewhere)."""
    v = np.asarray(values, dtype=float)
    pos = v[v > 0]
    k = np.floor(np.log10(pos)) if len(pos) else np.array([])
    lo, hi = RHO_CUTS
    bins = {"zero": int((v == 0).sum()), "lt_0.1": int(((v > 0) & (v < 0.1)).sum())}
    bins.update({name: int(((v >= a) & (v < b)).sum()) for name, (a, b) in SHARE_BINS.items()
                 if name not in bins})
    return {"n": int(len(v)), "zero": int((v == 0).sum()),
            "below": int((k < DECADES[0]).sum()), "above": int((k > DECADES[-1]).sum()),
            "decades": {str(d): int((k == d).sum()) for d in DECADES},
            "lt_1": int((v < lo).sum()), "1_to_500": int(((v >= lo) & (v < hi)).sum()),
            "ge_500": int((v >= hi).sum()), "bins": bins}


#: the goal object is "away from its goal" (where the optimiser should still be making
#: progress) while farther than this (m)
AWAY = 0.05


def mechanism(results: list[dict]) -> dict:
    """Per row, over every optimisation of its episodes: the median dJ/J while the goal object
    is more than ``AWAY`` from the goal, the share of optimisations accepted (alpha > 0), whose
    nominal touches the pushed object, the median mu; per episode: the median travel of the
    goal object and the median lag (agent steps) against the horizon T; the mean over episodes
    of each episode's mean |C|; the line-search rollouts the stability verdict flagged and the
    executed episodes it flagged."""
    away = [r for res in results for r, d in zip(res["rel_improvement"],
                                                 res["goal_distance_at_opt"], strict=True)
            if d > AWAY]
    alphas = [a for res in results for a in res["alpha"]]
    contact = [c > 0 for res in results for c in res["contact_steps"]]
    mus = [m for res in results for m in res["mu"]]

    return {"rel_improvement_median_away": median_or_none(away), "n_optimisations_away": len(away),
            "accepted_share": float(np.mean([a > 0 for a in alphas])) if alphas else None,
            "contact_share": float(np.mean(contact)) if contact else None,
            "mu_median": median_or_none(mus),
            "travel_median": median_or_none([res["travel"] for res in results]),
            "goal_distance_end_median": median_or_none([res["goal_distance_end"]
                                                        for res in results]),
            "lag_steps_median": median_or_none([res["lag_steps_mean"] for res in results]),
            "n_dofs_mean": float(np.mean([np.mean(res["n_dofs"]) for res in results
                                          if len(res["n_dofs"])])),
            "n_unstable_rollouts": int(sum(res.get("n_unstable_rollouts", 0) for res in results)),
            "n_unstable_episodes": int(sum(bool(res.get("unstable")) for res in results)),
            "horizon": results[0]["horizon"], **goal_held_split(results)}


def goal_held_split(results: list[dict]) -> dict:
    """Per row, whether an optimisation can move the goal object: over the optimisations
    while it is more than ``AWAY`` from the goal, the share whose C holds every planar DoF of
    it and the median dJ/J of those ("held") and of the rest ("dropped"); over every
    optimisation that held them with importances (SVR), the share whose least goal
    importance is below rho 1 (Table 1's cut removes them) among those whose new nominal
    touches the pushed object and among those whose nominal does not. None where no
    optimisation falls in a group."""
    held, dropped = [], []
    cut = {True: [], False: []}
    for res in results:
        imps = res.get("goal_importance") or [None] * len(res["goal_share"])  # older trials
        for share, dj, dist, imp, touch in zip(res["goal_share"], res["rel_improvement"],
                                               res["goal_distance_at_opt"], imps,
                                               res["contact_steps"], strict=True):
            if dist > AWAY:
                (held if share == 1.0 else dropped).append(dj)
            if share == 1.0 and imp:
                cut[touch > 0].append(min(imp) < RHO_CUTS[0])
    n_away = len(held) + len(dropped)
    return {"goal_held_share_away": len(held) / n_away if n_away else None,
            "rel_improvement_median_away_held": median_or_none(held),
            "rel_improvement_median_away_dropped": median_or_none(dropped),
            "goal_cut_share_contact": float(np.mean(cut[True])) if cut[True] else None,
            "goal_cut_share_no_contact": float(np.mean(cut[False])) if cut[False] else None,
            "n_goal_importances": {"contact": len(cut[True]), "no_contact": len(cut[False])}}


def summarize_rows(records: list[dict], bins: int) -> dict:
    """Per row: timelines of |C| and goal share (mean over seeds per bin of agent steps) and
    the pooled importance counts with their shares."""
    by: dict = {}
    for r in records:
        by.setdefault(row_label(r["params"]), []).append(r["result"])
    out = {}
    for row, results in by.items():
        timeout = max(max(r["steps"], 1) for r in results)
        edges = np.linspace(0, timeout, bins + 1)
        n_dofs, share = np.zeros(bins), np.zeros(bins)
        counts = np.zeros(bins)
        for r in results:
            idx = np.clip(np.searchsorted(edges, r["opt_step"], side="right") - 1, 0, bins - 1)
            np.add.at(n_dofs, idx, r["n_dofs"])
            np.add.at(share, idx, r["goal_share"])
            np.add.at(counts, idx, 1)
        with np.errstate(invalid="ignore"):
            n_dofs, share = n_dofs / counts, share / counts
        imp = _pool([r["importance"] for r in results])
        n = max(imp["n"], 1)
        out[row] = {"n_trials": len(results), "bin_edges": edges.tolist(),
                    "mechanism": mechanism(results),
                    "n_dofs": _nan_to_none(n_dofs), "goal_share": _nan_to_none(share),
                    "goal_share_mean": float(np.mean([np.mean(r["goal_share"] or [0])
                                                      for r in results])),
                    "importance": imp,
                    "importance_share": ({k: v / n for k, v in imp["bins"].items()}
                                         if imp["n"] else None)}
        if (goal_imp := goal_importance_summary(results)) is not None:
            out[row]["goal_importance"] = goal_imp
    return out


def _pool(counts: list[dict]) -> dict:
    out = {k: sum(c[k] for c in counts) for k in ("n", "zero", "below", "above", "lt_1",
                                                  "1_to_500", "ge_500")}
    out["decades"] = {d: sum(c["decades"][d] for c in counts) for d in counts[0]["decades"]}
    out["bins"] = {b: sum(c["bins"][b] for c in counts) for b in SHARE_BINS}
    return out


def _nan_to_none(a) -> list:
    return [None if not np.isfinite(x) else float(x) for x in a]


def plot(rows: dict, path, task: str) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b, c) = plt.subplots(1, 3, figsize=(14, 3.8))
    for row, d in rows.items():
        e = np.asarray(d["bin_edges"])
        mid = (e[:-1] + e[1:]) / 2
        a.plot(mid, [np.nan if v is None else v for v in d["n_dofs"]], marker="o", label=row)
        b.plot(mid, [np.nan if v is None else v for v in d["goal_share"]], marker="o",
               label=row)
        imp = d["importance"]
        if imp["n"]:
            decades = [int(k) for k in imp["decades"]]
            c.step(decades, [imp["decades"][str(k)] / imp["n"] for k in decades], where="post",
                   label=f"{row} ({imp['zero'] / imp['n']:.0%} exactly 0)")
    for rho in RHO_CUTS:
        c.axvline(np.log10(rho), color="k", ls="--", lw=1)
    a.set(xlabel="agent step", ylabel="|C|", title=f"{task}: active DoFs")
    b.set(xlabel="agent step", ylabel="share", ylim=(0, 1.05),
          title="goal object's x, y DoFs in C")
    c.set(xlabel="log10 importance (non-robot DoFs)", ylabel="share of values",
          title="importance before the cut (rho 1, 500 dashed)")
    for ax in (a, b, c):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    with atomic.writing(path) as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)


@guarded("svr_explain.py")
def main(argv=None) -> int:
    """``python experiments/svr_explain.py``: its exit status (module docstring)."""
    ap = parser()
    args = flags.parse_args(argv, ap, one_feedback=True)
    with sweep_session(args.out, args.verbose):   # a second run on this --out refuses at once
        return _main(args, argv)


def _main(args, argv) -> int:
    """The run of ``main`` once its flags are checked and it holds its folder."""
    trials = mapping.make_trials(args)
    records, res = runner.run(args, trials, fn=explain_trial, workers=1, schema=SCHEMA)
    rows = summarize_rows(records, args.bins)
    write_summary({"experiment": "svr_explain", "task": args.task,
                   **mapping.protocol(args, trials[0].params), "rows": rows,
                   "failed": res.failed, "trial_commits": res.commits},
                  args.out, args.record, "experiments/svr_explain.py", argv)
    if rows:
        plot(rows, args.out / "svr_explain.png", args.task)
    print_outputs(args.out, ["svr_explain.png"])
    return 1 if res.failed else 0
