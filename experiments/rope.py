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

import sys  # noqa: E402
from dataclasses import replace  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from common import (SCRIPTED, Problem, Stage, cem_settings, experiment_parser,  # noqa: E402
                    parse_experiment_args, run_experiment)
from deformables.goals import rope_crossed_triangle, rope_crumpled, rope_straight  # noqa: E402
from deformables.rope import rope_key_particles  # noqa: E402
from dopt.tasks.deformable_task import end_to_end, mean_distance  # noqa: E402
from dopt.tasks.picker import PickerConfig  # noqa: E402
from dopt.tasks.rope import RopeConfig, make_rope  # noqa: E402

GOALS = ("straighten", "fold")
CRUMPLE_TURN = 0.8


def parse_args(argv=None):
    ap = experiment_parser(__doc__, GOALS, "rope", {
        "goal": "the rope task (default %(default)s)",
        "seed": "first seed; runs use seed .. seed+seeds-1; the seed also picks the crumpled "
                "start of straighten (default %(default)s)",
        "quick": "smoke-sized run: 20 particles, population 8, 2 iterations, horizon 2, 1 seed",
        "n": "rope particles (default 40)",
        "population": "CEM population P (default 32)",
        "elites": "CEM elites (default 6)",
        "iterations": "CEM iterations (default 20)",
        "horizon": "actions per plan H (default 6)"}, bound=0.1)
    return parse_experiment_args(ap, argv, min_n=3)


def settings_of(args) -> dict:
    """The JSON-able trial settings (everything but method and seed)."""
    return {"goal": args.goal, "n": args.n or (20 if args.quick else 40), "length": 0.5,
            "bound": args.bound, "threads": args.threads,
            "cem": cem_settings(args, 20, 2 if args.quick else 6), "scripted": dict(SCRIPTED)}


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
    metrics = ["final_cost"] + (["end_to_end_ratio"] if args.goal == "straighten" else [])
    run_experiment(args, "rope", settings_of(args), build_problem, metrics, 0.8)
    return 0


if __name__ == "__main__":
    sys.exit(main())
