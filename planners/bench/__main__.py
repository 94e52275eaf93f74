"""python -m planners.bench {ilqr,clock,cem,cem-limit,cloth-budget,settle,cloth,rope,reference}
[options]: print timings as JSON (cem-limit: a table, one line per cloth size; --record
writes its rows as JSON)."""

from __future__ import annotations

import argparse
import sys

from dopt.bench.cli import add_common_args, add_record_arg, print_json, write_record
from dopt.lab.cli import (
    EPILOG,
    ArgumentParser,
    choices_type,
    guarded,
    int_at_least,
    nonneg_int,
    number_list,
    positive_float,
    positive_int,
)
from planners.bench.budget import FOLDS
from planners.bench.reference import CHECKS, PRESETS


def _add_ilqr(sub) -> None:
    """The ``ilqr`` subcommand's flags."""
    p = sub.add_parser("ilqr", help="one iLQR(-SVR) iteration per DoF-selection method")
    add_common_args(p)
    p.add_argument("--methods", default="baseline,rand,naive,svr-sum,svr-svd",
                   help="comma-separated methods (default %(default)s)")
    p.add_argument("--rho", type=positive_float, default=1.0, help="SVR importance threshold")
    p.add_argument("--theta", type=nonneg_int, default=None,
                   help="random DoFs re-added per iteration (rand: DoFs besides the robot); "
                        "default: the paper's Table 1 value per method (rand 5, svr 10)")
    p.add_argument("--keypoints", default="every",
                   help="comma-separated derivative variants: every, skip<K>, adaptive "
                        "(default %(default)s)")
    p.add_argument("--box-qp", action="store_true",
                   help="control limits in the backward pass (mju_boxQP)")
    add_record_arg(p, "ilqr_bench")
    p.add_argument("--iterations", type=positive_int, default=5,
                   help="timed iterations per method")
    p.add_argument("--warmup", type=nonneg_int, default=3,
                   help="untimed iterations per method first")


def _add_clock(sub) -> None:
    """The ``clock`` subcommand's flags."""
    p = sub.add_parser("clock", help="CPU time of an MPC optimisation against |C| per push "
                                     "task, and the model clock's fit ms = a + b |C|")
    p.add_argument("--tasks", default="clutter,soft,soft_rigid",
                   help="comma-separated push tasks (default %(default)s)")
    p.add_argument("--sizes", type=int_at_least(2), default=6,
                   help="DoF counts per task, 7 to nv")
    p.add_argument("--iterations", type=positive_int, default=8,
                   help="timed optimisations per count")
    p.add_argument("--warmup", type=nonneg_int, default=2, help="untimed optimisations first")
    p.add_argument("--nominal-threads", type=positive_float, default=2.0,
                   help="threads the CPU time is divided by (default %(default)s)")
    p.add_argument("--seed", type=nonneg_int, default=0, help="seed of the task instances")


def _add_cem(sub) -> None:
    """The ``cem`` subcommand's flags."""
    p = sub.add_parser("cem", help="one CEM iteration of the cloth or rope pick-and-place task")
    add_common_args(p, task="cloth")
    p.add_argument("--n", type=int_at_least(2), default=None,
                   help="cloth particles per side (default 12) or rope particles (default 40)")
    p.add_argument("--P", type=positive_int, default=32, help="CEM population")
    p.add_argument("--H", type=positive_int, default=2, help="actions per sequence")
    p.add_argument("--bound", type=positive_float, default=None,
                   help="picker displacement bound per axis, m (default: cloth 0.3, rope 0.1)")


def _add_cem_limit(sub) -> None:
    """The ``cem-limit`` subcommand's flags."""
    p = sub.add_parser("cem-limit", help="CEM iterations of the paper protocol's cloth "
                                         "diagonal fold per cloth size against the physical "
                                         "limit (steps x one mj_step / cores), and where the "
                                         "rest goes")
    p.add_argument("--sizes", type=number_list(int, 3, "particles per side"),
                   default=[10, 15, 20],
                   help="comma-separated cloth particles per side (default 10,15,20)")
    p.add_argument("--threads", type=nonneg_int, default=0,
                   help="simulation threads (0: all cores)")
    p.add_argument("--iterations", type=positive_int, default=2,
                   help="timed CEM iterations per size (default %(default)s)")
    p.add_argument("--candidates", choices=("keys", "all"), default="keys",
                   help="plan over the key particles (CEM(Simple)) or all particles "
                        "(CEM(Original)) (default %(default)s)")
    p.add_argument("--step-samples", type=positive_int, default=2000,
                   help="mj_step calls timed for the step cost (default %(default)s)")
    p.add_argument("--seed", type=nonneg_int, default=0, help="seed of the CEM plan")
    add_record_arg(p, "cem_limit", "as each size finishes")


def _add_cloth_budget(sub) -> None:
    """The ``cloth-budget`` subcommand's flags."""
    p = sub.add_parser("cloth-budget", help="the same CEM samples of the paper protocol's "
                                            "cloth folds simulated with the fixed move (one "
                                            "thread) and with moves sized per sample (all "
                                            "cores): steps, CPU and wall ratios, paired cost "
                                            "differences, a Fig. 7 panel's projected time")
    p.add_argument("--n", type=int_at_least(3), default=20,
                   help="cloth particles per side (default %(default)s)")
    p.add_argument("--folds", type=choices_type(FOLDS, "folds"), default=",".join(FOLDS),
                   help="comma-separated folds (default %(default)s)")
    p.add_argument("--iterations", type=positive_int, default=3,
                   help="CEM iterations whose samples are simulated both ways (default "
                        "%(default)s)")
    p.add_argument("--population", type=int_at_least(2), default=None,
                   help="CEM population (default: the protocol's)")
    p.add_argument("--threads", type=nonneg_int, default=0,
                   help="simulation threads of the sized moves (0: all cores); the fixed "
                        "move runs on one")
    p.add_argument("--seed", type=nonneg_int, default=0, help="seed of the CEM plan")
    p.add_argument("--quick", action="store_true",
                   help="a smoke run: an 8 x 8 cloth, one iteration of 4 samples per fold")
    add_record_arg(p, "cloth_budget", "as each fold finishes")


def _add_settle(sub) -> None:
    """The ``settle`` subcommand's flags."""
    p = sub.add_parser("settle", help="what settling CEM's sampled rollouts until at rest cuts "
                                      "and changes, per cloth size and rest speed (the paper "
                                      "protocol's diagonal fold)")
    p.add_argument("--sizes", type=number_list(int, 3, "particles per side"), default=[10, 20],
                   help="comma-separated cloth particles per side (default 10,20)")
    p.add_argument("--speeds", type=number_list(float, 0.0, "rest speeds", strict=True),
                   default=None, help="comma-separated rest speeds, m/s (default "
                                      "0.002,0.005,0.01,0.02)")
    p.add_argument("--samples", type=int_at_least(2), default=32,
                   help="random action sequences per size (default %(default)s)")
    p.add_argument("--threads", type=nonneg_int, default=0,
                   help="simulation threads (0: all cores)")
    p.add_argument("--seed", type=nonneg_int, default=0, help="seed of the actions")
    add_record_arg(p, "settle_rest", "as each size finishes")


def _add_physics(sub) -> None:
    """The ``cloth`` and ``rope`` subcommands' flags."""
    for task in ("cloth", "rope"):
        p = sub.add_parser(task, help=f"the {task} physics presets: speed, blow-ups per 1000 "
                                      f"random actions, strain, scripted error")
        add_common_args(p)
        p.add_argument("--sizes", type=number_list(int, 2, "particle counts"), default=None,
                       help="comma-separated particles per side / along the rope (default: "
                            "the n of the task's first preset, cloth 12, rope 40)")
        p.add_argument("--settings", default=None,
                       help="comma-separated setting names (default: all of "
                            "planners.bench.physics' table)")
        p.add_argument("--actions", type=positive_int, default=1000,
                       help="random pick-and-place actions per setting and size")
        p.add_argument("--no-scripted", action="store_true",
                       help="skip the scripted policy on the task's goals")
        p.add_argument("--picker-speeds", default=None,
                       type=number_list(float, 0.0, "picker speeds", strict=True),
                       help="comma-separated picker speeds (m/s, the average on the longest "
                            "move), a row each (default: the picker's 0.5)")


def _add_reference(sub) -> None:
    """The ``reference`` subcommand's flags."""
    p = sub.add_parser("reference", help="the rope and cloth physics presets against analytic "
                                         "references: catenary sag and shape, cantilever "
                                         "deflection, a hanging sheet's sag; and their cost")
    p.add_argument("--presets", type=choices_type(PRESETS, "presets"), default=",".join(PRESETS),
                   help="comma-separated physics presets (default %(default)s)")
    p.add_argument("--checks", type=choices_type(tuple(CHECKS), "checks"),
                   default=",".join(CHECKS), help="comma-separated references (default "
                                                  "%(default)s)")
    p.add_argument("--rope-n", type=int_at_least(3), default=None,
                   help="rope particles of the catenary (default: the preset's, 40)")
    p.add_argument("--cloth-n", type=int_at_least(3), default=None,
                   help="cloth particles per side of the sheet (default: the preset's, 16)")
    add_record_arg(p, "physics_reference")


def parser() -> argparse.ArgumentParser:
    """The command line: one subcommand per bench."""
    ap = ArgumentParser(prog="python -m planners.bench", description=__doc__,
                        epilog=EPILOG)
    sub = ap.add_subparsers(dest="bench", required=True)

    for add in (_add_ilqr, _add_clock, _add_cem, _add_cem_limit, _add_cloth_budget,
                _add_settle, _add_physics, _add_reference):
        add(sub)
    return ap


def run(args) -> int:
    """Run the bench ``args.bench`` names and print (or record) its result."""
    if args.bench == "ilqr":
        from planners.bench.ilqr import bench_ilqr
        out = bench_ilqr(args.task, args.methods.split(","), args.rho, args.theta,
                         args.iterations, args.warmup, args.threads, args.seed,
                         tuple(args.keypoints.split(",")), args.box_qp)
        if args.record:
            write_record(args.record, "ilqr_bench", out, task=args.task)
    elif args.bench == "clock":
        from planners.bench.clock import bench_clock
        out = bench_clock(args.tasks.split(","), args.sizes, args.iterations, args.warmup,
                          args.nominal_threads, args.seed)
    elif args.bench == "cem":
        from planners.bench.cem import bench_cem
        out = bench_cem(args.task, args.n, args.P, args.H, args.bound, args.threads,
                        args.repeats, args.seed)
    elif args.bench == "cem-limit":
        from planners.bench.cem import bench_cem_limit, limit_table

        def on_row(out: dict) -> None:
            rows = out["rows"]
            print(limit_table(rows[-1:], header=len(rows) == 1), flush=True)
            if args.record:
                write_record(args.record, "cem_limit", rows,
                             **{k: v for k, v in out.items() if k != "rows"})

        bench_cem_limit(args.sizes, args.threads, args.iterations, args.seed, args.candidates,
                        args.step_samples, on_row=on_row)
        return 0
    elif args.bench == "cloth-budget":
        from planners.bench.budget import bench_cloth_budget

        def on_fold(out: dict) -> None:
            if args.record:
                write_record(args.record, "cloth_budget", list(out["folds"].values()),
                             **{k: v for k, v in out.items() if k != "folds"})

        out = bench_cloth_budget(args.n, args.folds, args.iterations, args.population,
                                 args.seed, args.threads, args.quick, on_fold=on_fold)
    elif args.bench == "settle":
        from planners.bench.settle import SPEEDS, bench_settle

        def on_size(out: dict) -> None:
            if args.record:
                write_record(args.record, "settle_rest", out["rows"],
                             **{k: v for k, v in out.items() if k != "rows"})

        out = bench_settle(args.sizes, args.speeds or SPEEDS, args.samples, args.threads,
                           args.seed, on_row=on_size)["rows"]
    elif args.bench in ("cloth", "rope"):
        from planners.bench.physics import bench_physics
        out = bench_physics(args.bench, args.sizes,
                            args.settings.split(",") if args.settings else None, args.actions,
                            args.threads, args.seed, scripted=not args.no_scripted,
                            picker_speeds=args.picker_speeds or [None])
    elif args.bench == "reference":
        from planners.bench.reference import bench_reference
        out = bench_reference(args.presets, args.checks, args.rope_n, args.cloth_n)
        if args.record:
            write_record(args.record, "physics_reference", out["rows"],
                         presets=out["presets"])
        out = out["rows"]
    print_json(out)
    return 0


@guarded("python -m planners.bench")
def main(argv=None) -> int:
    return run(parser().parse_args(argv))

if __name__ == "__main__":
    sys.exit(main())
