"""Fig. 7 (c-f) of the key-particle paper: cloth folds planned by CEM over key particles.

Four methods (default all) on one fold goal, over several seeds:
CEM(Simple) plans over the key particles of the goal (deformables.cloth_key_particles),
CEM(Original) over all particles, CEM(Random) over a random subset as large as the key set,
and the scripted policy moves each key particle above its goal. Multi-step folds (reflective:
side -> reflective; underneath: side -> reflective -> underneath) plan to each intermediate goal
in turn with that goal's key particles (Sec. III-D).

Defaults (chosen to finish in under 10 minutes on 2 cores for all four methods x 3 seeds):
a 12 x 12 cloth, 0.3 m side, dt 0.02 s; one picker whose displacement is bounded by 0.3 m per
axis (one action can carry a corner across the cloth); CEM population 32, 6 elites, horizon 2
(diagonal) or 3 (side), 15 iterations per stage (fewer per stage for the multi-step folds). The
goal positions are deformables.goals' folds lifted by the particle radius (the cloth rests on
the floor at z = radius). Self-collision is on for the multi-layer folds only.

Writes OUT/summary.json ({"goal", "settings", "methods": {method: {"final_cost_mean" (m),
"final_cost_ci95", "n_candidates", "s_per_iteration", ...}}}), OUT/curves.csv (best cost per
iteration), OUT/cost_curves.png (mean and 95 % CI per method), OUT/final_<method>.png and
OUT/goal.png (renders; MUJOCO_GL=egl), OUT/trials/*.json (one per finished trial; a rerun
resumes).

    python experiments/cloth_fold.py --goal diagonal --out results/cloth_diagonal
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

import argparse  # noqa: E402
import json  # noqa: E402
import logging  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from common import METHODS, Problem, Stage, parse_methods, run_trials, write_report  # noqa: E402
from deformables.cloth import cloth_key_particles  # noqa: E402
from deformables.goals import goal_sequence  # noqa: E402
from dopt.tasks.cloth import ClothConfig, make_cloth  # noqa: E402
from dopt.tasks.deformable_task import mean_distance  # noqa: E402
from dopt.tasks.picker import PickerConfig  # noqa: E402

GOALS = ("diagonal", "side", "reflective", "underneath")
#: per goal: horizon, iterations per stage, self-collision
GOAL_DEFAULTS = {"diagonal": (2, 15, False), "side": (3, 15, False),
                 "reflective": (2, 8, True), "underneath": (2, 6, True)}


def parse_args(argv=None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--goal", choices=GOALS, default="diagonal",
                    help="the fold (default %(default)s)")
    ap.add_argument("--methods", default=",".join(METHODS),
                    help="comma-separated subset of " + ", ".join(METHODS) + " (default: all)")
    ap.add_argument("--seeds", type=int, default=3, help="seeds per method (default %(default)s)")
    ap.add_argument("--seed", type=int, default=0,
                    help="first seed; runs use seed .. seed+seeds-1 (default %(default)s)")
    ap.add_argument("--out", type=Path, default=None,
                    help="output folder (default results/cloth_<goal>)")
    ap.add_argument("--quick", action="store_true",
                    help="smoke-sized run: 8x8 cloth, population 8, 2 iterations, 1 seed")
    ap.add_argument("--n", type=int, default=None, help="cloth particles per side (default 12)")
    ap.add_argument("--population", type=int, default=None, help="CEM population P (default 32)")
    ap.add_argument("--elites", type=int, default=None, help="CEM elites (default 6)")
    ap.add_argument("--iterations", type=int, default=None,
                    help="CEM iterations per stage (default: 15 diagonal/side, 8 reflective, "
                         "6 underneath)")
    ap.add_argument("--horizon", type=int, default=None,
                    help="actions per plan H (default: 2, side 3)")
    ap.add_argument("--bound", type=float, default=0.3,
                    help="largest picker displacement per axis, metres (default %(default)s)")
    ap.add_argument("--threads", type=int, default=0,
                    help="simulation threads (0: one per core, the default)")
    ap.add_argument("--no-render", action="store_true", help="skip the PNG renders")
    ap.add_argument("-v", "--verbose", action="store_true", help="log progress of each stage")
    args = ap.parse_args(argv)
    for name in ("seeds", "n", "population", "elites", "iterations", "horizon"):
        v = getattr(args, name)
        if v is not None and v < 1:
            ap.error(f"--{name} must be >= 1")
    try:
        args.methods = parse_methods(args.methods)
    except ValueError as e:
        ap.error(str(e))
    return args


def settings_of(args) -> dict:
    """The JSON-able trial settings (everything but method and seed)."""
    horizon, iterations, selfcollide = GOAL_DEFAULTS[args.goal]
    quick = args.quick
    cem = {"population": args.population or (8 if quick else 32),
           "elites": args.elites or (2 if quick else 6),
           "iterations": args.iterations or (2 if quick else iterations),
           "horizon": args.horizon or horizon, "smoothing": 0.3, "init_std": 1.0,
           "min_std": 0.05}
    return {"goal": args.goal, "n": args.n or (8 if quick else 12), "selfcollide": selfcollide,
            "bound": args.bound, "threads": args.threads, "cem": cem,
            "scripted": {"lift": 0.02, "tolerance": 0.01, "per_particle": 3,
                         "max_actions": 12}}


def build_problem(params: dict) -> Problem:
    """The cloth scene and the fold's stages with their key particles."""
    n = params["n"]
    scene = make_cloth(ClothConfig(n=n, selfcollide=params["selfcollide"]),
                       PickerConfig(bound=(params["bound"],) * 3))
    stages = []
    for goal in goal_sequence(f"cloth_{params['goal']}", n=n, side=0.3):
        keys = cloth_key_particles(goal.positions, goal.faces,
                                   rest_positions=goal.rest_positions).indices
        lifted = goal.positions + np.array([0.0, 0.0, scene.radius])
        stages.append(Stage(goal.name, lifted, np.asarray(keys, dtype=int)))
    final = stages[-1].goal
    return Problem(scene, scene.initial_state, stages,
                   lambda state: {"final_cost": float(mean_distance(scene.positions(state),
                                                                     final))})


def main(argv=None) -> int:
    args = parse_args(argv)
    logging.basicConfig(level=logging.INFO if args.verbose else logging.WARNING,
                        format="%(levelname)s %(name)s: %(message)s")
    out = args.out or Path("results") / f"cloth_{args.goal}"
    out.mkdir(parents=True, exist_ok=True)
    seeds = range(args.seed, args.seed + (1 if args.quick else args.seeds))
    settings = settings_of(args)
    problem = build_problem(settings)
    print(f"cloth {settings['n']}x{settings['n']}, goal {args.goal}: "
          + ", ".join(f"stage {s.name}: {len(s.keys)} key particles {s.keys.tolist()}"
                      for s in problem.stages))
    t0 = time.perf_counter()
    per_trial = settings["cem"]["iterations"] * len(problem.stages)
    results = run_trials(build_problem, settings, args.methods, seeds, out, per_trial)
    summary = write_report(out, args.goal, results, args.methods, ["final_cost"], settings,
                           problem.scene, problem.stages[-1].goal, not args.no_render, 0.55)
    summary["wall_s"] = time.perf_counter() - t0
    with open(out / "summary.json", "w") as f:
        json.dump(summary, f, indent=2)
    for m, e in summary["methods"].items():
        ci = e["final_cost_ci95"]
        print(f"{m:9s} final cost {e['final_cost_mean'] * 1e3:6.1f} mm"
              + (f" +- {ci * 1e3:.1f}" if ci is not None else "")
              + f"  ({e['n_candidates']} candidates)")
    print(f"wrote {out}/summary.json in {summary['wall_s']:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
