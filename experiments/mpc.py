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
holds "trial_commits" (the code commits of the trial results: more than one when a resumed sweep
mixes code). Exits 1 if a trial failed (summary.json lists it under "failed") or the run failed
(one line on stderr); 2 on a bad flag. --keep-controls also keeps each trial's start state
and executed controls (about 280 KB a trial), which dopt-view re-simulates exactly; the keys
are the same either way, and a stored trial without controls is rerun.

    python experiments/mpc.py --task clutter --trials 20 --out results/mpc_clutter
    python experiments/mpc.py --task clutter --preset paper --trials 100 --workers 2 \\
        --out results/table1-clutter
"""

from __future__ import annotations

import argparse
import csv
import importlib.util
import logging
import os
import sys
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np

os.environ.setdefault("MUJOCO_GL", "egl")   # offscreen renders; read when mujoco is imported

from cli_args import (
    EPILOG,
    ArgumentParser,
    add_reuse_argument,
    blowup_captures,
    check_outputs,
    choices_type,
    guarded,
    no_repeats,
    nonneg_float,
    nonneg_int,
    output_dir,
    output_file,
    positive_float,
    positive_int,
    reuse_mode,
    write_summary,
)
from sweep_console import out_lock, run_with_console

from dopt.mpc import EXECUTORS
from dopt.sweep import Schema, SweepResult, Trial, is_finished
from dopt.tasks import PUSH_TASKS
from dopt.tasks.push.costs import COST_PRESETS
from planners.svr import METHODS, paper_theta
from planners.svr_mpc import (
    CONTROLS_FIELDS,
    OUTLIER_DISTANCE,
    SVR_CLOCKS,
    TABLE1_ROWS,
    CapturingTrial,
    Derivatives,
    Row,
    SVRMPCSettings,
    parse_row,
    row_label,
    run_trial,
    split_params,
    table1_fields,
    task_defaults,
    trial_key,
    trial_params,
)

log = logging.getLogger(__name__)
FEEDBACK = {"off": (False,), "on": (True,), "both": (False, True)}
#: what a stored MPC trial must hold to be reused: the fields the summary and plots read
SCHEMA = Schema(result=("mpc_cost", "success", "steps", "goal_distance_start",
                        "goal_distance_end", "opt_ms_mean", "dofs_mean", "n_dofs", "opt_step",
                        "lag_steps_mean", "unstable"))


def parser() -> argparse.ArgumentParser:
    ap = ArgumentParser(prog="mpc.py", description=__doc__, epilog=EPILOG,
                        formatter_class=argparse.RawDescriptionHelpFormatter)
    add_rows_argument(ap, None)
    ap.add_argument("--methods", type=choices_type(METHODS, "method(s)"),
                    default=",".join(METHODS),
                    help="comma-separated DoF-selection methods, with --rho and --theta, "
                         "when no --rows are given (default: all five)")
    ap.add_argument("--rho", type=nonneg_float, default=1.0,
                    help="SVR importance threshold: DoFs below it leave the active set "
                         "(default %(default)s, the paper's)")
    ap.add_argument("--theta", type=nonneg_int, default=None,
                    help="random DoFs re-added per iteration (svr) / used besides the robot "
                         "(rand); default: the paper's Table 1, rand 5, svr 10")
    add_run_arguments(ap)
    ap.add_argument("--no-render", action="store_true",
                    help="skip the renders of the final scenes (final_<method>.png)")
    ap.add_argument("--keep-controls", action="store_true",
                    help="keep each trial's start state and executed controls, for dopt-view "
                         "replays (~280 KB per trial; stored trials without them are rerun)")
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
    ap.add_argument("--preset", default="ours", choices=["ours", "paper", "authors"],
                    help="paper: the authors' protocol on our problems (Eq. 2 cost without the "
                         "end-effector term, on soft with their terminal reach residual; their "
                         "set-up motion and initial push plan, 5%% control noise, virtual "
                         "clock); authors: the same protocol on the authors' own problems "
                         "(their scenes, objects, contacts and cost weights, no control cost, "
                         "no control noise; clutter needs --layouts); ours: cost with the "
                         "end-effector term, zero initial plan, real clock (default "
                         "%(default)s). Flags below override it")
    ap.add_argument("--layouts", type=Path, default=None, metavar="DIR",
                    help="the authors' clutter scenes (a folder of {0..99}.csv, e.g. "
                         "../shared/external/ilqr_svr/push_mcl_layouts); seed i runs scene i")
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
    ap.add_argument("--clock", default=None, choices=list(SVR_CLOCKS),
                    help="real (wall time), virtual (CPU time / --nominal-threads), model "
                         "(ms = a + b |C| fitted on this project's machine) or authors (ms = a "
                         "+ b |C| fitted to the authors' own times; --preset authors); model "
                         "and authors are deterministic, the same on any machine")
    ap.add_argument("--executor", default=None, choices=list(EXECUTORS),
                    help="alg1: the paper's Alg. 1 (pad with the last control, land a plan "
                         "shifted by its lag); authors: their data generator's (hold the arm "
                         "after 80 controls until a plan lands, land at the nearest nominal "
                         "state; the default of --preset authors)")
    ap.add_argument("--clock-ms", type=positive_float, default=None, metavar="MS",
                    help="every optimisation lasts MS on the model clock (sets --clock model): "
                         "every row lags alike, so rows differ only in the DoFs they choose")
    ap.add_argument("--nominal-threads", type=positive_float, default=2.0,
                    help="threads a virtual duration divides the CPU time by (default "
                         "%(default)s, this machine)")
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
    ap.add_argument("--trials", type=positive_int, default=20,
                    help="task instances (seeds) per method (default %(default)s)")
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
    ap.add_argument("--control-noise", type=nonneg_float, default=None,
                    help="Gaussian noise on executed controls, fraction of range (authors and "
                         "--preset paper: 0.05; ours: 0)")
    ap.add_argument("--workers", type=positive_int, default=1,
                    help="local worker processes (default %(default)s)")
    ap.add_argument("--ray", nargs="?", const="local", default=None, metavar="ADDRESS",
                    help="run the trials on Ray (local instance if no ADDRESS)")
    ap.add_argument("--threads", type=nonneg_int, default=None,
                    help="simulation threads per trial (default: all cores, 1 with workers>1)")
    ap.add_argument("--quick", action="store_true",
                    help="smoke run: 1 trial per method, Y = 100 steps")
    ap.add_argument("--out", type=output_dir, default=None,
                    help="output folder (default results/<script>_<task>); finished trials "
                         "are kept under OUT/trials and a rerun resumes")
    ap.add_argument("--fresh", action="store_true",
                    help="recompute every trial (old trial files go to OUT/trials/outdated/)")
    add_reuse_argument(ap)
    ap.add_argument("--record", type=output_file, default=None, metavar="PATH",
                    help="also write the summary to PATH (docs/results/...)")


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
    if args.quick:
        args.trials, args.timeout = 1, args.timeout or 100
    if args.threads is None:
        args.threads = 1 if (args.workers > 1 or args.ray) else 0
    try:               # the pipeline's own checks of the settings, as usage errors
        for row in grid(args):
            settings_of(args, row, args.feedback == "on")
    except (ValueError, TypeError) as e:
        ap.error(str(e))
    check_outputs(ap, args, f"{Path(ap.prog).stem}_{args.task}")
    return args


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
    over.update(replace(flags, **row.variants).fields())
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
    """The rows of the flags: those of --rows (default with --preset paper: the nine of Table
    1; ``parse_row``), else every (method, rho, theta) of the arguments or flags, without
    variants of their own."""
    rows = getattr(args, "rows", None)
    if (rows is None and methods is None and args.preset in ("paper", "authors")
            and hasattr(args, "rows")):
        rows = list(TABLE1_ROWS)
    if rows:
        return [parse_row(r) for r in rows]
    return [Row(m, t, rho) for m in methods or getattr(args, "methods", ["baseline"])
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
    episode) under ``out`` (default --out), on ``workers`` processes (default --workers, or
    Ray with --ray), with the sweep's console (``sweep_console``: a bar of the agent steps of
    every trial, a trial's budget its timeout); a stored trial is reused only when it fits
    ``schema``; an MPC episode writes its blow-up captures under ``out`` and, with
    --keep-controls, keeps its controls (a stored trial without them is rerun). Returns their
    records and the sweep's result (``failed``: {key: error}, ``commits``: code commits of the
    records)."""
    out, keep = out or args.out, getattr(args, "keep_controls", False)
    if keep and fn is None:
        schema = replace(schema, wanted=schema.wanted + CONTROLS_FIELDS)
    steps = {t.key: int(t.params.get("timeout") or task_defaults(t.params["task"])[1])
             for t in trials}
    res = run_with_console(
        fn or CapturingTrial(str(out), run_trial, keep), trials, out, unit="step",
        desc=f"{args.task} MPC steps", steps=lambda t: steps[t.key],
        held=lambda t: steps[t.key] if is_finished(out, t.key, reuse=reuse_mode(args),
                                                   schema=schema) else 0,
        workers=workers or args.workers, ray_address=None if workers else args.ray,
        fresh=args.fresh, reuse=reuse_mode(args), schema=schema)
    for key, err in res.failed.items():
        print(f"FAILED {key}: {err}", file=sys.stderr)
    wanted = {t.key for t in trials}
    return [r for k, r in res.records.items() if k in wanted], res


def write_table(out: Path, task: str, methods: dict, feedback: dict | None = None) -> None:
    rows = [("row", "MPC cost (normalised) mean", "CI90 +-", "median (all)",
             "median ratio", "opt. time (ms)", "DoFs", "lag (steps)", "success",
             "goal dist. (m, median)", "outliers", "trials")]

    def num(x, digits=2):
        """A number to the table, or n/a when there is none (no baseline for the pairing)."""
        return "n/a" if x is None or x != x else f"{x:.{digits}f}"

    for name, m in methods.items():
        rows.append((name, num(m["mpc_cost_normalised_mean"]),
                     num(m["mpc_cost_normalised_ci90"]),
                     num(m["mpc_cost_normalised_median"]), num(m["mpc_cost_median_ratio"]),
                     f"{m['opt_ms_mean']:.0f}", f"{m['n_dofs_mean']:.1f}",
                     f"{m['lag_steps_mean']:.0f}", f"{m['success_rate']:.2f}",
                     f"{m['goal_distance_end_median']:.3f}", str(m["outliers"]),
                     str(m["n_trials"])))
    with open(out / "table1.csv", "w", newline="") as f:
        csv.writer(f).writerows(rows)
    lines = [f"Task: {task}. Normalised by baseline on the same instance; mean and 90% CI "
             f"exclude outliers (goal object > {OUTLIER_DISTANCE} m from the goal) and unstable "
             "trials.", "",
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


# ---------------------------------------------------------------------------------- plots

def first_seed(records: list[dict], rows) -> dict:
    """{row label: result of its lowest seed} for each row (``row_label``) in ``rows``."""
    out = {}
    for r in sorted(records, key=lambda r: r["params"]["seed"]):
        label = row_label(r["params"])
        if label in rows and label not in out:
            out[label] = {**r["result"], "seed": r["params"]["seed"], "params": r["params"]}
    return {k: out[k] for k in rows if k in out}


def write_plots(out: Path, task: str, records: list[dict], rows, render: bool = True) -> None:
    """mpc_dofs.png, mpc_goal_distance.png and (``render``) final_<row>.png of the first seed
    of each row. Trial files written before a result held the goal distance per step or the
    final state are left out of those pictures; a failed render is logged, not raised."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from dopt.tasks.push.costs import PushWeights

    first = first_seed(records, rows)
    if not first:
        return
    # colours and, as rows often overlap (every method starts alike), dashes and widths
    style = {row: dict(color=plt.get_cmap("tab10")(i % 10), lw=2.6 - 0.4 * (i % 4),
                       ls=("-", "--", "-.", ":")[i % 4]) for i, row in enumerate(first)}
    fig, ax = plt.subplots(figsize=(7, 4))
    for row, r in first.items():
        if not r["n_dofs"]:
            continue
        # each |C| holds from its optimisation's start to the next one's (the last: to the end)
        x = list(r["opt_step"]) + [max(r["steps"], r["opt_step"][-1] if r["opt_step"] else 0)]
        y = list(r["n_dofs"]) + list(r["n_dofs"][-1:])
        ax.step(x, y, where="post", **style[row],
                label=f"{row} (mean {r['dofs_mean']:.1f}, {len(r['n_dofs'])} optimisations)")
    _save(fig, ax, out / "mpc_dofs.png", "agent step at which the optimisation started",
          "active DoFs |C|", f"{task}: DoFs optimised over the episode (first seed of each "
          "method)")

    fig, ax = plt.subplots(figsize=(7, 4))
    for row, r in first.items():
        d = r.get("goal_distance") or []
        if d:
            stride = r.get("goal_distance_stride", 1)
            x = [min(i * stride, r["steps"]) for i in range(len(d))]
            ax.plot(x, d, **style[row],
                    label=f"{row}: {'success' if r['success'] else 'no success'}, "
                          f"end {d[-1]:.3f} m")
    ax.axhline(PushWeights().success_radius, color="k", ls="--", lw=1,
               label="success radius")
    _save(fig, ax, out / "mpc_goal_distance.png", "executed agent step",
          "goal object's distance to the goal (m)",
          f"{task}: goal distance over the episode (first seed of each method)")

    if not render:
        return
    try:
        for row, r in first.items():
            if r.get("final_state"):
                write_final(out / f"final_{row.replace(' +', '_')}.png", task, row, r)
    except Exception as e:                # the numbers are written; a missing GL only loses images
        log.warning("rendering failed (%s: %s); set MUJOCO_GL=egl", type(e).__name__, e)


def final_panels(params: dict, final_state, size=(640, 480)):
    """(close-up from above, oblique) images (2, H, W, 3) of a push task's final state: the
    close-up frames the objects, the goal and the pusher, leaves the arm out and marks where
    each object (a soft body: its mean vertex) started (white rings; the goal object's black)
    with a line to where it ended, and the goal (x); the oblique view shows the whole scene."""
    import mujoco

    from dopt import render
    from dopt.scene import Scene
    settings, seed, _ = split_params(params)
    tm = settings.build_task(seed)
    m = tm.model
    spec = Scene(m).layout.spec
    fovy, (w, h) = m.vis.global_.fovy, size
    data = mujoco.MjData(m)

    def body_xpos(state):
        mujoco.mj_setState(m, data, np.asarray(state, dtype=float), spec)
        mujoco.mj_forward(m, data)
        return data.xpos.copy(), data.site(tm.ee_site).xpos.copy()

    # the objects: the goal object, a soft body that is not it, the distractors; each a list
    # of bodies (a soft body's vertices) whose mean is marked
    objects = [tm.goal_bodies]
    if tm.soft_body and tm.soft_body != tm.goal_object:
        f = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_FLEX, tm.soft_body)
        objects.append([int(b) for b in m.flex_vertbodyid[
            m.flex_vertadr[f]:m.flex_vertadr[f] + m.flex_vertnum[f]]])
    objects += [[m.body(name).id] for name in tm.distractors]
    (x0, _), (x1, ee) = body_xpos(tm.initial_state), body_xpos(final_state)
    start = np.array([x0[b].mean(axis=0) for b in objects])
    end = np.array([x1[b].mean(axis=0) for b in objects])
    goal = np.asarray(tm.goal_position, dtype=float)
    # frame every object whole: each body +- its geoms' bounding radius along every axis
    bodies = np.concatenate(objects)
    radius = np.array([m.geom_rbound[m.geom_bodyid == b].max(initial=0.0) for b in bodies])
    box = (np.concatenate([x0[bodies], x1[bodies]])[:, None, :]
           + np.tile(radius, 2)[:, None, None] * np.concatenate([np.eye(3), -np.eye(3)]))
    # and the goal region (its marker, about a cylinder's size)
    region = goal + np.array([[x, y, z] for x in (-.06, .06) for y in (-.06, .06)
                              for z in (0.0, 0.12)])
    close = render.fit_camera(np.concatenate([box.reshape(-1, 3), region, [ee]]), *render.TOP,
                              fovy=fovy, aspect=w / h, fill=0.85, min_extent=0.3)
    arm = np.flatnonzero(np.isin(m.geom_bodyid, [m.body(b).id for b in tm.robot_bodies[:-1]]))
    top = render.render(m, final_state, spec, close, w, h, hide_geoms=arm)
    a, b = render.project(start, close, w, h, fovy), render.project(end, close, w, h, fovy)
    top = render.draw_segments(top, a, b, (20, 20, 20), 2.0)
    top = render.draw_markers(top, a[1:], (255, 255, 255), 7, "ring")
    top = render.draw_markers(top, a[:1], (20, 20, 20), 9, "ring", outline=(255, 255, 255))
    top = render.draw_markers(top, render.project(goal[None], close, w, h, fovy), (20, 20, 20),
                              7, "cross", outline=(255, 255, 255))
    whole = render.fit_camera(np.concatenate([x1[1:], [goal]]), *render.OBLIQUE, fovy=fovy,
                              aspect=w / h)
    return np.stack([top, render.render(m, final_state, spec, whole, w, h)])


def write_final(path: Path, task: str, row: str, r: dict) -> None:
    """final_<row>.png: ``final_panels`` side by side, titled with the method, seed, MPC cost,
    success and the final goal distance."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = final_panels(r["params"], r["final_state"])
    n, h, w = panels.shape[:3]
    top, gap, bottom = 56, 6, 30
    W, H = n * w + (n - 1) * gap, top + h + bottom
    fig = plt.figure(figsize=(W / 100, H / 100), dpi=100)
    for i, title in enumerate(("objects from above (arm hidden)", "whole scene")):
        ax = fig.add_axes((i * (w + gap) / W, bottom / H, w / W, h / H))
        ax.imshow(panels[i], interpolation="none")
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_title(title, fontsize=11, pad=3)
    fig.suptitle(f"{task}: {row}, seed {r['seed']}, MPC cost {r['mpc_cost']:.3g}, "
                 f"{'success' if r['success'] else 'no success'}, goal distance "
                 f"{r['goal_distance_start']:.3f} -> {r['goal_distance_end']:.3f} m "
                 f"({r['steps']} steps)", y=1 - 6 / H, fontsize=12, fontweight="bold")
    fig.text(0.25, 6 / H, "ring: start of each object (black: the goal object), line: to its "
             "end; x: the goal", ha="center", fontsize=10)
    fig.savefig(path, dpi=100)
    plt.close(fig)


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
               "blowups": blowup_captures(args.out, [t.key for t in trials])}
    write_summary(summary, args.out, args.record, "experiments/mpc.py", argv)
    write_table(args.out, args.task, rows, summary.get("feedback_effect"))
    write_plots(args.out, args.task, records, list(rows), render=not args.no_render)
    print((args.out / "table1.md").read_text())
    return 1 if failed else 0


def _save(fig, ax, path: Path, xlabel: str, ylabel: str, title: str) -> None:
    """Label, grid and legend one plot, write it to ``path`` and close it."""
    import matplotlib.pyplot as plt

    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
