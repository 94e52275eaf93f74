"""Why CEM(Random) is better or worse than CEM(Original) on a fold: the reach of each seed's
random candidate set against its final cost (``planners.pick_place.random_reach``), from a
Fig. 7 run's committed trials (nothing is simulated; each trial's candidates are re-drawn
from its seed).

Writes OUT/summary.json (experiment "random_reach"): per run folder, the fold, each
CEM(Random) trial's seed, final cost, candidates and reach per stage, and the summary (the
Spearman correlation of cost and reach, blind trials observed and expected, the mean cost of
blind and seeing trials) beside the mean final cost of CEM(Original) and CEM(Simple) of the
same run. Exits 2 on a bad flag, 1 when a folder holds no CEM(Random) trial.

    python experiments/random_reach.py docs/results/runs/fig7-cloth-diagonal \\
        docs/results/runs/fig7-cloth-side --out results/random_reach \\
        --record docs/results/fig7-random-reach.json
"""

from __future__ import annotations

import sys
from pathlib import Path

from dopt.lab.cli import EPILOG, ArgumentParser, existing_dir, guarded, output_dir, positive_float
from dopt.lab.record import record_problem, write_summary
from dopt.lab.sweep import load_finished
from planners.pick_place.random_reach import (
    MOVING,
    random_reach,
    reach_summary,
    settings_groups,
)


def parse_args(argv):
    ap = ArgumentParser(prog="random_reach.py", description=__doc__.split("\n\n")[0],
                        epilog=EPILOG)
    ap.add_argument("runs", nargs="+", type=existing_dir,
                    help="Fig. 7 run folders (each with trials/ of a pick-and-place sweep)")
    ap.add_argument("--moving", type=positive_float, default=MOVING,
                    help=f"metres a particle must move in a stage to count (default {MOVING})")
    ap.add_argument("--out", type=output_dir, required=True, help="the output folder")
    ap.add_argument("--record", type=Path, default=None,
                    help="also write the summary to this path (committed code only)")
    return ap.parse_args(argv)


def folder_report(folder: Path, moving: float) -> list[dict]:
    """The reach of one run folder's CEM(Random) trials, beside the other methods' means: one
    report per setting the folder's trials ran (a multi-layer fold's folder may hold its
    chained and its prepared start; ``settings_groups``), each naming its fold start."""
    groups = [g for g in settings_groups(load_finished(folder).values())
              if any(r["params"].get("method") == "random" for r in g)]
    if not groups:
        raise ValueError(f"{folder}: no CEM(Random) trial under trials/")
    return [_group_report(folder, records, moving) for records in groups]


def _group_report(folder: Path, records: list[dict], moving: float) -> dict:
    trials = random_reach(records, moving)
    settings = records[0]["params"]["settings"]
    means = {}
    for method in ("simple", "original", "random"):
        costs = [r["result"]["final_cost"] for r in records
                 if r["params"].get("method") == method]
        means[method] = sum(costs) / len(costs) if costs else None
    return {"folder": str(folder), "task": settings["task"], "goal": settings["goal"],
            "n": settings["n"], "fold_start": settings.get("fold_start"),
            "mean_final_cost": means, "summary": reach_summary(trials),
            "trials": [t.to_dict() for t in trials]}


@guarded("random_reach.py")
def main(argv=None) -> int:
    args = parse_args(sys.argv[1:] if argv is None else argv)
    if problem := record_problem(args.record, args.out):
        print(f"random_reach.py: error: {problem}", file=sys.stderr)
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    runs = [r for f in args.runs for r in folder_report(Path(f), args.moving)]
    for r in runs:
        s = r["summary"]
        start = f" ({r['fold_start']} start)" if r["fold_start"] else ""
        print(f"{r['task']} {r['goal']} {r['n']}{start}: Spearman rho {s['spearman_rho']}, "
              f"blind {s['blind']} of {s['trials']} (expected {s['blind_expected']:.2f})")
    write_summary({"experiment": "random_reach", "moving": args.moving, "runs": runs},
                  args.out, args.record, "experiments/random_reach.py", argv)
    return 0


if __name__ == "__main__":
    sys.exit(main())
