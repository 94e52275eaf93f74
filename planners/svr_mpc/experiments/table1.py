"""Table 1 of the state-vector-reduction paper: asynchronous MPC with iLQR-SVR and baselines.

Each trial is one MPC episode of one Table 1 row (a method with its theta and rho) on one task
instance (seed), run by ``planners.svr_mpc.run_svr_mpc``; every finished trial is written to
OUT/trials/<key>.json at once and a rerun skips it. ``--preset paper`` is the authors'
protocol and runs the nine rows of the paper's Table 1 by name (``--rows`` picks some); its
virtual clock makes a trial's lag its CPU time, so trials may run in parallel. Trials run
inline (--workers 1, the default; with the real clock keep it so: parallel real-time trials
steal each other's cores and distort the very timing the paper measures), on a local process
pool (--workers N), or on Ray (--ray [ADDRESS]; a local instance without ADDRESS).

Writes OUT/summary.json ({"task", the protocol's settings, "row_settings", "methods": {row:
{"mpc_cost_normalised_mean", "mpc_cost_normalised_ci90", "mpc_cost_normalised_median",
"mpc_cost_median_ratio", "opt_ms_mean", "n_dofs_mean", "lag_steps_mean", "success_rate",
"outliers", "n_trials", ...}}, "paired": {row: geometric mean and CI90 of cost / baseline on the
same seed}, "derivatives_effect": {row with a derivative variant such as sum-t10-r1+skip5: its cost
over the plain row's on the same seed, and both rows' lag}, "failed", "blowups": [the trials'
blow-up captures, OUT/blowups/<key>, also named on the console], "provenance"}), OUT/table1.md and
OUT/table1.csv, and the plots of the first seed of each row: OUT/mpc_dofs.png (|C| per optimisation
over the episode), OUT/mpc_goal_distance.png (the goal object's distance to the goal) and
OUT/final_<row>.png (the final scene; MUJOCO_GL=egl, skipped with --no-render). summary.json also
holds "trial_keys" (its trials: a folder may hold other runs' too) and "trial_commits" (the code
commits of the trial results: more than one when a resumed sweep mixes code). Exits 1 if a
trial failed (summary.json lists it under "failed") or the run failed (one line on stderr);
2 on a bad flag. The first seed of each row keeps its start state and executed controls
(``--keep-controls``: ``flags.KEEP_CONTROLS``, about 142 bytes per agent step, 280 KB a
2000-step clutter trial), which dopt-view re-simulates exactly; the keys are the same either
way. The run ends with the paths of its pictures and the dopt-view command that replays its
episodes.

``--rows`` names Table 1 rows; without it (and without --preset paper or authors, which run
the nine rows), ``--rules`` runs DoF-selection rules with ``--rho`` and ``--theta``. The flags
are ``flags``'s, their settings ``mapping``'s, the sweep ``runner``'s, the files ``outputs``'s.

``--quick`` is a short episode in which SVR visibly acts: ``flags.QUICK``'s flags (the paper's
protocol, rows sum-t10-r1 and baseline, one seed, 300 agent steps, the deterministic model
clock), each where it is not given; its table and plots show |C| falling and the rows differ.

    python experiments/mpc.py --quick
    python experiments/mpc.py --task clutter --trials 20 --out results/mpc_clutter
    python experiments/mpc.py --task clutter --preset paper --trials 100 --workers 2 \\
        --out results/table1-clutter
"""

from __future__ import annotations

import argparse

from dopt.blowup import captures_of
from dopt.lab.cli import EPILOG, ArgumentParser, choices_type, guarded, nonneg_float, nonneg_int
from dopt.lab.console import print_captures, print_outputs, sweep_session
from dopt.lab.record import write_summary
from planners.svr import METHODS
from planners.svr_mpc import row_label, table1_fields
from planners.svr_mpc.authors_data import TASK_DIRS, authors_travel
from planners.svr_mpc.experiments import flags, mapping, runner
from planners.svr_mpc.experiments.outputs import write_plots, write_table


def parser() -> argparse.ArgumentParser:
    ap = ArgumentParser(prog="mpc.py", description=__doc__, epilog=EPILOG,
                        formatter_class=argparse.RawDescriptionHelpFormatter)
    flags.add_rows_argument(ap, None)
    ap.add_argument("--rules", type=choices_type(METHODS, "rule(s)"), default=None,
                    help="comma-separated DoF-selection rules (" + ", ".join(METHODS) + "), "
                         "with --rho and --theta, when no --rows are given (default: all five; "
                         "with --preset paper or authors the nine rows of Table 1 unless "
                         "--rules is given)")
    flags.add_alias(ap, "--methods", "--rules")
    ap.add_argument("--rho", type=nonneg_float, default=1.0,
                    help="SVR importance threshold: DoFs below it leave the active set "
                         "(default %(default)s, the paper's)")
    ap.add_argument("--theta", type=nonneg_int, default=None,
                    help="random DoFs re-added per iteration (svr) / used besides the robot "
                         "(rand); default: the paper's Table 1, rand 5, svr 10")
    flags.add_run_arguments(ap)
    ap.add_argument("--no-render", action="store_true",
                    help="skip the renders of the final scenes (final_<row>.png)")
    return ap


def parse_args(argv=None) -> argparse.Namespace:
    """Table 1's flags (``parser``) checked as usage errors (``flags.parse_args``)."""
    return flags.parse_args(argv, parser())


@guarded("mpc.py")
def main(argv=None) -> int:
    """``python experiments/mpc.py`` (``dopt-mpc``): its exit status (module docstring)."""
    args = parse_args(argv)
    with sweep_session(args.out, args.verbose):   # a second run on this --out refuses at once
        return _main(args, argv)


def _main(args, argv) -> int:
    """The run of ``main`` once its flags are checked and it holds its folder."""
    trials = mapping.make_trials(args)
    records, res = runner.run(args, trials)
    failed = res.failed
    baseline = mapping.baseline_label(args)
    fields = table1_fields(records, baseline=baseline)
    rows = fields["methods"]
    summary = {"experiment": "table1", "task": args.task,
               **mapping.protocol(args, trials[0].params),
               "row_settings": {row: {"method": t.params["method"], "theta": t.params["theta"],
                              "rho": t.params["rho"]}
                        for t in trials for row in [row_label(t.params)]},
               **fields, "failed": failed, "trial_commits": res.commits,
               # the names its trials are stored under (an older name: as stored)
               "trial_keys": sorted(res.stored_key(t.key) for t in trials),
               # run_trial labels an episode's captures by the name it ran under
               "blowups": print_captures(args.out, captures_of(
                   args.out, [res.stored_key(t.key) for t in trials]))}
    if getattr(args, "authors_data", None) is not None:
        summary["authors_rows"] = authors_travel(args.authors_data / TASK_DIRS[args.task],
                                                 args.layouts)
    write_summary(summary, args.out, args.record, "experiments/mpc.py", argv)
    write_table(args.out, args.task, rows, summary.get("feedback_effect"))
    write_plots(args.out, args.task, records, list(rows), render=not args.no_render)
    print((args.out / "table1.md").read_text())
    print_outputs(args.out, ["table1.md", "mpc_dofs.png", "mpc_goal_distance.png",
                             *(f"final_{row}.png" for row in rows)])
    return 1 if failed else 0
