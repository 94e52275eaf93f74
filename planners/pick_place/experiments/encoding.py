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
        --seeds 5 --out docs/results/runs/fig7-encoding-diagonal \\
        --record docs/results/fig7-encoding-diagonal.json
"""

from __future__ import annotations

import argparse
import functools
import sys
import time
from dataclasses import replace

from fig7_scaling import plot
from pick_sweep import SCHEMA, cem_trial, describe_result, iterations_held

from dopt.lab.cli import (
    EPILOG,
    ArgumentParser,
    choices_type,
    guarded,
    number_list,
    output_dir,
    output_file,
    positive_float,
    positive_int,
)
from dopt.lab.console import print_outputs, run_with_console, sweep_session
from dopt.lab.record import check_outputs, record_figure, settings_dict, write_summary
from dopt.rollout import share_cores
from planners.pick_place.drag_settings import DragSettings
from planners.pick_place.encoding import (
    BASE,
    SIDE,
    encoding_settings,
    encoding_summary,
    encoding_trials,
)


def parser() -> argparse.ArgumentParser:
    """The flags of the module docstring."""
    d = DragSettings()
    ap = ArgumentParser(prog="fig7_encoding.py", description=__doc__, epilog=EPILOG,
                        formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--goal", choices=("diagonal", "side"), required=True,
                    help="the cloth fold")
    ap.add_argument("--points", type=number_list(int, 4, "points"),
                    default="100,400,1600,10000",
                    help="candidate counts N (perfect squares), comma-separated "
                         "(default %(default)s)")
    ap.add_argument("--seeds", type=positive_int, default=5,
                    help="seeds 0 .. SEEDS-1 per method and N (default %(default)s)")
    ap.add_argument("--methods", type=choices_type(tuple(BASE), "methods"),
                    default=",".join(BASE), help="comma-separated subset of " + ", ".join(BASE))
    ap.add_argument("--population", type=positive_int, default=d.population,
                    help="CEM samples per iteration (default %(default)s; the authors' 333)")
    ap.add_argument("--iterations", type=positive_int, default=d.iterations,
                    help="CEM iterations (default %(default)s)")
    ap.add_argument("--substeps", type=positive_int, default=d.substeps,
                    help="MuJoCo steps per 1 cm substep (default %(default)s)")
    ap.add_argument("--cost", choices=("best", "final"), default="best",
                    help="a plan's cost: its best decision (the authors') or after the whole "
                         "plan (default %(default)s)")
    ap.add_argument("--side", type=positive_float, default=SIDE,
                    help="the sheet's side in m (default %(default)s: SoftGym's 100 x 100)")
    ap.add_argument("--workers", type=positive_int, default=1,
                    help="trials at once (processes; default 1)")
    ap.add_argument("--out", type=output_dir, default=None,
                    help="the run's folder (default results/fig7_encoding_<goal>)")
    ap.add_argument("--record", type=output_file, default=None,
                    help="also write the summary here (committed code only)")
    ap.add_argument("--fresh", action="store_true", help="recompute every trial")
    ap.add_argument("-v", "--verbose", action="store_true")
    return ap


def parse(argv=None) -> argparse.Namespace:
    """Parsed flags; exit 2 with one line on a bad one."""
    ap = parser()
    args = ap.parse_args(argv)
    if "simple-drag" not in args.methods:
        ap.error("argument --methods: the gains are against simple-drag, which it must name")
    try:
        args.drag = DragSettings(population=args.population, iterations=args.iterations,
                                 substeps=args.substeps,
                                 best_over_trajectory=args.cost == "best")
        for n in args.points:
            replace(args.drag, n_points=n)
    except (TypeError, ValueError) as e:
        ap.error(f"argument --points/--population: {e}")
    check_outputs(ap, args, f"fig7_encoding_{args.goal}")
    return args


def main(argv=None) -> int:
    """The run of the module docstring; the exit code."""
    return guarded("fig7_encoding.py")(_main)(argv)


def _main(argv=None) -> int:
    args = parse(argv)
    with sweep_session(args.out, args.verbose):
        return _experiment(args, argv)


def _experiment(args, argv) -> int:
    """The sweep, the summary, the plot and the printed verdict."""
    start, out = time.perf_counter(), args.out
    threads = share_cores(args.workers)
    trials = encoding_trials(args.goal, args.points, range(args.seeds), args.methods,
                             args.drag, args.side, threads)
    settings = {n: encoding_settings(args.goal, replace(args.drag, n_points=n), args.side,
                                     threads) for n in args.points}
    res = run_with_console(
        functools.partial(cem_trial, blowup_out=str(out)), trials, out, unit="it",
        desc="CEM iterations", workers=args.workers, fresh=args.fresh, schema=SCHEMA,
        steps=lambda t: args.iterations,
        held=lambda t: iterations_held([t], args.iterations, out),
        describe=describe_result)
    keys = {t.key for t in trials}
    stats = encoding_summary([r for k, r in res.records.items() if k in keys], args.points)
    summary = {"experiment": "fig7_encoding", "task": "cloth", "goal": args.goal,
               "protocol": "paper", "encoding": "drag", "points": list(args.points),
               "seeds": list(range(args.seeds)), "methods_run": list(args.methods),
               "settings": {str(n): settings_dict(s) for n, s in settings.items()},
               "physics": {str(n): s.resolved_physics() for n, s in settings.items()},
               **stats, "failed": res.failed, "trial_commits": res.commits,
               "wall_s": time.perf_counter() - start}
    write_summary(summary, out, args.record, "experiments/fig7_encoding.py", argv)
    if plot(out / "encoding.png", stats, args.goal):
        record_figure(out / "encoding.png", args.record)
    print(f"{args.goal}, drag encoding: {stats['verdict']}")
    print(f"wrote {out}/summary.json")
    for key, err in res.failed.items():
        print(f"FAILED {key}: {err}", file=sys.stderr)
    print_outputs(out, ["encoding.png"])
    return 1 if res.failed else 0


if __name__ == "__main__":
    sys.exit(main())
