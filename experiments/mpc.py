"""Table 1 of the state-vector-reduction paper: asynchronous MPC with iLQR-SVR and baselines.

Each trial is one real-time MPC episode of one method on one task instance (seed); every
finished trial is written to OUT/trials/<key>.json at once and a rerun skips it. Trials run
inline (--workers 1, the default: on a 2-core machine parallel real-time trials would steal
each other's cores and distort the very timing the paper measures), on a local process pool
(--workers N), or on Ray (--ray [ADDRESS]; a local instance without ADDRESS).

Writes OUT/summary.json ({"task", "methods": {name: {"mpc_cost_normalised_mean",
"mpc_cost_normalised_ci90", "opt_ms_mean", "dofs_mean", "trials", ...}}}), OUT/table1.md
and OUT/table1.csv.

    python experiments/mpc.py --task clutter --trials 20 --out results/mpc_clutter
"""

from __future__ import annotations

import argparse
import csv
import json
import logging
import os
import sys
from pathlib import Path

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from cli_args import choices_list  # noqa: E402
from mpc_trial import (OUTLIER_DISTANCE, TRIAL_DEFAULTS, aggregate,  # noqa: E402
                       feedback_effect, run_trial, trial_key)

TASKS = ("clutter", "soft", "soft_rigid")
METHODS = ("baseline", "rand", "naive", "svr-sum", "svr-svd")
FEEDBACK = {"off": (False,), "on": (True,), "both": (False, True)}


def parse_args(argv=None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--task", default="clutter", help=f"one of {TASKS} (default %(default)s)")
    ap.add_argument("--methods", default=",".join(METHODS),
                    help="comma-separated DoF-selection methods (default: all five)")
    ap.add_argument("--rho", type=float, default=TRIAL_DEFAULTS["rho"],
                    help="SVR importance threshold: DoFs below it leave the active set")
    ap.add_argument("--theta", type=int, default=None,
                    help="random DoFs re-added per iteration (svr) / used besides the robot "
                         "(rand); default: the paper's Table 1, rand 5, svr 10")
    ap.add_argument("--trials", type=int, default=20, help="task instances (seeds) per method")
    ap.add_argument("--seed", type=int, default=0, help="first seed; trials use seed..seed+N-1")
    ap.add_argument("--slowdown", type=float, default=None,
                    help="agent wall time per step over dt (default: the task's, see README)")
    ap.add_argument("--timeout", type=int, default=None,
                    help="task timeout Y in agent steps (default: the paper's)")
    ap.add_argument("--feedback", nargs="?", const="on", default="off",
                    choices=["off", "on", "both"],
                    help="execute u + K (x - x_nom) on the measured state (authors: off); "
                         "'both' runs every trial open-loop and with feedback back to back, "
                         "so the pair sees the same machine load (rows 'METHOD +fb')")
    ap.add_argument("--control-noise", type=float, default=0.0,
                    help="Gaussian noise on executed controls, fraction of range (authors: 0.05)")
    ap.add_argument("--workers", type=int, default=1, help="local worker processes")
    ap.add_argument("--ray", nargs="?", const="local", default=None, metavar="ADDRESS",
                    help="run the trials on Ray (local instance if no ADDRESS)")
    ap.add_argument("--threads", type=int, default=None,
                    help="simulation threads per trial (default: all cores, 1 with workers>1)")
    ap.add_argument("--quick", action="store_true",
                    help="smoke run: 1 trial per method, Y = 100 steps")
    ap.add_argument("--out", required=True, help="output folder")
    args = ap.parse_args(argv)
    if args.task not in TASKS:
        ap.error(f"unknown task {args.task!r}; choose from {TASKS}")
    try:
        args.methods = choices_list(args.methods, METHODS, "method(s)")
    except ValueError as e:
        ap.error(str(e))
    if args.rho < 0:
        ap.error("--rho must be >= 0")
    if args.theta is not None and args.theta < 0:
        ap.error("--theta must be >= 0")
    if args.trials < 1:
        ap.error("--trials must be >= 1")
    if args.workers < 1:
        ap.error("--workers must be >= 1")
    if args.quick:
        args.trials, args.timeout = 1, args.timeout or 100
    if args.threads is None:
        args.threads = 1 if (args.workers > 1 or args.ray) else 0
    return args


def make_trials(args, methods=None, rhos=None, thetas=None):
    from dopt.sweep import Trial
    out = []
    for seed in range(args.seed, args.seed + args.trials):
        for method in methods or args.methods:
            for rho in rhos or [args.rho]:
                for theta in thetas or [_theta(args.theta, method)]:
                    for feedback in FEEDBACK[args.feedback]:
                        p = dict(task=args.task, method=method, rho=rho, theta=theta,
                                 seed=seed, slowdown=args.slowdown or _default_slowdown(args.task),
                                 timeout=args.timeout or 0, threads=args.threads,
                                 feedback=feedback, control_noise=args.control_noise)
                        out.append(Trial(trial_key(p), p))
    return out


def _theta(theta: int | None, method: str) -> int:
    """--theta, or the paper's Table 1 value for the method (rand 5, svr 10; unused else)."""
    from planners.svr import paper_theta
    return paper_theta(method) if theta is None else theta


def _default_slowdown(task: str) -> float:
    from dopt.tasks import get_task
    import numpy as np
    return float(get_task(task)(np.random.default_rng(0)).slowdown)


def run(args, trials) -> dict:
    from tqdm import tqdm

    from dopt.sweep import run_sweep
    bar = tqdm(total=len(trials), desc=f"{args.task} trials", unit="trial")
    res = run_sweep(run_trial, trials, args.out, workers=args.workers, ray_address=args.ray,
                    progress=lambda key, rec: bar.update(1))
    bar.update(len(res.skipped))
    bar.close()
    if res.failed:
        for key, err in res.failed.items():
            print(f"FAILED {key}: {err}", file=sys.stderr)
    return res.records


def write_table(out: Path, task: str, methods: dict, feedback: dict | None = None) -> None:
    rows = [("method", "MPC cost (normalised) mean", "CI90 +-", "median (all)",
             "opt. time (ms)", "DoFs", "lag (steps)", "success", "goal dist. (m, median)",
             "outliers", "trials")]
    def num(x, digits=2):
        """A number to the table, or n/a when there is none (no baseline for the pairing)."""
        return "n/a" if x is None or x != x else f"{x:.{digits}f}"

    for name, m in methods.items():
        rows.append((name, num(m["mpc_cost_normalised_mean"]),
                     num(m["mpc_cost_normalised_ci90"]),
                     num(m["mpc_cost_normalised_median"]), f"{m['opt_ms_mean']:.0f}",
                     f"{m['dofs_mean']:.1f}", f"{m['lag_steps_mean']:.0f}",
                     f"{m['success_rate']:.2f}", f"{m['goal_distance_end_median']:.3f}",
                     str(m["outliers"]), str(m["trials"])))
    with open(out / "table1.csv", "w", newline="") as f:
        csv.writer(f).writerows(rows)
    lines = [f"Task: {task}. Normalised by baseline on the same instance; mean and 90% CI "
             f"exclude outliers (goal object > {OUTLIER_DISTANCE} m from the goal).", "",
             "| " + " | ".join(rows[0]) + " |", "|" + "---|" * len(rows[0])]
    lines += ["| " + " | ".join(r) + " |" for r in rows[1:]]
    if feedback:
        lines += ["", "Feedback vs open loop, paired by seed (MPC cost ratio, geometric mean and "
                  "90% CI; pairs where feedback cost less; successes open loop -> feedback):",
                  "", "| method | cost ratio | CI90 | feedback better | successes |",
                  "|---|---|---|---|---|"]
        lines += [f"| {name} | {f['ratio_geomean']:.2f} | {f['ratio_ci90'][0]:.2f}-"
                  f"{f['ratio_ci90'][1]:.2f} | {f['better']}/{f['pairs']} | "
                  f"{f['success_open_loop']} -> {f['success_feedback']} |"
                  for name, f in feedback.items()]
    (out / "table1.md").write_text("\n".join(lines) + "\n")


def main(argv=None) -> int:
    logging.basicConfig(level=logging.WARNING)
    args = parse_args(argv)
    out = Path(args.out)
    trials = make_trials(args)
    records = run(args, trials)
    wanted = {t.key for t in trials}
    methods = aggregate([r for k, r in records.items() if k in wanted],
                        baseline="baseline +fb" if args.feedback == "on" else "baseline")
    order = {m: i for i, m in enumerate(METHODS)}
    methods = dict(sorted(methods.items(),
                          key=lambda kv: (order.get(kv[0].split()[0], 99), kv[0])))
    summary = {"task": args.task, "rho": args.rho,
               "theta": {m: _theta(args.theta, m) for m in args.methods},
               "slowdown": trials[0].params["slowdown"], "methods": methods}
    if args.feedback == "both":
        summary["feedback_effect"] = feedback_effect(
            [r for k, r in records.items() if k in wanted])
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    write_table(out, args.task, methods, summary.get("feedback_effect"))
    print((out / "table1.md").read_text())
    return 0


if __name__ == "__main__":
    sys.exit(main())
