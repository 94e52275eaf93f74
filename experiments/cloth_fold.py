"""Fig. 7 (c-f) of the key-particle paper: cloth folds planned by CEM over key particles.

Four methods (default all) on one fold goal: CEM(Simple) over the key particles of the goal,
CEM(Original) over all particles, CEM(Random) over a random subset as large as the key set, and
the scripted policy (each key particle above its goal, release). The bare command runs one seed
per method, a first answer in minutes, and says before it starts how long it will take (timed
by a short calibration rollout); ``--preset ours`` runs the experiments' three seeds,
``--preset paper`` the paper's protocol (ten seeds on a 20 x 20 cloth), ``--seeds N`` any.
Multi-step folds (reflective: side -> reflective; underneath: side -> reflective ->
underneath) plan to each intermediate goal in turn with that goal's key particles (Sec. III-D),
from the flat sheet (``--fold-start chained``, the default of ``--preset ours``), or, as the
paper's authors run them, from the fold before the last prepared in place, planning only the
last with the final goal's key particles (``--fold-start prepared``, the default of ``--preset
paper``).
The pipeline is ``planners.pick_place``; the defaults are its ``PRESETS`` (12 x 12 cloth,
0.3 m; CEM population 32, 6 elites, horizon 2 (side 3), 15 iterations per stage; the
self-colliding multi-layer folds population 16, 4 elites, 8 (reflective) and 5 (underneath)
iterations per stage).

Writes OUT/summary.json ({"goal", "settings", "methods": {method: {"final_cost_mean" (m),
"final_cost_ci95", "final_costs", "n_candidates", "s_per_iteration", "seeds", "n"}},
"failed", "blowups": [the blow-up captures of flagged executed plans, OUT/blowups/<trial
key>-<stage>, also named on the console], "provenance"}), OUT/curves.csv (best cost per
iteration), OUT/cost_curves.png, for the first seed of each method OUT/goal_vs_<method>.png
(goal | result from above and obliquely, key and picked particles marked) and
OUT/plan_<method>.gif (the executed plan replayed) (renders; MUJOCO_GL=egl, skipped with
--no-render), OUT/trials/*.json (one per finished trial; a rerun resumes, --fresh recomputes).
Exits 1 if a trial failed (summary.json lists it under "failed") or the run failed (one line on
stderr).

    python experiments/cloth_fold.py --goal diagonal                  # one seed: a first answer
    python experiments/cloth_fold.py --goal diagonal --preset ours    # the experiments' 3 seeds
    python experiments/cloth_fold.py --goal reflective --preset paper --fold-start chained
"""

from __future__ import annotations

import os
import sys

os.environ.setdefault("MUJOCO_GL", "egl")

import pick_place_cli  # noqa: E402  (after MUJOCO_GL: rendering reads it at import)

HELP = {
    "seed": "first seed; runs use seed .. seed+seeds-1 (default %(default)s)",
    "quick": "smoke-sized run: 8x8 cloth, population 8, 2 iterations, 1 seed (unless --seeds)",
    "n": "cloth particles per side (default 12)",
    "population": "CEM population P (default 32; 16 reflective and underneath)",
    "elites": "CEM elites (default 6; 4 reflective and underneath)",
    "iterations": "CEM iterations per stage (default: 15 diagonal and side, 8 reflective, "
                  "5 underneath)",
    "horizon": "actions per plan H (default: 2, side 3)",
    "bound": "largest picker displacement per axis, metres (default 0.3)",
}


def main(argv=None) -> int:
    return pick_place_cli.main("cloth", "experiments/cloth_fold.py", __doc__, HELP, argv)


if __name__ == "__main__":
    sys.exit(main())
