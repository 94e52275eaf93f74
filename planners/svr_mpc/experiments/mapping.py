"""The experiments' flags (``flags``) as settings and trials: each Table 1 row's
``SVRMPCSettings`` under the preset and the flags that override it (``settings_of``), the
rows of the flags (``grid``), the sweep's trials with their keys (``make_trials``: the keys
of the committed trials, ``trial_key``) and the protocol a summary records (``protocol``)."""

from __future__ import annotations

from dataclasses import asdict, replace

from dopt.lab.sweep import Trial
from planners.svr import METHODS, paper_theta
from planners.svr_mpc import (
    TABLE1_ROWS,
    Derivatives,
    Row,
    SVRMPCSettings,
    parse_row,
    row_label,
    task_defaults,
    trial_key,
    trial_params,
)

#: --feedback -> the feedback settings each trial runs under
FEEDBACK = {"off": (False,), "on": (True,), "both": (False, True)}


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


def grid(args, rules=None, rhos=None, thetas=None) -> list[Row]:
    """The rows of the flags: those of --rows (default with --preset paper or authors and no
    --rules: the nine of Table 1; ``parse_row``), else every (rule, rho, theta) of the
    arguments or flags (--rules' default: all five DoF-selection rules, ``METHODS``), without
    variants of their own."""
    rows, flag = getattr(args, "rows", None), getattr(args, "rules", None)
    if (rows is None and rules is None and flag is None
            and args.preset in ("paper", "authors") and hasattr(args, "rows")):
        rows = list(TABLE1_ROWS)
    if rows:
        return [parse_row(r) for r in rows]
    flag = flag or (list(METHODS) if hasattr(args, "rules") else ["baseline"])
    return [Row(m, t, rho) for m in rules or flag
            for rho in rhos or [getattr(args, "rho", 1.0)]
            for t in thetas or [_theta(getattr(args, "theta", None), m)]]


def make_trials(args, rules=None, rhos=None, thetas=None, **override) -> list[Trial]:
    """Every (seed, row, feedback) trial of the flags (``grid``; ``rules``, ``rhos``,
    ``thetas``: the grid's in place of the flags'), each with its key (``trial_key``, the
    committed trials'); ``override``: settings fields replaced in every trial (e.g.
    clock="real")."""
    out = []
    for seed in range(args.seed, args.seed + args.trials):
        for row in grid(args, rules, rhos, thetas):
            for feedback in FEEDBACK[args.feedback]:
                s = replace(settings_of(args, row, feedback), **override)
                p = trial_params(s, seed, row.optimiser)
                out.append(Trial(trial_key(p), p))
    return out


def _theta(theta: int | None, method: str) -> int:
    """--theta, or the paper's Table 1 value for the rule (rand 5, svr 10; unused else)."""
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
