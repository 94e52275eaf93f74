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
(``--keep-controls``: ``KEEP_CONTROLS``, about 142 bytes per agent step, 280 KB a 2000-step
clutter trial), which dopt-view re-simulates exactly; the keys are the same either way. The run
ends with the paths of its pictures and the dopt-view command that replays its episodes.

``--quick`` is a short episode in which SVR visibly acts: ``QUICK``'s flags (the paper's
protocol, rows sum-t10-r1 and baseline, one seed, 300 agent steps, the deterministic model
clock), each where it is not given; its table and plots show |C| falling and the rows differ.

    python experiments/mpc.py --quick
    python experiments/mpc.py --task clutter --trials 20 --out results/mpc_clutter
    python experiments/mpc.py --task clutter --preset paper --trials 100 --workers 2 \\
        --out results/table1-clutter
"""

from __future__ import annotations

import argparse
import functools
import importlib.util
import logging
import os
import sys
from dataclasses import asdict, replace
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")   # offscreen renders; read when mujoco is imported

import numpy as np
from mpc_outputs import write_plots, write_table

from dopt.blowup import captures_of
from dopt.lab.cli import (
    EPILOG,
    ArgumentParser,
    choices_type,
    guarded,
    no_repeats,
    nonneg_float,
    nonneg_int,
    number_in,
    output_dir,
    output_file,
    positive_float,
    positive_int,
)
from dopt.lab.console import out_lock, print_captures, print_outputs, run_with_console
from dopt.lab.record import add_reuse_argument, check_outputs, reuse_mode, write_summary
from dopt.lab.sweep import Schema, SweepResult, Trial, is_finished
from dopt.mpc import EXECUTORS, MAX_CONTROL_NOISE
from dopt.tasks import PUSH_TASKS
from dopt.tasks.push.costs import COST_PRESETS
from planners.svr import METHODS, paper_theta
from planners.svr_mpc import (
    CLOCK_MODEL_MS,
    CONTROLS_FIELDS,
    SVR_CLOCKS,
    TABLE1_ROWS,
    CapturingTrial,
    Derivatives,
    KeptControls,
    Row,
    SVRMPCSettings,
    authors_clock,
    parse_row,
    row_label,
    run_trial,
    table1_fields,
    task_defaults,
    trial_key,
    trial_params,
)
from planners.svr_mpc.authors_data import TASK_DIRS, authors_travel

log = logging.getLogger(__name__)
FEEDBACK = {"off": (False,), "on": (True,), "both": (False, True)}
#: task instances (seeds) per method without --trials (1 with --quick)
DEFAULT_TRIALS = 20
#: the files a run writes under --out (besides its trials): checked before the first trial
RUN_FILES = ("summary.json", "table1.md")
#: what a stored MPC trial must hold to be reused: the fields the summary and plots read,
#: the numbers among them finite (a cost of +inf once failed every rerun in the summary), and
#: params that name the trial they are stored for (``trial_key``: not the threads)
SCHEMA = Schema(result=("mpc_cost", "success", "steps", "goal_distance_start",
                        "goal_distance_end", "opt_ms_mean", "dofs_mean", "n_dofs", "opt_step",
                        "lag_steps_mean", "unstable"),
                finite=("mpc_cost", "steps", "goal_distance_start", "goal_distance_end",
                        "opt_ms_mean", "dofs_mean", "lag_steps_mean"),
                identity=trial_key)
#: --keep-controls: which trials keep their start state and executed controls for dopt-view's
#: exact replay (about ``CONTROLS_BYTES_PER_STEP`` bytes per agent step of JSON); "first"
#: (the default) is one episode per row, the one the plots show, and reuses a stored trial as
#: it is; "all" reruns a stored trial that lacks them
KEEP_CONTROLS = ("first", "all", "none")
#: bytes of kept controls per agent step (the Panda's seven controls as JSON, measured)
CONTROLS_BYTES_PER_STEP = 142
#: the flags of --quick, each applied where it is not given: a short episode in which SVR
#: visibly acts (|C| falls from the full set, the rows' costs differ)
QUICK = {"preset": "paper", "rows": ("sum-t10-r1", "baseline"), "trials": 1, "timeout": 300,
         "clock": "model"}


def parser() -> argparse.ArgumentParser:
    ap = ArgumentParser(prog="mpc.py", description=__doc__, epilog=EPILOG,
                        formatter_class=argparse.RawDescriptionHelpFormatter)
    add_rows_argument(ap, None)
    ap.add_argument("--methods", type=choices_type(METHODS, "method(s)"), default=None,
                    help="comma-separated DoF-selection methods, with --rho and --theta, "
                         "when no --rows are given (default: all five; with --preset paper "
                         "or authors the nine rows of Table 1 unless --methods is given)")
    ap.add_argument("--rho", type=nonneg_float, default=1.0,
                    help="SVR importance threshold: DoFs below it leave the active set "
                         "(default %(default)s, the paper's)")
    ap.add_argument("--theta", type=nonneg_int, default=None,
                    help="random DoFs re-added per iteration (svr) / used besides the robot "
                         "(rand); default: the paper's Table 1, rand 5, svr 10")
    add_run_arguments(ap)
    ap.add_argument("--no-render", action="store_true",
                    help="skip the renders of the final scenes (final_<method>.png)")
    return ap


def rows_list(text: str) -> list[str]:
    """--rows: comma-separated ``parse_row`` specs, none twice (argparse ``type=``)."""
    names = [name.strip() for name in text.split(",")]
    try:
        for name in names:
            parse_row(name)
        return no_repeats(names, "row(s)")
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def add_rows_argument(ap: argparse.ArgumentParser, default: tuple[str, ...] | None) -> None:
    """--rows: Table 1 rows by name (``default``; None: all nine with --preset paper)."""
    ap.add_argument("--rows", type=rows_list,
                    default=None if default is None else ",".join(default),
                    help="comma-separated Table 1 rows by name (" + ", ".join(TABLE1_ROWS)
                    + ", or an optimiser's name: unoptimised runs the push plan as it is; "
                    "planners.svr_mpc.OPTIMISERS), "
                    "each optionally with derivative variants +skip<K>, +adaptive, "
                    "+boxqp, +central (e.g. sum-t10-r1+skip5; they override --fd-skip, "
                    "--keypoints, --box-qp and --fd for that row); default "
                    + ("with --preset paper: all nine" if default is None
                       else ",".join(default)))


def add_run_arguments(ap: argparse.ArgumentParser) -> None:
    """The flags of any MPC sweep (this script's and rho_sweep.py's): task, trials, seeds,
    timing, feedback, workers, output."""
    ap.add_argument("--task", default="clutter", choices=list(PUSH_TASKS),
                    help="the pushing task (default %(default)s)")
    ap.add_argument("--preset", default=None, choices=["ours", "paper", "authors"],
                    help="paper: the authors' protocol on our problems (Eq. 2 cost without the "
                         "end-effector term, on soft with their terminal reach residual; their "
                         "set-up motion and initial push plan, 5%% control noise, virtual "
                         "clock); authors: the same protocol on the authors' own problems "
                         "(their scenes, objects, contacts and cost weights, no control cost, "
                         "no control noise; clutter needs --layouts); ours: cost with the "
                         "end-effector term, zero initial plan, real clock (default ours; "
                         "paper with --quick). Flags below override it")
    ap.add_argument("--layouts", type=Path, default=None, metavar="DIR",
                    help="the authors' clutter scenes (a folder of {0..99}.csv, e.g. "
                         "../shared/external/ilqr_svr/push_mcl_layouts); seed i runs scene i")
    ap.add_argument("--authors-data", type=Path, default=None, metavar="DIR",
                    help="the authors' PaperData folder (e.g. ../shared/external/ilqr_svr/"
                         "paper_data): the summary then holds their rows' goal distances and, "
                         "with --layouts, travel, beside ours (authors_rows)")
    ap.add_argument("--push-tail", default="on", choices=["on", "off"],
                    help="the first push plan ends moving forward (default on); off: it ends "
                         "braking at its end point (dopt.tasks.push.warm_start)")
    ap.add_argument("--islands", default="on", choices=["on", "off"],
                    help="MuJoCo's constraint islands (default on); off: one monolithic "
                         "constraint solve, as the authors' MuJoCo")
    ap.add_argument("--cost", default=None, choices=list(COST_PRESETS),
                    help="the cost: paper (Eq. 2), paper-reach (Eq. 2 with the authors' soft-task "
                         "reach residual) or ee (with the end-effector term)")
    ap.add_argument("--warm-start", default=None, choices=["on", "off"],
                    help="start from the authors' set-up state and push plan")
    add_clock_arguments(ap)
    ap.add_argument("--fd", default="forward", choices=["forward", "central"],
                    help="finite differences: forward eps 1e-3 (default) or the authors' "
                         "central eps 1e-6")
    ap.add_argument("--fd-skip", type=positive_int, default=1,
                    help="finite differences every K-th timestep, A and B linear between "
                         "(default %(default)s: every timestep)")
    ap.add_argument("--keypoints", default=None, choices=["adaptive"],
                    help="adaptive key timesteps for the finite differences "
                         "(planners.keypoints) instead of --fd-skip")
    ap.add_argument("--box-qp", action="store_true",
                    help="control limits in iLQR's backward pass (mju_boxQP)")
    ap.add_argument("--trials", type=positive_int, default=None,
                    help=f"task instances (seeds) per method (default {DEFAULT_TRIALS}; 1 with "
                         f"--quick)")
    ap.add_argument("--seed", type=nonneg_int, default=0,
                    help="first seed; trials use seed..seed+N-1 (default %(default)s)")
    ap.add_argument("--slowdown", type=positive_float, default=None,
                    help="agent wall time per step over dt (default: the task's, the paper's)")
    ap.add_argument("--timeout", type=positive_int, default=None,
                    help="task timeout Y in agent steps (default: the task's, the paper's)")
    ap.add_argument("--feedback", nargs="?", const="on", default="off",
                    choices=["off", "on", "both"],
                    help="execute u + K (x - x_nom) on the measured state (authors: off); "
                         "'both' runs every trial open-loop and with feedback back to back, "
                         "so the pair sees the same machine load (rows 'METHOD +fb')")
    ap.add_argument("--control-noise", type=number_in(float, 0.0, MAX_CONTROL_NOISE),
                    default=None,
                    help="Gaussian noise on executed controls, fraction of range (authors and "
                         f"--preset paper: 0.05; ours: 0; at most {MAX_CONTROL_NOISE:g}, the "
                         "whole range)")
    ap.add_argument("--workers", type=positive_int, default=1,
                    help="local worker processes (default %(default)s)")
    ap.add_argument("--ray", nargs="?", const="local", default=None, metavar="ADDRESS",
                    help="run the trials on Ray (local instance if no ADDRESS)")
    ap.add_argument("--threads", type=nonneg_int, default=None,
                    help="simulation threads per trial (default: all cores, 1 with workers>1)")
    add_episode_arguments(ap)
    ap.add_argument("--out", type=output_dir, default=None,
                    help="output folder (default results/<script>_<task>); finished trials "
                         "are kept under OUT/trials and a rerun resumes")
    ap.add_argument("--fresh", action="store_true",
                    help="recompute every trial (old trial files go to OUT/trials/outdated/)")
    add_reuse_argument(ap)
    ap.add_argument("--record", type=output_file, default=None, metavar="PATH",
                    help="also write the summary to PATH (docs/results/...)")


def add_episode_arguments(ap: argparse.ArgumentParser) -> None:
    """--quick (``QUICK``) and --keep-controls (``KEEP_CONTROLS``): the flags of every MPC
    script that say how long its episodes are and whether dopt-view can replay them."""
    ap.add_argument("--quick", action="store_true",
                    help="a short episode where SVR visibly acts, in seconds: "
                         + " ".join(f"--{k} {','.join(v) if isinstance(v, tuple) else v}"
                                    for k, v in QUICK.items())
                         + " (each where not given; --rows only where the script has it)")
    ap.add_argument("--keep-controls", nargs="?", const="all", default="first",
                    choices=KEEP_CONTROLS,
                    help="which trials keep their start state and executed controls for "
                         "dopt-view's exact replay, about "
                         f"{CONTROLS_BYTES_PER_STEP} bytes per agent step (280 KB a 2000-step "
                         "trial): first (default: the first seed of each row, the episode the "
                         "plots show; a stored trial is reused as it is), all (the bare flag; "
                         "a stored trial without them is rerun), none")


def add_clock_arguments(ap: argparse.ArgumentParser) -> None:
    """The flags of the MPC loop's timing: clock, its fixed duration, executor, threads."""
    ap.add_argument("--clock", default=None, choices=list(SVR_CLOCKS),
                    help="real (wall time), virtual (CPU time / --nominal-threads), model "
                         "(ms = a + b |C| fitted on this project's machine) or authors (ms = a "
                         "+ b |C| fitted to the authors' own times; --preset authors); model "
                         "and authors are deterministic, the same on any machine")
    ap.add_argument("--executor", default=None, choices=list(EXECUTORS),
                    help="alg1: the paper's Alg. 1 (pad with the last control, land shifted "
                         "by the lag); authors (--preset authors): their code's (hold after 80 "
                         "controls, land at the nearest nominal state)")
    ap.add_argument("--clock-ms", type=positive_float, default=None, metavar="MS",
                    help="every optimisation lasts MS on the model clock (sets --clock model): "
                         "every row lags alike, so rows differ only in the DoFs they choose")
    ap.add_argument("--nominal-threads", type=positive_float, default=2.0,
                    help="threads a virtual duration divides the CPU time by (default "
                         "%(default)s, this machine)")


def parse_args(argv=None, ap: argparse.ArgumentParser | None = None,
               one_feedback: bool = False) -> argparse.Namespace:
    """The flags of ``ap`` (default: this script's) checked as usage errors; ``one_feedback``:
    the script runs one feedback setting, so --feedback both is refused."""
    ap = ap or parser()
    args = ap.parse_args(argv)
    if one_feedback and args.feedback == "both":
        ap.error(f"--feedback both is for experiments/mpc.py; give on or off to {ap.prog}")
    if args.ray is not None and importlib.util.find_spec("ray") is None:
        ap.error("--ray needs the ray package (pip install 'dopt[cluster]')")
    if args.clock_ms is not None and args.clock not in (None, "model"):
        ap.error(f"--clock-ms sets the model clock's duration; it cannot go with --clock "
                 f"{args.clock}")
    if args.authors_data is not None and not (args.authors_data / TASK_DIRS[args.task]).is_dir():
        ap.error(f"--authors-data: no {TASK_DIRS[args.task]} folder under {args.authors_data} "
                 f"(the authors' PaperData)")
    quick_defaults(args)
    if args.threads is None:
        args.threads = 1 if (args.workers > 1 or args.ray) else 0
    if args.layouts is not None and (args.preset, args.task) != ("authors", "clutter"):
        ap.error(f"argument --layouts: only --preset authors on --task clutter reads the "
                 f"authors' clutter scenes, not --preset {args.preset} on --task {args.task} "
                 f"(leave it out)")
    try:               # the pipeline's own checks of the settings, as usage errors
        for row in grid(args):
            settings_of(args, row, args.feedback == "on")
    except (ValueError, TypeError) as e:
        ap.error(str(e))
    if (problem := layouts_problem(args)) is not None:
        ap.error(problem)
    check_outputs(ap, args, f"{Path(ap.prog).stem}_{args.task}", files=RUN_FILES)
    return args


def quick_defaults(args) -> None:
    """Resolve the flags whose default depends on --quick: the preset (ours; ``QUICK``'s with
    --quick) and, with --quick, one trial and each other flag of ``QUICK`` where it is not
    given (--rows only where the script has it and neither --rows nor --methods is given;
    --clock not beside --clock-ms, which sets the model clock); an explicit --trials stands."""
    if args.trials is None:                  # an explicit --trials stands with --quick
        args.trials = QUICK["trials"] if args.quick else DEFAULT_TRIALS
    if not args.quick:
        args.preset = args.preset or "ours"
        return
    for name, value in QUICK.items():
        if name == "trials" or not hasattr(args, name) or getattr(args, name) is not None:
            continue
        if (name == "rows" and getattr(args, "methods", None) is not None) or \
                (name == "clock" and args.clock_ms is not None):
            continue
        setattr(args, name, list(value) if isinstance(value, tuple) else value)


def layouts_problem(args) -> str | None:
    """Why the --layouts scenes of the run's seeds cannot be run (a seed without a scene, a
    file that is not a layout or whose scene makes no sense: ``check_layout``), or None;
    before any trial, so that a bad scene is not found by its trial alone."""
    if args.layouts is None:
        return None
    from dopt.tasks import N_AUTHORS_LAYOUTS
    from dopt.tasks.push.authors import check_layout

    for seed in range(args.seed, args.seed + args.trials):
        if seed >= N_AUTHORS_LAYOUTS:
            return (f"argument --trials: seed {seed} names no scene of the authors' clutter "
                    f"(scenes 0-{N_AUTHORS_LAYOUTS - 1})")
        path = args.layouts / f"{seed}.csv"
        try:
            check_layout(path)
        except FileNotFoundError:
            return f"argument --layouts: no {path} (the scene of seed {seed})"
        except ValueError as e:
            return f"argument --layouts: {e}"
    return None


def settings_of(args, row: Row, feedback: bool) -> SVRMPCSettings:
    """The settings of one row (``parse_row``) under the flags: the preset's, then the flags
    that override it, then the row's own derivative variants."""
    preset = SVRMPCSettings.preset(args.preset, args.task,
                                   str(args.layouts) if args.layouts else None)
    if args.islands == "off":
        preset = replace(preset, islands=False)
    if args.push_tail == "off":
        preset = replace(preset, push_tail=False)
    over = {"cost": args.cost, "control_noise": args.control_noise, "clock": args.clock,
            "clock_ms": args.clock_ms, "executor": args.executor}
    if args.clock_ms is not None:
        over["clock"] = "model"
    over = {k: v for k, v in over.items() if v is not None}
    if args.warm_start is not None:
        over["warm_start"] = args.warm_start == "on"
    kp = args.keypoints or ("skip" if args.fd_skip > 1 else "every")
    flags = Derivatives(args.fd, kp, args.fd_skip if kp == "skip" else 1, args.box_qp)
    over.update(replace(flags, **row.variants).fields(), **row.fixes)
    return replace(preset, task=args.task, method=row.method, theta=row.theta,
                   rho=float(row.rho),
                   slowdown=args.slowdown or task_defaults(args.task)[0], timeout=args.timeout,
                   threads=args.threads or 0, feedback=feedback,
                   nominal_threads=float(args.nominal_threads), **over)


def baseline_label(args) -> str:
    """The row label (``row_label``) of the baseline trials of the flags: the row every other
    is normalised by."""
    return row_label(asdict(settings_of(args, Row("baseline", 0, 1.0), args.feedback == "on")))


def grid(args, methods=None, rhos=None, thetas=None) -> list[Row]:
    """The rows of the flags: those of --rows (default with --preset paper or authors and no
    --methods: the nine of Table 1; ``parse_row``), else every (method, rho, theta) of the
    arguments or flags (--methods' default: all five), without variants of their own."""
    rows, flag = getattr(args, "rows", None), getattr(args, "methods", None)
    if (rows is None and methods is None and flag is None
            and args.preset in ("paper", "authors") and hasattr(args, "rows")):
        rows = list(TABLE1_ROWS)
    if rows:
        return [parse_row(r) for r in rows]
    flag = flag or (list(METHODS) if hasattr(args, "methods") else ["baseline"])
    return [Row(m, t, rho) for m in methods or flag
            for rho in rhos or [getattr(args, "rho", 1.0)]
            for t in thetas or [_theta(getattr(args, "theta", None), m)]]


def make_trials(args, methods=None, rhos=None, thetas=None, **override) -> list[Trial]:
    """Every (seed, row, feedback) trial of the flags (``grid``); ``override``: settings
    fields replaced in every trial (e.g. clock="real")."""
    out = []
    for seed in range(args.seed, args.seed + args.trials):
        for row in grid(args, methods, rhos, thetas):
            for feedback in FEEDBACK[args.feedback]:
                s = replace(settings_of(args, row, feedback), **override)
                p = trial_params(s, seed, row.optimiser)
                out.append(Trial(trial_key(p), p))
    return out


def _theta(theta: int | None, method: str) -> int:
    """--theta, or the paper's Table 1 value for the method (rand 5, svr 10; unused else)."""
    return paper_theta(method) if theta is None else theta


def protocol(args, params: dict) -> dict:
    """The protocol a summary records: preset, cost, warm start, clock, nominal threads,
    control noise, finite differences and slowdown of a trial's params under the flags."""
    return {"preset": args.preset, "cost": params["cost"], "warm_start": params["warm_start"],
            "clock": params["clock"], "nominal_threads": params["nominal_threads"],
            "control_noise": params["control_noise"], "fd": args.fd,
            "keypoints": params["keypoints"], "fd_skip": params["fd_skip"],
            "box_qp": params["box_qp"], "slowdown": params["slowdown"],
            "problem": params["problem"], "layouts": params["layouts"],
            "islands": params["islands"], "push_tail": params["push_tail"],
            "executor": params.get("executor", "alg1"),
            **({"clock_ms": params["clock_ms"]} if params.get("clock_ms") is not None else {})}


def run(args, trials, fn=None, out: Path | None = None, workers: int | None = None,
        schema: Schema = SCHEMA) -> tuple[list, SweepResult]:
    """Run (or resume; ``args.fresh``: recompute) the trials with ``fn`` (default one MPC
    episode, ``run_trial``, which writes its blow-up captures under ``out``; another takes
    ``(params, report, keep_controls=False)``) under ``out`` (default --out), on ``workers``
    processes (default --workers, or Ray with --ray), with the sweep's console
    (``dopt.lab.console``: an estimate of the time up front, a bar of the agent steps of every
    trial, a trial's budget its timeout, each trial's cost as it finishes); a stored trial is
    reused only when it fits ``schema``; a trial keeps its controls as --keep-controls says
    (``kept_controls``, ``KeptControls``). Returns their records and the sweep's result
    (``failed``: {key: error}, ``commits``: code commits of the records)."""
    out = out or args.out
    every, seeds = kept_controls(args)
    if every:
        schema = replace(schema, wanted=schema.wanted + CONTROLS_FIELDS)
    steps = {t.key: int(t.params.get("timeout") or task_defaults(t.params["task"])[1])
             for t in trials}
    kept = KeptControls(fn or run_trial, seeds, every)
    res = run_with_console(
        kept if fn is not None else CapturingTrial(str(out), kept), trials, out, unit="step",
        desc=f"{args.task} MPC steps", steps=lambda t: steps[t.key],
        held=lambda t: steps[t.key] if is_finished(out, t.key, reuse=reuse_mode(args),
                                                   schema=schema, params=t.params) else 0,
        seconds=lambda t: steps[t.key] * agent_seconds(t.params),
        basis="this machine's optimisation times (agent_seconds)",
        describe=describe_result,
        workers=workers or args.workers, ray_address=None if workers else args.ray,
        fresh=args.fresh, reuse=reuse_mode(args), schema=schema)
    for key, err in res.failed.items():
        print(f"FAILED {key}: {err}", file=sys.stderr)
    wanted = {t.key for t in trials}
    return [r for k, r in res.records.items() if k in wanted], res


def kept_controls(args) -> tuple[bool, tuple[int, ...]]:
    """--keep-controls (``KEEP_CONTROLS``) as (every trial keeps its controls, a stored one
    without them rerun; the seeds whose newly run trials keep theirs)."""
    mode = getattr(args, "keep_controls", "none")
    return mode == "all", ((int(args.seed),) if mode == "first" else ())


@functools.cache
def _sizes(task: str) -> tuple[float, int]:
    """dt (s) and nv of the task's own instance (seed 0)."""
    built = PUSH_TASKS[task](np.random.default_rng(0))
    return float(built.dt), int(built.model.nv)


def agent_seconds(params: dict) -> float:
    """A trial's expected wall time per agent step (s), a first guess that the console
    revises from the run's own pace: the task's dt times its slowdown (the real clock's
    pace), on a modelled clock (model, authors) times this machine's optimisation time over
    the clock's where that is more (``CLOCK_MODEL_MS`` over the clock's a + b n, at the
    task's full DoF count n: an optimisation takes what it takes here, and the agent moves
    on by what the clock says; executing the steps keeps the real pace a floor). The virtual
    clock is taken at the real clock's pace."""
    dt, nv = _sizes(params["task"])
    pace = dt * float(params.get("slowdown") or task_defaults(params["task"])[0])
    clock = params.get("clock")
    if clock in ("model", "authors"):
        a, b = CLOCK_MODEL_MS[params["task"]]
        ours = a + b * nv
        if clock == "authors":
            a, b = authors_clock.model_ms(params["task"], params["method"])
            theirs = a + b * nv
        else:
            theirs = params.get("clock_ms") or ours
        pace *= max(1.0, ours / theirs)
    return pace


def describe_result(record: dict) -> str:
    """A finished MPC trial in a few words: its MPC cost, mean |C|, the goal object's final
    distance to the goal and whether it got there."""
    r = record["result"]
    text = f"MPC cost {r['mpc_cost']:.4g}"
    if r.get("dofs_mean") is not None:
        text += f", mean |C| {r['dofs_mean']:.1f}"
    return (text + f", goal {100 * r['goal_distance_end']:.1f} cm away"
            + (", reached" if r.get("success") else "")
            + (", UNSTABLE" if r.get("unstable") else ""))


@guarded("mpc.py")
def main(argv=None) -> int:
    logging.basicConfig(level=logging.WARNING)
    args = parse_args(argv)
    with out_lock(args.out):              # a second run on this --out refuses at once
        return _main(args, argv)


def _main(args, argv) -> int:
    """The run of ``main`` once its flags are checked and it holds its folder."""
    trials = make_trials(args)
    records, res = run(args, trials)
    failed = res.failed
    baseline = baseline_label(args)
    fields = table1_fields(records, baseline=baseline)
    rows = fields["methods"]
    summary = {"experiment": "table1", "task": args.task, **protocol(args, trials[0].params),
               "row_settings": {row: {"method": t.params["method"], "theta": t.params["theta"],
                              "rho": t.params["rho"]}
                        for t in trials for row in [row_label(t.params)]},
               **fields, "failed": failed, "trial_commits": res.commits,
               "trial_keys": sorted(t.key for t in trials),
               "blowups": print_captures(args.out,
                                         captures_of(args.out, [t.key for t in trials]))}
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


if __name__ == "__main__":
    sys.exit(main())
