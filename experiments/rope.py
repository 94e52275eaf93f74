"""Fig. 7 (a-b) of the key-particle paper: rope straightening and rope folding with CEM.

Four methods (default all) over several seeds: CEM(Simple) over the key particles of the goal
(deformables.rope_key_particles: the two ends for a straight rope, the four corners of the
crossed triangle), CEM(Original) over all 40 particles, CEM(Random) over a random subset as
large as the key set, and the scripted policy (each key particle above its goal, release).

straighten: the start is a crumpled rope (deformables.goals.rope_crumpled, turn 0.8, one per
    seed), the goal the straight rope along the line through the start's two ends, centred
    between them (pulling both ends outwards reaches it). Also reports the paper's metric
    (Sec. IV-B): end-to-end distance over rope length.
fold: the start is the straight rope, the goal the crossed triangle (Fig. 4b).

Defaults (a few minutes on 2 cores for all four methods x 3 seeds): 40 particles, 0.5 m,
dt 0.02 s, picker displacement bounded by 0.1 m per axis, CEM population 32, 6 elites,
horizon 6, 20 iterations.

Writes OUT/summary.json ({"goal", "settings", "methods": {method: {"final_cost_mean" (m),
"final_cost_ci95", "end_to_end_ratio_mean" (straighten), "n_candidates", "s_per_iteration",
...}}}), OUT/curves.csv, OUT/cost_curves.png, OUT/final_<method>.png, OUT/goal.png and
OUT/trials/*.json (a rerun resumes).

    python experiments/rope.py --goal straighten --out results/rope_straighten
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

import argparse  # noqa: E402
import json  # noqa: E402
import logging  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from dataclasses import replace  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from common import METHODS, Problem, Stage, parse_methods, run_trials, write_report  # noqa: E402
from deformables.goals import rope_crossed_triangle, rope_crumpled, rope_straight  # noqa: E402
from deformables.rope import rope_key_particles  # noqa: E402
from dopt.tasks.deformable_task import end_to_end, mean_distance  # noqa: E402
from dopt.tasks.picker import PickerConfig  # noqa: E402
from dopt.tasks.rope import RopeConfig, make_rope  # noqa: E402

GOALS = ("straighten", "fold")
CRUMPLE_TURN = 0.8


def parse_args(argv=None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--goal", choices=GOALS, default="straighten",
                    help="the rope task (default %(default)s)")
    ap.add_argument("--methods", default=",".join(METHODS),
                    help="comma-separated subset of " + ", ".join(METHODS) + " (default: all)")
    ap.add_argument("--seeds", type=int, default=3, help="seeds per method (default %(default)s)")
    ap.add_argument("--seed", type=int, default=0,
                    help="first seed; runs use seed .. seed+seeds-1; the seed also picks the "
                         "crumpled start of straighten (default %(default)s)")
    ap.add_argument("--out", type=Path, default=None,
                    help="output folder (default results/rope_<goal>)")
    ap.add_argument("--quick", action="store_true",
                    help="smoke-sized run: 20 particles, population 8, 2 iterations, 1 seed")
    ap.add_argument("--n", type=int, default=None, help="rope particles (default 40)")
    ap.add_argument("--population", type=int, default=None, help="CEM population P (default 32)")
    ap.add_argument("--elites", type=int, default=None, help="CEM elites (default 6)")
    ap.add_argument("--iterations", type=int, default=None, help="CEM iterations (default 20)")
    ap.add_argument("--horizon", type=int, default=None, help="actions per plan H (default 6)")
    ap.add_argument("--bound", type=float, default=0.1,
                    help="largest picker displacement per axis, metres (default %(default)s)")
    ap.add_argument("--threads", type=int, default=0,
                    help="simulation threads (0: one per core, the default)")
    ap.add_argument("--no-render", action="store_true", help="skip the PNG renders")
    ap.add_argument("-v", "--verbose", action="store_true", help="log progress of each trial")
    args = ap.parse_args(argv)
    for name in ("seeds", "n", "population", "elites", "iterations", "horizon"):
        v = getattr(args, name)
        if v is not None and v < 1:
            ap.error(f"--{name} must be >= 1")
    if args.n is not None and args.n < 3:
        ap.error("--n must be >= 3")
    try:
        args.methods = parse_methods(args.methods)
    except ValueError as e:
        ap.error(str(e))
    return args


def settings_of(args) -> dict:
    """The JSON-able trial settings (everything but method and seed)."""
    quick = args.quick
    cem = {"population": args.population or (8 if quick else 32),
           "elites": args.elites or (2 if quick else 6),
           "iterations": args.iterations or (2 if quick else 20),
           "horizon": args.horizon or (2 if quick else 6), "smoothing": 0.3, "init_std": 1.0,
           "min_std": 0.05}
    return {"goal": args.goal, "n": args.n or (20 if quick else 40), "length": 0.5,
            "bound": args.bound, "threads": args.threads, "cem": cem,
            "scripted": {"lift": 0.02, "tolerance": 0.01, "per_particle": 3,
                         "max_actions": 12}}


def build_problem(params: dict) -> Problem:
    """The rope at its start (crumpled by the seed, or straight) and the goal's key particles."""
    n, length = params["n"], params["length"]
    config = RopeConfig(n=n, length=length)
    picker = PickerConfig(bound=(params["bound"],) * 3)
    if params["goal"] == "straighten":
        start = rope_crumpled(np.random.default_rng(params["seed"]), n, length,
                              turn=CRUMPLE_TURN).positions.copy()
        start[:, 2] = config.radius + 1e-4
        scene = make_rope(config, picker, positions=start)
        p0 = scene.positions(scene.initial_state)
        direction = p0[-1] - p0[0]
        goal = rope_straight(n, length, float(np.arctan2(direction[1], direction[0])))
        goal = replace(goal, positions=goal.positions + [*(0.5 * (p0[0] + p0[-1]))[:2], 0.0])
    else:
        scene = make_rope(config, picker)
        goal = rope_crossed_triangle(n, length)
    keys = np.asarray(rope_key_particles(goal.positions).indices, dtype=int)
    positions = goal.positions.copy()
    positions[:, 2] = config.radius          # the goal rests on the floor
    straighten = params["goal"] == "straighten"

    def metrics(state):
        p = scene.positions(state)
        out = {"final_cost": float(mean_distance(p, positions))}
        if straighten:
            out["end_to_end_ratio"] = float(end_to_end(p) / length)
        return out

    return Problem(scene, scene.initial_state, [Stage(goal.name, positions, keys)], metrics)


def main(argv=None) -> int:
    args = parse_args(argv)
    logging.basicConfig(level=logging.INFO if args.verbose else logging.WARNING,
                        format="%(levelname)s %(name)s: %(message)s")
    out = args.out or Path("results") / f"rope_{args.goal}"
    out.mkdir(parents=True, exist_ok=True)
    seeds = range(args.seed, args.seed + (1 if args.quick else args.seeds))
    settings = settings_of(args)
    problem = build_problem({**settings, "seed": seeds[0]})
    print(f"rope {settings['n']} particles, goal {args.goal}: key particles "
          f"{problem.stages[0].keys.tolist()}")
    metrics = ["final_cost"] + (["end_to_end_ratio"] if args.goal == "straighten" else [])
    t0 = time.perf_counter()
    results = run_trials(build_problem, settings, args.methods, seeds, out,
                         settings["cem"]["iterations"])
    summary = write_report(out, args.goal, results, args.methods, metrics, settings,
                           problem.scene, problem.stages[0].goal, not args.no_render, 0.8)
    summary["wall_s"] = time.perf_counter() - t0
    with open(out / "summary.json", "w") as f:
        json.dump(summary, f, indent=2)
    for m, e in summary["methods"].items():
        line = f"{m:9s} final cost {e['final_cost_mean'] * 1e3:6.1f} mm"
        if "end_to_end_ratio_mean" in e:
            line += f", end-to-end / length {e['end_to_end_ratio_mean']:.3f}"
        print(line + f"  ({e['n_candidates']} candidates)")
    print(f"wrote {out}/summary.json in {summary['wall_s']:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
