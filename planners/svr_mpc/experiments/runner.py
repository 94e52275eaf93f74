"""Running the MPC trials of an experiment: the sweep (``run``: resumable trial files under
OUT/trials, on a process pool or Ray) with its console (an estimate up front, ``agent_seconds``;
a bar of agent steps; each finished trial's result, ``describe_result``), the schema a stored
trial must fit to be reused (``SCHEMA``) and which trials keep their controls for dopt-view's
exact replay (``kept_controls``)."""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

from dopt.lab.console import run_with_console
from dopt.lab.record import reuse_mode
from dopt.lab.sweep import Schema, SweepResult, is_finished
from dopt.tasks import PUSH_TASKS
from planners.svr_mpc import (
    CLOCK_MODEL_MS,
    CONTROLS_FIELDS,
    CapturingTrial,
    KeptControls,
    authors_clock,
    run_trial,
    task_defaults,
)
from planners.svr_mpc.trial_names import trial_aliases, trial_identity

#: what a stored MPC trial must hold to be reused: the fields the summary and plots read,
#: the numbers among them finite (a cost of +inf once failed every rerun in the summary), and
#: params that name the trial they are stored for (``trial_identity``: not the threads); a
#: trial written before the one identity is found under its older name (``trial_aliases``)
SCHEMA = Schema(result=("mpc_cost", "success", "steps", "goal_distance_start",
                        "goal_distance_end", "opt_ms_mean", "dofs_mean", "n_dofs", "opt_step",
                        "lag_steps_mean", "unstable"),
                finite=("mpc_cost", "steps", "goal_distance_start", "goal_distance_end",
                        "opt_ms_mean", "dofs_mean", "lag_steps_mean"),
                identity=trial_identity, aliases=trial_aliases)


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


def _sizes(task: str) -> tuple[float, int]:
    """dt (s) and nv of the task (its ``PushTaskSpec``: no model is built)."""
    spec = PUSH_TASKS[task]
    return float(spec.dt), int(spec.nv)


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
