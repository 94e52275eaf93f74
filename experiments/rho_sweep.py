"""Fig. 4 of the state-vector-reduction paper: MPC cost and mean DoFs against rho, per theta.

Runs svr-sum (or --method svr-svd) for every (rho, theta) and baseline once per seed for the
normalisation, all as resumable trials under OUT/trials (the MPC flags are experiments/mpc.py's).
Writes OUT/summary.json, OUT/rho_sweep.csv and OUT/rho_sweep.png (normalised MPC cost and mean
|C| vs rho, one line per theta; summary.json also holds "trial_commits", the code commits of
the trial results). Exits 1 if a trial failed (listed under "failed" in summary.json) or the run
failed (one line on stderr); 2 on a bad flag.

    python experiments/rho_sweep.py --task clutter --rhos 0.1,1,10,100 --thetas 0,5,10 \\
        --trials 5 --out results/rho
"""

from __future__ import annotations

import argparse
import csv
import sys

import mpc as table1
from cli_args import EPILOG, guarded, number_list, write_summary

from planners.svr_mpc import row_name, summarize


def parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="rho_sweep.py", description=__doc__, epilog=EPILOG,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rhos", type=number_list(float, 0.0, "rhos"), default="0.1,1,10,100",
                    help="comma-separated rho values, each >= 0 (default %(default)s)")
    ap.add_argument("--thetas", type=number_list(int, 0, "thetas"), default="0,5,10",
                    help="comma-separated theta values, integers >= 0 (default %(default)s)")
    ap.add_argument("--method", default="svr-sum", choices=["svr-sum", "svr-svd"],
                    help="SVR importance method (default %(default)s)")
    table1.add_run_arguments(ap)
    return ap


@guarded("rho_sweep.py")
def main(argv=None) -> int:
    ap = parser()
    args = table1.parse_args(argv, ap)
    if args.feedback == "both":
        ap.error("--feedback both is for experiments/mpc.py; give on or off here")
    args.rho, args.theta = 1.0, None          # make_trials' defaults; the grid overrides them
    fb = " +fb" if args.feedback == "on" else ""
    trials = table1.make_trials(args, methods=["baseline"]) + table1.make_trials(
        args, methods=[args.method], rhos=args.rhos, thetas=args.thetas)
    recs, res = table1.run(args, trials)
    failed = res.failed
    base = [r for r in recs if r["params"]["method"] == "baseline"]
    rows = []
    for theta in args.thetas:
        for rho in args.rhos:
            group = [r for r in recs if r["params"]["method"] == args.method
                     and r["params"]["rho"] == rho and r["params"]["theta"] == theta]
            if group:
                rows.append(dict(rho=rho, theta=theta,
                                 **summarize(base + group, baseline="baseline" + fb)[
                                     row_name(args.method, theta, rho) + fb]))
    write_summary({"experiment": "fig4", "task": args.task, "method": args.method,
                   "points": rows, "failed": failed, "trial_commits": res.commits},
                  args.out, args.record, "experiments/rho_sweep.py", argv)
    if rows:
        with open(args.out / "rho_sweep.csv", "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
        plot(rows, args.thetas, args.out / "rho_sweep.png", args.task, args.method)
    return 1 if failed else 0


def plot(rows, thetas, path, task, method) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (a, b) = plt.subplots(1, 2, figsize=(9, 3.5))
    for theta in thetas:
        pts = sorted((r for r in rows if r["theta"] == theta), key=lambda r: r["rho"])
        x = [r["rho"] for r in pts]
        y = [r["mpc_cost_normalised_mean"] for r in pts]
        e = [r["mpc_cost_normalised_ci90"] for r in pts]
        a.errorbar(x, y, yerr=e, marker="o", capsize=3, label=f"theta={theta}")
        b.plot(x, [r["dofs_mean"] for r in pts], marker="o", label=f"theta={theta}")
    for ax, label in ((a, "MPC cost / baseline"), (b, "mean |C|")):
        ax.set_xscale("log")
        ax.set_xlabel("rho")
        ax.set_ylabel(label)
        ax.legend()
    a.axhline(1.0, color="k", lw=0.5)
    fig.suptitle(f"{task}: {method}")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
