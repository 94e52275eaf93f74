"""Key particles of the paper's six goals (Fig. 4 and Sec. IV-C.1 of the key-particle paper).

For each task: run Alg. 1 on the goal (and on each intermediate goal of a multi-step task),
write the error-vs-size curve as CSV, a PNG with the curve, the goal and the simplified model
with its key particles, and DIR/summary.json with counts, indices, errors and times. Unless
--quick, it also sweeps cloth resolutions x triangulations and goal noise and records the key
counts (the README's robustness table).

    python experiments/key_particles.py --task all --out results/key_particles
"""
from __future__ import annotations

import argparse
import csv
import json
import logging
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from deformables import (ClothConfig, RopeConfig, cloth_key_particles, goal_sequence,  # noqa: E402
                         make_goal, rope_key_particles)
from deformables.goals import TRIANGULATIONS  # noqa: E402

ROPE_TASKS = ["rope_straighten", "rope_fold", "rope_fold_unequal"]
CLOTH_TASKS = ["cloth_diagonal", "cloth_side", "cloth_reflective", "cloth_underneath"]
TASKS = ROPE_TASKS + CLOTH_TASKS
#: the counts the paper reports (Sec. IV-C.1): key particles for rope, triangles for cloth
PAPER = {"rope_straighten": {"keys": 2}, "rope_fold": {"keys": 4},
         "rope_fold_unequal": {"keys": 4}, "cloth_diagonal": {"triangles": 4, "keys": 4},
         "cloth_side": {"triangles": 6}, "cloth_reflective": {"triangles": 12},
         "cloth_underneath": {"triangles": 16}}

logger = logging.getLogger("key_particles")


def reduce_goal(goal, rope_config: RopeConfig, cloth_config: ClothConfig):
    """Alg. 1 on one goal (rope or cloth)."""
    if hasattr(goal, "faces"):
        return cloth_key_particles(goal.positions, goal.faces, rest_positions=goal.rest_positions,
                                   config=cloth_config)
    return rope_key_particles(goal.positions, config=rope_config)


def record(result) -> dict:
    return {"n_keys": result.n_keys, "n_elements": result.n_elements,
            "indices": result.indices.tolist(), "error": result.error,
            "threshold": result.threshold, "seconds": result.seconds,
            "sizes": result.sizes.tolist(), "errors": result.errors.tolist()}


def write_curve(path: Path, result) -> None:
    with path.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["size", "error", "threshold", "accepted"])
        for size, error in zip(result.sizes, result.errors):
            writer.writerow([int(size), float(error), result.threshold,
                             int(size == result.sizes[-1])])


def plot_task(path: Path, task: str, goal, result, z_scale: float) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cloth = hasattr(goal, "faces")
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.5))
    ax = axes[0]
    ax.plot(result.sizes, np.asarray(result.errors) * 1e3, "o-")
    ax.axhline(result.threshold * 1e3, color="grey", ls="--", label="threshold")
    ax.set_xlabel("model size (triangles)" if cloth else "model size (vertices)")
    ax.set_ylabel("error, mm" + (" (z stretched)" if cloth else " (Eq. 3)"))
    ax.set_title(f"{task}: error history")
    ax.legend()
    p, v, keys = goal.positions, result.vertices, result.indices
    stretch = z_scale if cloth else 1.0
    for ax, (i, j), title in [(axes[1], (0, 1), "top view"),
                              (axes[2], (0, 2), f"side view (z x{stretch:g})")]:
        scale = np.array([1.0, 1.0, stretch])
        ps, vs = p * scale, v * scale
        ax.scatter(ps[:, i], ps[:, j], s=4, c=p[:, 2], cmap="viridis", label="goal particles")
        for element in result.elements:
            loop = list(element) + ([element[0]] if cloth else [])
            ax.plot(vs[loop, i], vs[loop, j], "b-", lw=1)
        ax.scatter(ps[keys, i], ps[keys, j], marker="^", s=80, c="tab:red", label="key particles")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(f"{title}: {result.n_elements} elements, {result.n_keys} keys")
    axes[1].legend(loc="best", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def robustness(rng: np.random.Generator, rope_config: RopeConfig, cloth_config: ClothConfig,
               resolutions: list[int], noise_sigmas: list[float], noise_resolutions: list[int],
               seeds: int) -> dict:
    """Key counts over cloth resolutions x triangulations, and under Gaussian goal noise (rope at
    its default size, cloth at each of ``noise_resolutions`` particles per side)."""
    out = {"cloth_grid": [], "noise": []}
    for task in CLOTH_TASKS:
        for n in resolutions:
            for triangulation in TRIANGULATIONS:
                goal = make_goal(task, n=n, triangulation=triangulation, rng=rng)
                try:
                    r = reduce_goal(goal, rope_config, cloth_config)
                    row = {"n_keys": r.n_keys, "n_elements": r.n_elements, "seconds": r.seconds}
                except ValueError as exc:
                    row = {"n_keys": None, "n_elements": None, "failure": str(exc)}
                out["cloth_grid"].append({"task": task, "n": n, "triangulation": triangulation,
                                          **row})
                logger.info("grid %s n=%d %s: %s", task, n, triangulation, row)
    for task in TASKS:
        for n in [None] if task in ROPE_TASKS else noise_resolutions:
            goal = make_goal(task) if n is None else make_goal(task, n=n)
            for sigma in noise_sigmas:
                counts = []
                for _ in range(seeds):
                    noisy = goal.positions + rng.normal(0.0, sigma, goal.positions.shape)
                    try:
                        counts.append(reduce_goal(replace(goal, positions=noisy), rope_config,
                                                  cloth_config).n_keys)
                    except ValueError:
                        counts.append(None)
                out["noise"].append({"task": task, "n": n or len(goal.positions),
                                     "sigma_m": sigma, "n_keys": counts})
                logger.info("noise %s n=%s sigma=%g: %s", task, n, sigma, counts)
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        description="Key particles of the paper's rope and cloth goals (Fig. 4, Sec. IV-C.1).")
    parser.add_argument("--task", choices=TASKS + ["all"], default="all",
                        help="goal to reduce (rope_fold_unequal is the crossed triangle with "
                             "legs 1 : 1.3 : 1.6); 'all' runs every task")
    parser.add_argument("--out", type=Path, required=True,
                        help="output folder for summary.json, curve_<task>.csv, <task>.png")
    parser.add_argument("--seed", type=int, default=0,
                        help="seed of the random triangulations and the goal noise of the "
                             "robustness sweep")
    parser.add_argument("--quick", action="store_true",
                        help="smoke-sized run: 16 x 16 cloth, no robustness sweep")
    parser.add_argument("--cloth-n", type=int, default=None,
                        help="cloth particles per side (default 25, or 16 with --quick)")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")

    rng = np.random.default_rng(args.seed)
    cloth_n = args.cloth_n or (16 if args.quick else 25)
    rope_config, cloth_config = RopeConfig(), ClothConfig()
    tasks = TASKS if args.task == "all" else [args.task]
    args.out.mkdir(parents=True, exist_ok=True)
    summary = {"seed": args.seed, "quick": args.quick, "cloth_particles_per_side": cloth_n,
               "rope_config": vars(rope_config),
               "cloth_config": vars(cloth_config), "paper": PAPER, "tasks": {}}
    for task in tasks:
        kwargs = {} if task in ROPE_TASKS else {"n": cloth_n}
        sequence = goal_sequence(task, **kwargs)
        results = [reduce_goal(goal, rope_config, cloth_config) for goal in sequence]
        goal, result = sequence[-1], results[-1]
        entry = record(result)
        entry["particles"] = len(goal.positions)
        if len(sequence) > 1:
            entry["intermediate_goals"] = [{"goal": g.name, **record(r)}
                                           for g, r in zip(sequence[:-1], results[:-1])]
        summary["tasks"][task] = entry
        write_curve(args.out / f"curve_{task}.csv", result)
        plot_task(args.out / f"{task}.png", task, goal, result, cloth_config.z_scale)
        logger.info("%s: %d elements, %d key particles %s, %.4f s", task, result.n_elements,
                    result.n_keys, result.indices.tolist(), result.seconds)
    if not args.quick:
        summary["robustness"] = robustness(rng, rope_config, cloth_config,
                                           resolutions=[16, 21, 25, 28, 32, 40],
                                           noise_sigmas=[2e-5, 5e-5, 1e-4, 5e-4, 1e-3, 2e-3],
                                           noise_resolutions=[16, 25, 40], seeds=3)
    (args.out / "summary.json").write_text(json.dumps(summary, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
