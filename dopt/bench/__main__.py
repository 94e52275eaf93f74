"""python -m dopt.bench {rollout,derivatives,cloth-steps,cloth-warp} [options]: print timings
as JSON.

The planner benches (ilqr, cem) are ``python -m planners.bench``."""

from __future__ import annotations

import sys

from dopt.bench.cli import add_common_args, add_record_arg, print_json, write_record
from dopt.lab.cli import EPILOG, ArgumentParser, guarded, nonneg_int, number_list, positive_int

#: a comma list of particles per side (a cloth needs two per side)
SIZES = number_list(int, 2, "particles per side")


@guarded("python -m dopt.bench")
def main(argv=None) -> int:
    ap = ArgumentParser(prog="python -m dopt.bench", description=__doc__,
                        epilog=EPILOG)
    sub = ap.add_subparsers(dest="bench", required=True)

    p = sub.add_parser("rollout", help="P open-loop rollouts of T steps in one batched call")
    add_common_args(p)
    p.add_argument("--P", type=positive_int, default=64, help="number of rollouts")
    p.add_argument("--T", type=positive_int, default=80, help="steps per rollout")

    p = sub.add_parser("derivatives", help="reduced FD derivatives over a horizon vs full set")
    add_common_args(p)
    p.add_argument("--T", type=positive_int, default=80, help="horizon")
    p.add_argument("--objects", type=nonneg_int, default=2,
                   help="objects in the active set besides the robot (2 -> |C| = 7 + 12 = 19)")
    p.add_argument("--centered", action="store_true", help="centred differences")

    p = sub.add_parser("cloth-steps", help="ms per cloth step by MuJoCo stage and the warnings, "
                                           "per physics preset and resolution")
    p.add_argument("--sizes", type=SIZES, default="12,25,40,64,100",
                   help="comma-separated particles per side (default %(default)s)")
    p.add_argument("--presets", default="default,fast,accurate",
                   help="comma-separated cloth physics presets (default %(default)s)")
    p.add_argument("--variants", default="",
                   help="comma-separated settings tried on top of the first preset "
                        "(dopt.bench.cloth_steps.VARIANTS, e.g. \"iterations 300,dt 5 ms\")")
    add_record_arg(p, "cloth_steps")

    p = sub.add_parser("cloth-warp", help="a cloth action on MuJoCo Warp (GPU), W worlds in "
                                          "lockstep, beside MuJoCo's CPU step")
    p.add_argument("--sizes", type=SIZES, default="20,100",
                   help="comma-separated particles per side (default %(default)s)")
    p.add_argument("--nworlds", type=number_list(int, 1, "world counts"), default="1,32,1024",
                   help="comma-separated batch sizes W (default %(default)s)")
    p.add_argument("--preset", default="default", help="cloth physics preset")
    p.add_argument("--device", default=None, help="warp device (default: warp's, a GPU if any)")
    p.add_argument("--preload-workers", type=nonneg_int, default=0,
                   help="on a GPU, compile MuJoCo Warp's kernel modules on this many threads "
                        "before the first size (default 0: each kernel compiles at first use)")
    add_record_arg(p, "cloth_warp", "after the CPU run and each batch size")

    args = ap.parse_args(argv)
    if args.bench == "rollout":
        from dopt.bench.rollout import bench_rollout
        out = bench_rollout(args.task, args.P, args.T, args.threads, args.repeats, args.seed)
    elif args.bench == "derivatives":
        from dopt.bench.rollout import bench_derivatives
        out = bench_derivatives(args.task, args.objects, args.T, args.threads, args.repeats,
                                args.centered, args.seed)
    elif args.bench == "cloth-steps":
        from dopt.bench.cloth_steps import bench_cloth_steps
        out = bench_cloth_steps(args.sizes, args.presets.split(","),
                                [v for v in args.variants.split(",") if v])
        if args.record:
            write_record(args.record, "cloth_steps", out)
    elif args.bench == "cloth-warp":
        from dopt.bench.cloth_warp import bench_cloth_warp

        def on_rows(rows: list[dict]) -> None:
            if args.record:
                write_record(args.record, "cloth_warp", rows)

        out = bench_cloth_warp(args.sizes, args.nworlds, args.preset, args.device,
                               on_rows=on_rows, preload_workers=args.preload_workers)
    print_json(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
