"""Fig. 7 (a-b) of the key-particle paper: rope straightening and rope folding with CEM.

Four methods (default all) over several seeds: CEM(Simple) over the key particles of the goal
(the two ends for a straight rope, the four corners of the crossed triangle), CEM(Original)
over all 40 particles, CEM(Random) over a random subset as large as the key set, and the
scripted policy (each key particle above its goal, release).

straighten: the start is a crumpled rope (one per seed), the goal the straight rope along the
    line through the start's two ends, centred between them. Also reports the paper's metric
    (Sec. IV-B): end-to-end distance over rope length.
fold: the start is the straight rope, the goal the crossed triangle (Fig. 4b).

The pipeline is ``planners.pick_place``; the defaults are its ``PRESETS``: 40 particles,
0.5 m, picker displacement bounded by 0.1 m per axis, CEM population 32, 6 elites, horizon 6,
20 iterations.

Writes OUT/summary.json (as cloth_fold.py, plus "end_to_end_ratio_mean" for straighten),
OUT/curves.csv, OUT/cost_curves.png, OUT/goal_vs_<method>.png and OUT/plan_<method>.gif
(renders, as cloth_fold.py), OUT/trials/*.json (a rerun resumes, --fresh recomputes) and
OUT/blowups/ (as cloth_fold.py).
Exits 1 if a trial failed (listed under "failed") or the run failed (one line on stderr).

    python experiments/rope.py --goal straighten --out results/rope_straighten
"""

from __future__ import annotations

import os
import sys

os.environ.setdefault("MUJOCO_GL", "egl")

import pick_place_cli  # noqa: E402  (after MUJOCO_GL: rendering reads it at import)

HELP = {
    "seed": "first seed; runs use seed .. seed+seeds-1; the seed also picks the crumpled "
            "start of straighten (default %(default)s)",
    "quick": "smoke-sized run: 20 particles, population 8, 2 iterations, horizon 2, 1 seed "
             "(unless --seeds)",
    "n": "rope particles (default 40)",
    "population": "CEM population P (default 32)",
    "elites": "CEM elites (default 6)",
    "iterations": "CEM iterations (default 20)",
    "horizon": "actions per plan H (default 6)",
    "bound": "largest picker displacement per axis, metres (default 0.1)",
}


def main(argv=None) -> int:
    return pick_place_cli.main("rope", "experiments/rope.py", __doc__, HELP, argv)


if __name__ == "__main__":
    sys.exit(main())
