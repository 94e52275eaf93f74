"""The gain of key particles against the candidate count under the authors' drag encoding
(issue 89, item 2): a Fig. 7 cloth fold planned by CEM(Original), CEM(Simple) and CEM(Random)
in T short drags whose pick is an index scalar over N + 2 nodes, on one 20 x 20 physics mesh
with N virtual candidate points (``planners.pick_place.encoding``, ``planners.pick_place.drag``).

The trials run through ``dopt.lab.sweep`` into OUT/trials (a rerun resumes finished trials; a
drag trial is not checkpointed inside). The statistics are the library's
(``encoding_summary``): per N and method the mean final cost with its 95 % interval, the
paired Original - Simple and Random - Simple differences, and the trend of each against
log N (OLS slope, Holm over the two), whose verdict is printed.

Writes OUT/summary.json (experiment "fig7_encoding": the settings of every N in full, the
statistics, the failures, the provenance), OUT/encoding.png where matplotlib is installed
(with --record also copied beside the record). Exits 1 if a trial failed, 2 on bad flags.

    python experiments/fig7_encoding.py --goal diagonal --points 100,400,1600,10000 \\
        --trials 5 --out docs/results/runs/fig7-encoding-diagonal \\
        --record docs/results/fig7-encoding-diagonal.json
"""

from __future__ import annotations

import argparse
import functools
import sys
import time
from dataclasses import replace

from dopt.lab.cli import (
    EPILOG,
    ArgumentParser,
    choices_type,
    nonneg_int,
    number_list,
    output_dir,
    output_file,
    positive_float,
    positive_int,
)
from dopt.lab.console import print_outputs, run_with_console, sweep_main
from dopt.lab.flags import SettingsFlags, add_alias, apply, common_settings
from dopt.lab.record import (
    add_reuse_argument,
    check_outputs,
    record_figure,
    reuse_mode,
    settings_dict,
    write_summary,
)
from dopt.rollout import share_cores
from planners.pick_place.drag_settings import DragSettings
from planners.pick_place.encoding import (
    BASE,
    SIDE,
    encoding_settings,
    encoding_summary,
    encoding_trials,
)
from planners.pick_place.experiments.scaling import plot
from planners.pick_place.experiments.sweep import (
    SCHEMA,
    cem_trial,
    describe_result,
    iterations_held,
)

#: candidate counts N by default, and with --quick (a smoke run)
DEFAULT_POINTS, QUICK_POINTS = "100,400,1600,10000", "4,9"
#: trials per method and N by default
DEFAULT_TRIALS = 5
#: the DragSettings of --quick (besides its points): CEM's smallest useful budget
QUICK_DRAG = {"population": 8, "iterations": 2}


def summary_drag(data: dict) -> dict:
    """The drag settings of a run's summary.json (a --config file): those common to its
    sizes' settings (``common_settings``), less the candidate count (--points')."""
    common = common_settings(data["settings"])
    drag = {k.removeprefix("drag."): v for k, v in common.items() if k.startswith("drag.")}
    drag.pop("n_points", None)
    return drag


def drag_flags() -> SettingsFlags:
    """The flags of the drag encoding's CEM budget and substeps, derived from
    ``DragSettings``, with --config (``DragSettings`` fields; a run's summary gives its
    drag settings, ``summary_drag``)."""
    d = DragSettings()
    return SettingsFlags(DragSettings, ["population", "iterations", "substeps"],
                         defaults=lambda path: str(getattr(d, path)), summary=summary_drag)


def parser() -> argparse.ArgumentParser:
    """The flags of the module docstring."""
    ap = ArgumentParser(prog="fig7_encoding.py", description=__doc__, epilog=EPILOG,
                        formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--goal", choices=("diagonal", "side"), required=True,
                    help="the cloth fold")
    ap.add_argument("--points", type=number_list(int, 4, "points"), default=None,
                    help="candidate counts N (perfect squares), comma-separated "
                         f"(default {DEFAULT_POINTS}; {QUICK_POINTS} with --quick)")
    ap.add_argument("--trials", type=positive_int, default=None,
                    help="trials per method and N, seeds SEED .. SEED+TRIALS-1 (default "
                         f"{DEFAULT_TRIALS}; 1 with --quick)")
    add_alias(ap, "--seeds", "--trials")
    ap.add_argument("--seed", type=nonneg_int, default=0, help="the first seed (default 0)")
    ap.add_argument("--quick", action="store_true",
                    help=f"smoke-sized run: N {QUICK_POINTS}, CEM population "
                         f"{QUICK_DRAG['population']} and {QUICK_DRAG['iterations']} "
                         "iterations (unless given), one trial (unless --trials)")
    ap.add_argument("--methods", type=choices_type(tuple(BASE), "methods"),
                    default=",".join(BASE), help="comma-separated subset of " + ", ".join(BASE))
    drag_flags().add_to(ap)
    ap.add_argument("--cost", choices=("best", "final"), default=None,
                    help="a plan's cost: its best decision (the authors') or after the whole "
                         "plan (default best, or the --config file's best_over_trajectory)")
    ap.add_argument("--side", type=positive_float, default=SIDE,
                    help="the sheet's side in m (default %(default)s: SoftGym's 100 x 100)")
    ap.add_argument("--workers", type=positive_int, default=1,
                    help="trials at once (processes; default 1)")
    ap.add_argument("--threads", type=nonneg_int, default=0,
                    help="simulation threads per trial (0, the default: the cores shared out "
                         "over the trials that run at once)")
    ap.add_argument("--out", type=output_dir, default=None,
                    help="the run's folder (default results/fig7_encoding_<goal>)")
    ap.add_argument("--record", type=output_file, default=None,
                    help="also write the summary here (committed code only)")
    ap.add_argument("--fresh", action="store_true", help="recompute every trial")
    add_reuse_argument(ap)
    ap.add_argument("-v", "--verbose", action="store_true", help="log the cost of each stage")
    return ap


def parse(argv=None) -> argparse.Namespace:
    """Parsed flags; exit 2 with one line on a bad one."""
    ap = parser()
    args = ap.parse_args(argv)
    if "simple-drag" not in args.methods:
        ap.error("argument --methods: the gains are against simple-drag, which it must name")
    args.points = args.points or number_list(int, 4, "points")(
        QUICK_POINTS if args.quick else DEFAULT_POINTS)
    if args.trials is None:                   # an explicit --trials stands with --quick
        args.trials = 1 if args.quick else DEFAULT_TRIALS
    flags = drag_flags()
    config = flags.config(ap, args)              # DragSettings < --quick < config < flags
    if "n_points" in config:
        ap.error(f"argument --config: {args.config}: n_points is --points' (the candidate "
                 f"counts of the sweep)")
    if args.cost is not None:
        config["best_over_trajectory"] = args.cost == "best"
    try:
        budget = {**(QUICK_DRAG if args.quick else {}), **config, **flags.overrides(args)}
        args.drag = apply(DragSettings(), budget)
        for n in args.points:
            replace(args.drag, n_points=n)
    except (TypeError, ValueError) as e:
        ap.error(f"argument --points/--population: {e}")
    check_outputs(ap, args, f"fig7_encoding_{args.goal}")
    return args


def _experiment(args, argv) -> int:
    """The sweep, the summary, the plot and the printed verdict."""
    start, out = time.perf_counter(), args.out
    threads = args.threads or share_cores(args.workers)
    seeds = range(args.seed, args.seed + args.trials)
    trials = encoding_trials(args.goal, args.points, seeds, args.methods, args.drag,
                             args.side, threads)
    settings = {n: encoding_settings(args.goal, replace(args.drag, n_points=n), args.side,
                                     threads) for n in args.points}
    res = run_with_console(
        functools.partial(cem_trial, blowup_out=str(out)), trials, out, unit="it",
        desc="CEM iterations", workers=args.workers, fresh=args.fresh, schema=SCHEMA,
        reuse=reuse_mode(args), steps=lambda t: args.drag.iterations,
        held=lambda t: iterations_held([t], args.drag.iterations, out),
        describe=describe_result)
    keys = {t.key for t in trials}
    stats = encoding_summary([r for k, r in res.records.items() if k in keys], args.points)
    summary = {"experiment": "fig7_encoding", "task": "cloth", "goal": args.goal,
               "protocol": "paper", "encoding": "drag", "points": list(args.points),
               "seeds": list(seeds), "methods_run": list(args.methods),
               "settings": {str(n): settings_dict(s) for n, s in settings.items()},
               "physics": {str(n): s.resolved_physics() for n, s in settings.items()},
               **stats, "failed": res.failed, "trial_commits": res.commits,
               "wall_s": time.perf_counter() - start}
    write_summary(summary, out, args.record, "experiments/fig7_encoding.py", argv)
    if plot(out / "encoding.png", stats, args.goal,
            xlabel="candidate points N = n x n on one physics mesh (log scale)"):
        record_figure(out / "encoding.png", args.record)
    print(f"{args.goal}, drag encoding: {stats['verdict']}")
    print(f"wrote {out}/summary.json")
    for key, err in res.failed.items():
        print(f"FAILED {key}: {err}", file=sys.stderr)
    print_outputs(out, ["encoding.png"])
    return 1 if res.failed else 0


#: the run of the module docstring, holding OUT's lock and logging; the exit code
main = sweep_main("fig7_encoding.py", parse, _experiment)


if __name__ == "__main__":
    sys.exit(main())
