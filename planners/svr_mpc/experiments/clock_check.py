"""The virtual clock against the real one: the same trials (rows x seeds) under both clocks.

The real clock runs each trial alone in real time on ``--real-threads`` simulation threads
(default 2, this machine's cores: run it on an idle machine); the virtual clock runs each trial
on one thread and divides its CPU time by ``--nominal-threads`` (default 2). Both use the rest
of mpc.py's flags (``--preset paper`` for the authors' protocol). Trials are resumable files
under OUT/real/trials and OUT/virtual/trials.

Writes OUT/summary.json (experiment "clock_check", with the seeds): per row and clock the mean
lag (agent steps per optimisation), mean optimisation time, MPC cost mean and 90 % CI; the
ratios virtual / real of the mean lag and of the mean optimisation time; whether the lag ratio
is within 10 % of 1 and whether the two cost intervals overlap. Exits 1 if a trial failed, 2
on a bad flag.

    python experiments/clock_check.py --task clutter --preset paper \\
        --rows baseline,rand-t5,sum-t10-r1 --trials 10 --out results/clock_check \\
        --record docs/results/clock-check-clutter.json
"""

from __future__ import annotations

import argparse
from dataclasses import replace

import numpy as np

from dopt.lab.cli import EPILOG, ArgumentParser, guarded, positive_int
from dopt.lab.console import print_outputs, sweep_session
from dopt.lab.record import write_summary
from dopt.lab.stats import mean_ci
from dopt.lab.sweep import Trial
from planners.svr_mpc import row_label
from planners.svr_mpc.experiments import flags, mapping, runner
from planners.svr_mpc.trial_names import legacy_trial_key

DEFAULT_ROWS = ("baseline", "rand-t5", "sum-t10-r1")


def parser() -> argparse.ArgumentParser:
    ap = ArgumentParser(prog="clock_check.py", description=__doc__, epilog=EPILOG,
                        formatter_class=argparse.RawDescriptionHelpFormatter)
    flags.add_rows_argument(ap, DEFAULT_ROWS)
    ap.add_argument("--real-threads", type=positive_int, default=2,
                    help="simulation threads of the real-clock trials (default %(default)s)")
    flags.add_run_arguments(ap)
    return ap


def clock_trials(args, clock: str) -> list[Trial]:
    """Every (seed, row) trial under ``clock`` (real: --real-threads threads; virtual: one),
    its key the trial's name and its threads (they set a real clock's wall time)."""
    threads = args.real_threads if clock == "real" else 1
    return [Trial(t.key + f"-threads{threads}", t.params)
            for t in mapping.make_trials(args, clock=clock, threads=threads)]


def clock_aliases(params: dict) -> tuple[str, ...]:
    """The older key a clock check's trial of ``params`` may be stored under: its
    ``legacy_trial_key`` and its threads (``SCHEMA``'s aliases)."""
    return (f"{legacy_trial_key(params)}-threads{params['threads']}",)


#: the MPC trials' schema (``runner.SCHEMA``), their older keys naming the threads too
SCHEMA = replace(runner.SCHEMA, aliases=clock_aliases)


def compare(records: dict[str, list[dict]], nominal_threads: float) -> dict:
    """Per row: each clock's lag, optimisation time and cost statistics, the ratios, and the
    real run's speed-up over one thread (one thread's CPU time, the virtual optimisation time
    x ``nominal_threads``, over the real wall time): the nominal thread count at which the
    virtual clock would match the real one."""
    out: dict = {}
    for clock, recs in records.items():
        for r in recs:
            out.setdefault(row_label(r["params"]), {}).setdefault(clock, []).append(r["result"])
    rows = {}
    for row, by in out.items():
        stats = {}
        for clock, res in by.items():
            cost_mean, cost_ci = mean_ci([v["mpc_cost"] for v in res], 0.90)
            stats[clock] = {"n_trials": len(res),
                            "lag_steps_mean": float(np.mean([v["lag_steps_mean"] for v in res])),
                            "opt_ms_mean": float(np.mean([v["opt_ms_mean"] for v in res])),
                            "mpc_cost_mean": cost_mean, "mpc_cost_ci90": cost_ci}
        if {"real", "virtual"} <= set(stats):
            r, v = stats["real"], stats["virtual"]
            lag = v["lag_steps_mean"] / r["lag_steps_mean"]
            stats["lag_ratio"] = lag
            stats["opt_ms_ratio"] = v["opt_ms_mean"] / r["opt_ms_mean"]
            stats["real_speedup"] = nominal_threads * stats["opt_ms_ratio"]
            stats["lag_within_10_percent"] = bool(abs(lag - 1) <= 0.10)
            stats["cost_intervals_overlap"] = bool(
                abs(v["mpc_cost_mean"] - r["mpc_cost_mean"])
                <= v["mpc_cost_ci90"] + r["mpc_cost_ci90"])
        rows[row] = stats
    return rows


@guarded("clock_check.py")
def main(argv=None) -> int:
    """``python experiments/clock_check.py``: its exit status (module docstring)."""
    ap = parser()
    args = flags.parse_args(argv, ap, one_feedback=True)
    with sweep_session(args.out, args.verbose):   # a second run on this --out refuses at once
        return _main(args, argv)


def _main(args, argv) -> int:
    """The run of ``main`` once its flags are checked and it holds its folder."""
    trials = {clock: clock_trials(args, clock) for clock in ("real", "virtual")}
    records, failed, commits = {}, {}, {}
    for clock, these in trials.items():
        records[clock], res = runner.run(args, these, out=args.out / clock, workers=1,
                                         schema=SCHEMA)
        failed.update(res.failed)
        commits[clock] = res.commits
    write_summary({"experiment": "clock_check", "task": args.task,
                   **mapping.protocol(args, trials["virtual"][0].params),
                   "real_threads": args.real_threads,
                   "seeds": sorted({t.params["seed"] for t in trials["virtual"]}),
                   "rows": compare(records, trials["virtual"][0].params["nominal_threads"]),
                   "failed": failed, "trial_commits": commits},
                  args.out, args.record, "experiments/clock_check.py", argv)
    print(f"wrote {args.out / 'summary.json'}")
    print_outputs(args.out, view=args.out / "virtual")
    return 1 if failed else 0
