"""Fig. 4 of the state-vector-reduction paper: MPC cost and mean DoFs against rho, per theta.

Runs svr-sum (or --method svr-svd) for every (rho, theta) and baseline once per seed for the
normalisation, all as resumable trials under OUT/trials. Writes OUT/summary.json, OUT/rho_sweep.csv
and OUT/rho_sweep.png (normalised MPC cost and mean |C| vs rho, one line per theta).

    python experiments/rho_sweep.py --task clutter --rhos 0.1,1,10,100 --thetas 0,4,12 --trials 5 --out results/rho
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import sys
from pathlib import Path

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import mpc as table1  # noqa: E402
from mpc_trial import aggregate  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rhos", default="0.1,1,10,100", help="comma-separated rho values")
    ap.add_argument("--thetas", default="0,4,12", help="comma-separated theta values")
    ap.add_argument("--method", default="svr-sum", choices=["svr-sum", "svr-svd"],
                    help="SVR importance method")
    args, rest = ap.parse_known_args(argv)
    rhos = [float(r) for r in args.rhos.split(",")]
    thetas = [int(t) for t in args.thetas.split(",")]
    if any(r < 0 for r in rhos) or any(t < 0 for t in thetas):
        ap.error("rho and theta must be >= 0")
    targs = table1.parse_args(rest + ["--methods", f"baseline,{args.method}"])
    if targs.feedback == "both":
        ap.error("--feedback both is for experiments/mpc.py; give on or off here")
    fb = " +fb" if targs.feedback == "on" else ""
    trials = table1.make_trials(targs, methods=["baseline"]) + table1.make_trials(
        targs, methods=[args.method], rhos=rhos, thetas=thetas)
    records = table1.run(targs, trials)
    wanted = {t.key for t in trials}
    recs = [r for k, r in records.items() if k in wanted]
    base = [r for r in recs if r["params"]["method"] == "baseline"]
    rows = []
    for theta in thetas:
        for rho in rhos:
            group = [r for r in recs if r["params"]["method"] == args.method
                     and r["params"]["rho"] == rho and r["params"]["theta"] == theta]
            if not group:
                continue
            m = aggregate(base + group, baseline="baseline" + fb)[args.method + fb]
            rows.append(dict(rho=rho, theta=theta, **m))
    out = Path(targs.out)
    (out / "summary.json").write_text(json.dumps(
        {"task": targs.task, "method": args.method, "points": rows}, indent=2))
    with open(out / "rho_sweep.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    plot(rows, thetas, out / "rho_sweep.png", targs.task, args.method)
    return 0


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


if __name__ == "__main__":
    sys.exit(main())
