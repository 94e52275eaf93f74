"""Time the key-particle reduction per task: ``python -m deformables.bench [--repeats R]``.

Prints one JSON object per task: the median wall time of the whole reduction (validation,
Alg. 1 loop, extraction) over ``repeats`` runs after one warm-up run (the rope's cvxpy problems
are compiled once per process, the warm-up pays for that and is reported as
``first_call_seconds``), and the ratio to the paper's reported average (0.125 s per rope task,
0.73 s per cloth task; Sec. IV-C.1). Ropes have 40 particles, cloths 40 x 40 with MuJoCo's
triangulation. ``--noise SIGMA`` adds Gaussian goal noise (metres, seed 0), which makes the
cloth reduction project the goal onto its panels first.
"""
from __future__ import annotations

import argparse
import json
import statistics
import time

import numpy as np

from .cloth import cloth_key_particles
from .goals import make_goal
from .rope import rope_key_particles

PAPER_SECONDS = {"rope": 0.125, "cloth": 0.73}
TASKS = ("rope_straighten", "rope_fold", "rope_fold_unequal", "cloth_diagonal", "cloth_side",
         "cloth_reflective", "cloth_underneath")


def _run(task: str, cloth_n: int, noise: float):
    goal = make_goal(task) if task.startswith("rope") else make_goal(task, n=cloth_n)
    positions = goal.positions + np.random.default_rng(0).normal(0.0, noise, goal.positions.shape)
    if task.startswith("rope"):
        return lambda: rope_key_particles(positions), len(positions)
    return (lambda: cloth_key_particles(positions, goal.faces,
                                        rest_positions=goal.rest_positions), len(positions))


def bench(task: str, repeats: int = 5, cloth_n: int = 40, noise: float = 0.0) -> dict:
    """Timing record of one task (see the module docstring)."""
    call, n_particles = _run(task, cloth_n, noise)
    paper = PAPER_SECONDS[task.split("_")[0]]
    start = time.perf_counter()
    try:
        result = call()
    except ValueError as exc:          # e.g. the threshold is never reached: report, go on
        return {"task": task, "particles": n_particles, "failure": str(exc),
                "seconds": round(time.perf_counter() - start, 5), "paper_seconds": paper}
    first = time.perf_counter() - start
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        call()
        times.append(time.perf_counter() - start)
    seconds = statistics.median(times)
    return {"task": task, "particles": n_particles, "noise_m": noise,
            "n_elements": result.n_elements,
            "n_keys": result.n_keys, "seconds": round(seconds, 5),
            "first_call_seconds": round(first, 5), "paper_seconds": paper,
            "ratio_to_paper": round(seconds / paper, 4), "speedup": round(paper / seconds, 2)}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5,
                        help="timed runs per task after one warm-up run (median reported)")
    parser.add_argument("--cloth-n", type=int, default=40,
                        help="cloth particles per side (the target is set at 40)")
    parser.add_argument("--task", choices=TASKS, action="append",
                        help="task to time (repeatable); default: all")
    parser.add_argument("--noise", type=float, default=0.0,
                        help="Gaussian goal noise per coordinate, metres (default 0)")
    args = parser.parse_args(argv)
    if not args.noise >= 0:
        parser.error("--noise must be >= 0")
    for task in args.task or TASKS:
        print(json.dumps(bench(task, args.repeats, args.cloth_n, args.noise)), flush=True)


if __name__ == "__main__":
    main()
