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
(diagonal, reflective, underneath) or 3 (side), 15 iterations per stage for diagonal and side.
The multi-layer folds need self-collision, which makes a step of a layered 12 x 12 cloth about
6 ms instead of 1 ms: reflective (2 stages) and underneath (3 stages) use population 16 with
4 elites and 8 and 5 iterations per stage. The goal positions are deformables.goals' folds lifted by
the particle radius (the cloth rests on the floor at z = radius). Self-collision is on for the
multi-layer folds (reflective, underneath) only. Measured on the shared 2-core box: diagonal
7 min, side 7 min.

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

import sys  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from common import (SCRIPTED, Problem, Stage, cem_settings, experiment_parser,  # noqa: E402
                    parse_experiment_args, run_experiment)
from deformables.cloth import cloth_key_particles  # noqa: E402
from deformables.goals import goal_sequence  # noqa: E402
from dopt.tasks.cloth import ClothConfig, make_cloth  # noqa: E402
from dopt.tasks.deformable_task import mean_distance  # noqa: E402
from dopt.tasks.picker import PickerConfig  # noqa: E402

GOALS = ("diagonal", "side", "reflective", "underneath")
#: per goal: horizon, iterations per stage, population, elites, self-collision
GOAL_DEFAULTS = {"diagonal": (2, 15, 32, 6, False), "side": (3, 15, 32, 6, False),
                 "reflective": (2, 8, 16, 4, True), "underneath": (2, 5, 16, 4, True)}


def parse_args(argv=None):
    ap = experiment_parser(__doc__, GOALS, "cloth", {
        "goal": "the fold (default %(default)s)",
        "seed": "first seed; runs use seed .. seed+seeds-1 (default %(default)s)",
        "quick": "smoke-sized run: 8x8 cloth, population 8, 2 iterations, 1 seed",
        "n": "cloth particles per side (default 12)",
        "population": "CEM population P (default 32; 16 reflective and underneath)",
        "elites": "CEM elites (default 6; 4 reflective and underneath)",
        "iterations": "CEM iterations per stage (default: 15 diagonal and side, 8 reflective, "
                      "5 underneath)",
        "horizon": "actions per plan H (default: 2, side 3)"}, bound=0.3)
    return parse_experiment_args(ap, argv, min_n=3)


def settings_of(args) -> dict:
    """The JSON-able trial settings (everything but method and seed)."""
    horizon, iterations, population, elites, selfcollide = GOAL_DEFAULTS[args.goal]
    return {"goal": args.goal, "n": args.n or (8 if args.quick else 12),
            "selfcollide": selfcollide, "bound": args.bound, "threads": args.threads,
            "cem": cem_settings(args, iterations, horizon, population, elites),
            "scripted": dict(SCRIPTED)}


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
    run_experiment(args, "cloth", settings_of(args), build_problem, ["final_cost"], 0.55)
    return 0


if __name__ == "__main__":
    sys.exit(main())
