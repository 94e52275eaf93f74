"""Why the rows of Table 1 differ: which DoFs each method holds over an episode, and the
importance magnitudes that rho cuts.

For each row (``--rows``, default rand-t5, sum-t10-r1, sum-t10-r500, svd-t10-r1) and seed, one
MPC episode under the protocol of ``experiments/mpc.py``'s flags (``--preset paper`` for the
authors') records each optimisation's active set C and, for SVR, the importance of each DoF in
C before the cut. Trials are resumable files under OUT/trials (one at a time).

Writes OUT/summary.json (experiment "svr_explain"): per row, |C| and the share of the goal
object's planar DoFs in C, each averaged over seeds in ``--bins`` bins of the episode's agent
steps; for SVR rows the importances pooled over optimisations and seeds: counts per decade,
exact zeros, and the shares below 1, in [1, 500) (what raising rho from 1 to 500 removes) and
at or above 500 (what no rho of the paper's grid below 1e6 removes); robot DoFs, never
removed, are left out. And OUT/svr_explain.png. Exits 1 if a trial failed, 2 on a bad flag.

    python experiments/svr_explain.py --task clutter --preset paper --trials 10 \\
        --out results/svr_explain --record docs/results/svr-explain-clutter.json
"""

from __future__ import annotations

import argparse
import sys

import mpc as table1
import numpy as np
from cli_args import EPILOG, guarded, positive_int, write_summary

from planners.svr_mpc import SVRMPCSettings, row_label, run_svr_mpc

DEFAULT_ROWS = ("rand-t5", "sum-t10-r1", "sum-t10-r500", "svd-t10-r1")
#: importance decades counted: 10^k <= v < 10^(k+1) for k in DECADES (and the ends beyond)
DECADES = tuple(range(-6, 7))
RHO_CUTS = (1.0, 500.0)


def parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="svr_explain.py", description=__doc__, epilog=EPILOG,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    table1.add_rows_argument(ap, DEFAULT_ROWS)
    ap.add_argument("--bins", type=positive_int, default=10,
                    help="bins of the episode's agent steps for the timelines (default "
                         "%(default)s)")
    table1.add_run_arguments(ap)
    return ap


def explain_trial(params: dict) -> dict:
    """One episode with its optimisations' sets and importances, reduced to per-optimisation
    (start step, |C|, share of the goal object's planar DoFs in C) and importance counts."""
    from dopt.tasks import get_task
    from dopt.tasks.push.task_model import planar_dofs

    p = dict(params)
    seed = p.pop("seed")
    settings = SVRMPCSettings(**p)
    history: list = []
    result = run_svr_mpc(settings, seed, history=history)
    task = get_task(settings.task)(np.random.default_rng(seed))
    goal = planar_dofs(task.model, task.goal_bodies)
    robot = set(task.robot_dofs.tolist())
    values = [v for h in history if h["importance"] is not None
              for d, v in zip(h["dofs"], h["importance"], strict=True) if d not in robot]
    return {"steps": result.steps, "mpc_cost": result.mpc_cost, "success": result.success,
            "goal_distance_end": result.goal_distance_end,
            "opt_step": result.opt_step, "n_dofs": result.n_dofs,
            "goal_share": [round(float(np.isin(goal, h["dofs"]).mean()), 4) for h in history],
            "importance": importance_counts(values)}


def importance_counts(values) -> dict:
    """Counts of importance values: "zero", "below" (0 < v < 10^min), per decade "k" (10^k <= v
    < 10^(k+1)), "above"; and the counts below 1, in [1, 500), at or above 500."""
    v = np.asarray(values, dtype=float)
    pos = v[v > 0]
    k = np.floor(np.log10(pos)) if len(pos) else np.array([])
    lo, hi = RHO_CUTS
    return {"n": int(len(v)), "zero": int((v == 0).sum()),
            "below": int((k < DECADES[0]).sum()), "above": int((k > DECADES[-1]).sum()),
            "decades": {str(d): int((k == d).sum()) for d in DECADES},
            "lt_1": int((v < lo).sum()), "1_to_500": int(((v >= lo) & (v < hi)).sum()),
            "ge_500": int((v >= hi).sum())}


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
                    "n_dofs": _nan_to_none(n_dofs), "goal_share": _nan_to_none(share),
                    "goal_share_mean": float(np.mean([np.mean(r["goal_share"] or [0])
                                                      for r in results])),
                    "importance": imp,
                    "importance_share": ({"lt_1": imp["lt_1"] / n, "1_to_500": imp["1_to_500"]
                                          / n, "ge_500": imp["ge_500"] / n,
                                          "zero": imp["zero"] / n} if imp["n"] else None)}
    return out


def _pool(counts: list[dict]) -> dict:
    out = {k: sum(c[k] for c in counts) for k in ("n", "zero", "below", "above", "lt_1",
                                                  "1_to_500", "ge_500")}
    out["decades"] = {d: sum(c["decades"][d] for c in counts) for d in counts[0]["decades"]}
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
    fig.savefig(path, dpi=110)
    plt.close(fig)


@guarded("svr_explain.py")
def main(argv=None) -> int:
    ap = parser()
    args = table1.parse_args(argv, ap, one_feedback=True)
    trials = table1.make_trials(args)
    records, res = table1.run(args, trials, fn=explain_trial, workers=1)
    rows = summarize_rows(records, args.bins)
    write_summary({"experiment": "svr_explain", "task": args.task,
                   **table1.protocol(args, trials[0].params), "rows": rows,
                   "failed": res.failed, "trial_commits": res.commits},
                  args.out, args.record, "experiments/svr_explain.py", argv)
    if rows:
        plot(rows, args.out / "svr_explain.png", args.task)
    return 1 if res.failed else 0


if __name__ == "__main__":
    sys.exit(main())
