"""python -m dopt.bench {rollout,derivatives,ilqr,cem} [options]: print timings as JSON."""

from __future__ import annotations

import argparse
import json
import sys


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m dopt.bench", description=__doc__)
    sub = ap.add_subparsers(dest="bench", required=True)

    def common(p, task="clutter"):
        p.add_argument("--task", default=task, help="task scene from dopt.tasks (default %(default)s)")
        p.add_argument("--threads", type=int, default=0, help="simulation threads (0: all cores)")
        p.add_argument("--repeats", type=int, default=5, help="timed repeats; the best is kept")
        p.add_argument("--seed", type=int, default=0, help="seed of the scene layout and controls")

    p = sub.add_parser("rollout", help="P open-loop rollouts of T steps in one batched call")
    common(p)
    p.add_argument("--P", type=int, default=64, help="number of rollouts")
    p.add_argument("--T", type=int, default=80, help="steps per rollout")

    p = sub.add_parser("derivatives", help="reduced FD derivatives over a horizon vs full set")
    common(p)
    p.add_argument("--T", type=int, default=80, help="horizon")
    p.add_argument("--objects", type=int, default=2,
                   help="objects in the active set besides the robot (2 -> |C| = 7 + 12 = 19)")
    p.add_argument("--centered", action="store_true", help="centred differences")

    p = sub.add_parser("ilqr", help="one iLQR(-SVR) iteration per DoF-selection method")
    common(p)
    p.add_argument("--methods", default="baseline,rand,naive,svr-sum,svr-svd",
                   help="comma-separated methods (default %(default)s)")
    p.add_argument("--rho", type=float, default=1.0, help="SVR importance threshold")
    p.add_argument("--theta", type=int, default=None,
                   help="random DoFs re-added per iteration (rand: DoFs besides the robot); "
                        "default: the paper's Table 1 value per method (rand 5, svr 10)")
    p.add_argument("--iterations", type=int, default=5, help="timed iterations per method")
    p.add_argument("--warmup", type=int, default=3, help="untimed iterations per method first")

    p = sub.add_parser("cem", help="one CEM iteration of the cloth or rope pick-and-place task")
    common(p, task="cloth")
    p.add_argument("--n", type=int, default=None,
                   help="cloth particles per side (default 12) or rope particles (default 40)")
    p.add_argument("--P", type=int, default=32, help="CEM population")
    p.add_argument("--H", type=int, default=2, help="actions per sequence")
    p.add_argument("--bound", type=float, default=None,
                   help="picker displacement bound per axis, m (default: cloth 0.3, rope 0.1)")

    args = ap.parse_args(argv)
    if args.bench == "rollout":
        from dopt.bench.rollout import bench_rollout
        out = bench_rollout(args.task, args.P, args.T, args.threads, args.repeats, args.seed)
    elif args.bench == "derivatives":
        from dopt.bench.rollout import bench_derivatives
        out = bench_derivatives(args.task, args.objects, args.T, args.threads, args.repeats,
                                args.centered, args.seed)
    elif args.bench == "ilqr":
        from dopt.bench.ilqr import bench_ilqr
        out = bench_ilqr(args.task, args.methods.split(","), args.rho, args.theta,
                         args.iterations, args.warmup, args.threads, args.seed)
    elif args.bench == "cem":
        from dopt.bench.cem import bench_cem
        out = bench_cem(args.task, args.n, args.P, args.H, args.bound, args.threads,
                        args.repeats, args.seed)
    for obj in out if isinstance(out, list) else [out]:
        print(json.dumps(obj))
    return 0


if __name__ == "__main__":
    sys.exit(main())
