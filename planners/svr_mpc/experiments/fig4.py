"""Fig. 4 of the state-vector-reduction paper: MPC cost and mean DoFs against rho, per theta.

Runs svr-sum (or --rule svr-svd) for every (rho, theta) and baseline once per seed for the
normalisation, all as resumable trials under OUT/trials (the MPC flags are experiments/mpc.py's,
``flags.add_run_arguments``).
Writes OUT/summary.json, OUT/rho_sweep.csv and OUT/rho_sweep.png (normalised MPC cost and mean
|C| vs rho, one line per theta, with the authors' curves from --paper-reference; with --record also
copied to docs/images/<record's name>.png, which RESULTS.md shows beside it; summary.json
also holds "trial_commits", the code commits of the trial results). Exits 1 if a trial failed
(listed under "failed" in summary.json) or the run failed (one line on stderr); 2 on a bad
flag. The authors' grid under their protocol:

    python experiments/rho_sweep.py --task clutter --preset paper \\
        --rhos 0,0.1,0.5,1,5,10,20,50,100,500,1e6 --thetas 0,5,10 --trials 20 --workers 2 \\
        --paper-reference docs/results/paper-svr.json --out docs/results/runs/fig4-clutter \\
        --record docs/results/fig4-clutter.json
"""

from __future__ import annotations

import argparse
import csv
import json
from pathlib import Path

import numpy as np

from dopt import atomic
from dopt.lab.cli import EPILOG, ArgumentParser, guarded, number_list
from dopt.lab.console import print_outputs, sweep_session
from dopt.lab.record import record_figure, write_summary
from planners.svr_mpc import fig4_fields, row_label
from planners.svr_mpc.experiments import flags, mapping, runner


def parser() -> argparse.ArgumentParser:
    ap = ArgumentParser(prog="rho_sweep.py", description=__doc__, epilog=EPILOG,
                        formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rhos", type=number_list(float, 0.0, "rhos"), default="0.1,1,10,100",
                    help="comma-separated rho values, each >= 0 (default %(default)s)")
    ap.add_argument("--thetas", type=number_list(int, 0, "thetas"), default="0,5,10",
                    help="comma-separated theta values, integers >= 0 (default %(default)s)")
    ap.add_argument("--rule", default="svr-sum", choices=["svr-sum", "svr-svd"],
                    help="SVR importance rule (default %(default)s)")
    flags.add_alias(ap, "--method", "--rule")
    ap.add_argument("--paper-reference", type=Path, default=None, metavar="PATH",
                    help="the authors' data (experiments/paper_reference.py's file, e.g. "
                         "docs/results/paper-svr.json) drawn beside ours")
    flags.add_run_arguments(ap)
    return ap


def paper_reference(path: Path | None, task: str) -> dict | None:
    """The "tasks" of the authors' data file at ``path`` (None: none given), read and checked
    before any trial runs: ValueError, naming the file and what is wrong, for a file that
    cannot be read, is not JSON or has no Fig. 4 points that ``plot`` can draw for ``task``."""
    if path is None:
        return None
    try:
        tasks = json.loads(Path(path).read_text())["tasks"]
        points = tasks.get(task, {}).get("fig4", [])
        bad = [p for p in points if not all(
            isinstance(p.get(k), (int, float)) and not isinstance(p.get(k), bool)
            for k in ("theta", "rho", "median_ratio", "avg_dofs"))]
    except (OSError, UnicodeDecodeError, ValueError, KeyError, TypeError, AttributeError) as e:
        raise ValueError(f"{path} is not experiments/paper_reference.py's file "
                         f"({type(e).__name__}: {e})") from None
    if bad:
        raise ValueError(f"{path}: {len(bad)} of the {task} Fig. 4 points lack a number for "
                         f"theta, rho, median_ratio or avg_dofs (e.g. {bad[0]})")
    return tasks


@guarded("rho_sweep.py")
def main(argv=None) -> int:
    """``python experiments/rho_sweep.py``: its exit status (module docstring)."""
    ap = parser()
    args = flags.parse_args(argv, ap, one_feedback=True)
    try:                  # the authors' curves are drawn after the sweep: read them first
        paper = paper_reference(args.paper_reference, args.task)
    except ValueError as e:
        ap.error(f"argument --paper-reference: {e}")
    with sweep_session(args.out, args.verbose):   # a second run on this --out refuses at once
        return _main(args, paper, argv)


def _main(args, paper: dict | None, argv) -> int:
    """The run of ``main`` once its flags (and the authors' data) are checked."""
    args.rho, args.theta = 1.0, None          # make_trials' defaults; the grid overrides them
    trials = mapping.make_trials(args, rules=["baseline"]) + mapping.make_trials(
        args, rules=[args.rule], rhos=args.rhos, thetas=args.thetas)
    # scene by scene (the sort is stable): a sweep stopped part way has every point of the
    # grid, and its baseline, on the same first scenes
    trials.sort(key=lambda t: t.params["seed"])
    recs, res = runner.run(args, trials)
    failed = res.failed
    fields = fig4_fields(recs, args.rule, baseline=mapping.baseline_label(args))
    rows = fields["points"]
    write_summary({"experiment": "fig4", "task": args.task, "method": args.rule,
                   **mapping.protocol(args, trials[0].params),
                   # every SVRMPCSettings field of each row (the trials' params less the seed)
                   "settings": {row_label(t.params): {k: v for k, v in t.params.items()
                                                      if k != "seed"} for t in trials},
                   **fields, "failed": failed, "trial_commits": res.commits},
                  args.out, args.record, "experiments/rho_sweep.py", argv)
    if rows:
        with atomic.writing(args.out / "rho_sweep.csv") as tmp, \
                open(tmp, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
        plot(rows, args.thetas, args.out / "rho_sweep.png", args.task, args.rule, paper)
        record_figure(args.out / "rho_sweep.png", args.record)
    print_outputs(args.out, ["rho_sweep.png", "rho_sweep.csv"])
    return 1 if failed else 0


def plot(rows, thetas, path, task, method, paper: dict | None = None) -> None:
    """Cost / baseline and mean |C| against rho, one colour per theta: our mean with its 90 %
    CI band and our median ratio (dotted); with ``paper`` (the "tasks" of
    experiments/paper_reference.py's file) the authors' median ratio and DoFs (dashed)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4))
    theirs = (paper or {}).get(task, {}).get("fig4", [])
    for i, theta in enumerate(thetas):
        colour = plt.get_cmap("tab10")(i)
        pts = sorted((r for r in rows if r["theta"] == theta), key=lambda r: r["rho"])
        x = np.array([r["rho"] for r in pts], dtype=float)
        y = np.array([r["mpc_cost_normalised_mean"] for r in pts], dtype=float)
        e = np.array([r["mpc_cost_normalised_ci90"] for r in pts], dtype=float)
        a.plot(x, y, marker="o", color=colour, label=f"theta {theta}: mean, 90 % CI")
        a.fill_between(x, y - e, y + e, color=colour, alpha=0.15)
        a.plot(x, [r["mpc_cost_median_ratio"] for r in pts], ls=":", marker=".",
               color=colour, label=f"theta {theta}: median ratio")
        b.plot(x, [r["n_dofs_mean"] for r in pts], marker="o", color=colour,
               label=f"theta {theta}")
        ref = sorted((p for p in theirs if p["theta"] == theta), key=lambda p: p["rho"])
        if ref:
            a.plot([p["rho"] for p in ref], [p["median_ratio"] for p in ref], ls="--",
                   color=colour, label=f"theta {theta}: authors' median ratio")
            b.plot([p["rho"] for p in ref], [p["avg_dofs"] for p in ref], ls="--",
                   color=colour, label=f"theta {theta}: authors'")
    for ax, label in ((a, "MPC cost / baseline"), (b, "mean |C|")):
        ax.set_xscale("symlog", linthresh=0.1)
        ax.set_xlabel("rho")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    a.axhline(1.0, color="k", lw=0.5)
    fig.suptitle(f"{task}: {method}")
    fig.tight_layout()
    with atomic.writing(path) as tmp:
        fig.savefig(tmp, dpi=120)
    plt.close(fig)
