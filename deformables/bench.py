"""Time and compare the key-particle reductions: ``python -m deformables.bench [MODE] ...``.

Modes (JSON on stdout, one object per line; ``--out FILE`` also writes the whole record):

* ``tasks`` (default): per task, the median wall time of the whole reduction (validation,
  Alg. 1 loop, extraction) over ``--repeats`` runs after one warm-up run (the rope's cvxpy
  problems are compiled once per process, the warm-up pays for that and is reported as
  ``first_call_seconds``), and the ratio to the paper's reported average (0.125 s per rope
  task, 0.73 s per cloth task; Sec. IV-C.1) and to the yardstick of the machine timed once
  before the tasks (:func:`yardstick`, see ``paper-scale``). Ropes have 40 particles, cloths
  ``--cloth-n`` per side (40) with MuJoCo's triangulation. ``--noise SIGMA`` adds Gaussian
  goal noise (metres, seed 0).
* ``paper-scale``: the four cloth folds at the paper's resolution, ``--cloth-n`` 100 per side
  (N = 10,000), each without noise and with ``--noise`` (1 mm), timed over ``--repeats`` runs
  after one warm-up reduction of a small goal; the mean over the folds per noise level against
  the paper's 0.73 s, and against a yardstick of the machine timed in the same run
  (:func:`yardstick`): the paper's seconds come from another machine, and machines that report
  the same CPU model can differ by large factors, so the ratio to the yardstick is what
  compares runs across machines.
* ``authors``: the authors' own goals (``--external``, their ``ac_softagent`` folder: the
  diagonal fold at 90 x 90, the side fold at 100 x 100; :mod:`deformables.authors`) in each
  triangulation of ``TRIANGULATIONS``, the default pipeline: faces against the paper's, keys
  against the reference count and the authors' own keys (within their 0.05 m filter, both
  ways), seconds (median of ``--repeats``, 1, after one warm-up reduction of a small goal),
  and the mean seconds per reduction against the paper's 0.73 s and against the yardstick at
  100 x 100 (as in ``paper-scale``).
* ``compare``: the pipelines of ``PIPELINES`` on the same goals: the default
  (``ClothConfig()``), the paper's (``ClothConfig.paper()``) and the default with every
  restart decimating from the goal itself (``shared_faces=None``); the four folds x
  ``--resolutions`` x the four triangulations x (no noise, ``--noise``), goal seed 0. Per
  goal: faces, keys, error, threshold, whether it was reached and seconds; per pipeline and
  fold: the face and key counts, how many goals hold the reference key count and how many
  the default's face and key counts.

Library functions return dicts; only :func:`main` prints.
"""
from __future__ import annotations

import json
import statistics
import sys
import time
from collections import Counter

import numpy as np

from dopt.atomic import write_text
from dopt.lab.cli import (
    EPILOG,
    ArgumentParser,
    existing_dir,
    guarded,
    int_at_least,
    nonneg_float,
    number_list,
    output_file,
    positive_int,
)
from dopt.lab.provenance import provenance

from .authors import AUTHORS_CLOTH, keys_agree, load_authors_cloth
from .cloth import ClothConfig, cloth_key_particles
from .decimation import decimate
from .goals import CLOTH_REFERENCE_KEYS, TRIANGULATIONS, grid_faces, make_goal
from .rope import rope_key_particles

PAPER_SECONDS = {"rope": 0.125, "cloth": 0.73}
TASKS = ("rope_straighten", "rope_fold", "rope_fold_unequal", "cloth_diagonal", "cloth_side",
         "cloth_reflective", "cloth_underneath")
CLOTH_TASKS = TASKS[3:]
MODES = ("tasks", "paper-scale", "authors", "compare")
#: the pipelines ``compare`` runs on every goal
PIPELINES = {"default": ClothConfig(), "paper": ClothConfig.paper(),
             "separate-restarts": ClothConfig(shared_faces=None)}


def _run(task: str, cloth_n: int, noise: float, config: ClothConfig | None = None,
         triangulation: str = "mujoco", seed: int = 0):
    """(call, N, reference keys) for one goal; the call runs the whole reduction."""
    rng = np.random.default_rng(seed)
    goal = (make_goal(task) if task.startswith("rope") else
            make_goal(task, n=cloth_n, triangulation=triangulation, rng=rng))
    positions = goal.positions + rng.normal(0.0, noise, goal.positions.shape)
    if task.startswith("rope"):
        return lambda: rope_key_particles(positions), len(positions), None
    config = ClothConfig() if config is None else config
    return (lambda: cloth_key_particles(positions, goal.faces, rest_positions=goal.rest_positions,
                                        config=config),
            len(positions), CLOTH_REFERENCE_KEYS[task])


def bench(task: str, repeats: int = 5, cloth_n: int = 40, noise: float = 0.0,
          stick: float | None = None) -> dict:
    """Timing record of one task (``tasks`` mode, see the module docstring); with ``stick``,
    the seconds of :func:`yardstick` in the same run, also the median against it."""
    call, n_particles, _ = _run(task, cloth_n, noise)
    paper = PAPER_SECONDS[task.split("_")[0]]
    start = time.perf_counter()
    try:
        result = call()
    except ValueError as exc:          # a bad goal: report, go on
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
            "n_elements": result.n_elements, "n_keys": result.n_keys,
            "reached_threshold": result.reached_threshold, "seconds": round(seconds, 5),
            "first_call_seconds": round(first, 5), "paper_seconds": paper,
            "ratio_to_paper": round(seconds / paper, 4), "speedup": round(paper / seconds, 2),
            **({} if stick is None else _against(seconds, stick, 4))}


def yardstick(cloth_n: int = 100, repeats: int = 3) -> dict:
    """The machine's speed at the reduction's own kind of work, timed where the reduction is:
    one pymeshlab quadric edge collapse of the noise-free diagonal fold at ``cloth_n`` per side
    (MuJoCo's triangulation) to a tenth of its faces (19,602 to 1,960 at 100 x 100: the size
    of the pipeline's first and largest decimation), median seconds of ``repeats``. Returns
    ``{"what", "faces", "target_faces", "seconds"}``."""
    goal = make_goal("cloth_diagonal", n=cloth_n, rng=np.random.default_rng(0))
    target = max(2, len(goal.faces) // 10)
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        decimate(goal.positions, goal.faces, target)
        times.append(time.perf_counter() - start)
    return {"what": "pymeshlab QECD of the diagonal fold to a tenth of its faces",
            "faces": len(goal.faces), "target_faces": target,
            "seconds": round(statistics.median(times), 4)}


def _against(seconds: float, stick: float, digits: int = 3) -> dict:
    """The yardstick's ``stick`` seconds and ``seconds`` over them, as a record's fields."""
    return {"yardstick_seconds": round(stick, 4),
            "ratio_to_yardstick": round(seconds / stick, digits)}


def paper_scale(cloth_n: int = 100, noise: float = 1e-3, repeats: int = 1) -> dict:
    """The four cloth folds at ``cloth_n`` per side, without noise and with ``noise``: per
    goal the median seconds of ``repeats`` runs (after one warm-up reduction of a 12 x 12
    goal, which loads the decimation back-end), its counts, and per noise level the mean over
    the folds against the paper's 0.73 s and against :func:`yardstick` (timed before the folds
    and again after them; the record keeps both and the ratio uses their mean)."""
    warm, _, _ = _run("cloth_side", 12, 0.0)
    warm()
    sticks = [yardstick(cloth_n)]
    rows = []
    for sigma in (0.0, noise):
        for task in CLOTH_TASKS:
            call, n_particles, reference = _run(task, cloth_n, sigma)
            times, result = [], None
            for _ in range(repeats):
                start = time.perf_counter()
                result = call()
                times.append(time.perf_counter() - start)
            rows.append({"task": task, "particles": n_particles, "noise_m": sigma,
                         "n_elements": result.n_elements, "n_keys": result.n_keys,
                         "reference_keys": reference,
                         "reached_threshold": result.reached_threshold,
                         "seconds": round(statistics.median(times), 4)})
    sticks.append(yardstick(cloth_n))
    stick = statistics.fmean(s["seconds"] for s in sticks)
    summary = {}
    for sigma in (0.0, noise):
        mine = [r["seconds"] for r in rows if r["noise_m"] == sigma]
        mean = statistics.fmean(mine)
        summary[f"noise_{sigma:g}"] = {
            "mean_seconds": round(mean, 4), "paper_seconds": PAPER_SECONDS["cloth"],
            "ratio_to_paper": round(mean / PAPER_SECONDS["cloth"], 3),
            **_against(mean, stick),
            "keys_held": sum(r["n_keys"] == r["reference_keys"] for r in rows
                             if r["noise_m"] == sigma)}
    return {"bench": "key-particles-paper-scale", "mode": "paper-scale",
            "cloth_n": cloth_n, "repeats": repeats, "goals": rows, "yardstick": sticks,
            "summary": summary, "provenance": provenance()}


def authors(external, repeats: int = 1) -> dict:
    """The authors' goals in every triangulation (``authors`` mode, see the module
    docstring)."""
    goals = [load_authors_cloth(external, task) for task in sorted(AUTHORS_CLOTH)]
    _run("cloth_side", 12, 0.0)[0]()                         # loads the decimation back-end
    sticks = [yardstick()]
    rows = []
    for goal in goals:
        for triangulation in TRIANGULATIONS:
            faces = grid_faces(goal.n, triangulation, rng=np.random.default_rng(0))
            times, result = [], None
            for _ in range(repeats):
                start = time.perf_counter()
                result = cloth_key_particles(goal.goal, faces, rest_positions=goal.rest)
                times.append(time.perf_counter() - start)
            rows.append({"task": goal.task, "particles": goal.n ** 2,
                         "triangulation": triangulation, "n_elements": result.n_elements,
                         "paper_elements": goal.paper_faces, "n_keys": result.n_keys,
                         "reference_keys": CLOTH_REFERENCE_KEYS[goal.task],
                         "keys": result.indices.tolist(), "authors_keys": goal.keys.tolist(),
                         "keys_agree": keys_agree(goal.rest, result.indices, goal.keys),
                         "reached_threshold": result.reached_threshold,
                         "seconds": round(statistics.median(times), 4)})
    sticks.append(yardstick())
    stick = statistics.fmean(s["seconds"] for s in sticks)
    mean = statistics.fmean(r["seconds"] for r in rows)
    summary = {"goals": len(rows), "mean_seconds": round(mean, 4),
               "paper_seconds": PAPER_SECONDS["cloth"],
               "ratio_to_paper": round(mean / PAPER_SECONDS["cloth"], 3),
               **_against(mean, stick),
               "paper_elements_held": sum(r["n_elements"] == r["paper_elements"] for r in rows),
               "keys_held": sum(r["n_keys"] == r["reference_keys"] for r in rows),
               "keys_agree": sum(r["keys_agree"] for r in rows)}
    return {"bench": "key-particles-authors", "mode": "authors", "repeats": repeats,
            "goals": rows, "yardstick": sticks, "summary": summary, "provenance": provenance()}


def compare(resolutions: tuple[int, ...] = (16, 25, 40), noise: float = 1e-3,
            triangulations: tuple[str, ...] = TRIANGULATIONS) -> dict:
    """The pipelines of ``PIPELINES`` on the same cloth goals (``compare`` mode, see the module
    docstring)."""
    pipelines = PIPELINES
    warm, _, _ = _run("cloth_side", 12, 0.0)
    warm()
    rows = []
    for task in CLOTH_TASKS:
        for n in resolutions:
            for triangulation in triangulations:
                for sigma in (0.0, noise):
                    row = {"task": task, "n": n, "triangulation": triangulation,
                           "noise_m": sigma, "reference_keys": CLOTH_REFERENCE_KEYS[task]}
                    for name, config in pipelines.items():
                        call, _, _ = _run(task, n, sigma, config, triangulation)
                        start = time.perf_counter()
                        result = call()
                        row[name] = {"n_elements": result.n_elements, "n_keys": result.n_keys,
                                     "error": result.error, "threshold": result.threshold,
                                     "reached_threshold": result.reached_threshold,
                                     "seconds": round(time.perf_counter() - start, 4)}
                    rows.append(row)
    return {"bench": "key-particles-compare", "mode": "compare",
            "resolutions": list(resolutions), "noise_m": noise,
            "triangulations": list(triangulations), "goals": rows,
            "summary": summarize_comparison(rows, list(pipelines)),
            "provenance": provenance()}


def summarize_comparison(rows: list[dict], pipelines: list[str]) -> dict:
    """Per pipeline, noise level and fold: how many goals hold the reference key count, reach
    the threshold, hold the first pipeline's face and key counts, the face and key counts seen
    ({count: goals}) and the median seconds."""
    summary: dict = {}
    for name in pipelines:
        for sigma in sorted({r["noise_m"] for r in rows}):
            for task in CLOTH_TASKS:
                mine = [r for r in rows if r["task"] == task and r["noise_m"] == sigma]
                if not mine:
                    continue
                results = [r[name] for r in mine]
                summary.setdefault(name, {}).setdefault(f"noise_{sigma:g}", {})[task] = {
                    "goals": len(mine),
                    "keys_held": sum(r[name]["n_keys"] == r["reference_keys"] for r in mine),
                    "reached_threshold": sum(x["reached_threshold"] for x in results),
                    "counts_as_first": sum(
                        (r[name]["n_keys"], r[name]["n_elements"])
                        == (r[pipelines[0]]["n_keys"], r[pipelines[0]]["n_elements"])
                        for r in mine),
                    "faces": _histogram(x["n_elements"] for x in results),
                    "keys": _histogram(x["n_keys"] for x in results),
                    "median_seconds": round(statistics.median(x["seconds"] for x in results), 4)}
    return summary


def _histogram(values) -> dict:
    return {str(k): v for k, v in sorted(Counter(values).items())}


@guarded("python -m deformables.bench")
def main(argv=None) -> int:
    parser = ArgumentParser(prog="python -m deformables.bench",
                            description=__doc__.splitlines()[0], epilog=EPILOG)
    parser.add_argument("mode", nargs="?", choices=MODES, default="tasks",
                        help="tasks (default), paper-scale, authors or compare (see the module "
                             "doc)")
    parser.add_argument("--repeats", type=positive_int, default=None,
                        help="timed runs per goal (median reported); tasks: 5 after one "
                             "warm-up run, paper-scale and authors: 1")
    parser.add_argument("--cloth-n", type=int_at_least(2), default=None,
                        help="cloth particles per side (tasks: 40, paper-scale: 100)")
    parser.add_argument("--task", choices=TASKS, action="append",
                        help="tasks mode: task to time (repeatable); default: all")
    parser.add_argument("--noise", type=nonneg_float, default=None,
                        help="Gaussian goal noise per coordinate, metres (tasks: 0; "
                             "paper-scale and compare: the noisy level, 0.001)")
    parser.add_argument("--resolutions", type=number_list(int, 2, "particles per side"),
                        default="16,25,40",
                        help="compare mode: comma list of particles per side "
                             "(default %(default)s)")
    parser.add_argument("--external", type=existing_dir, default=None,
                        help="authors mode: the authors' ac_softagent folder "
                             "(../shared/external/ac_softagent)")
    parser.add_argument("--out", type=output_file, default=None,
                        help="also write the whole record as one JSON file here")
    args = parser.parse_args(argv)
    if args.mode == "tasks":
        noise = args.noise or 0.0
        stick = yardstick()["seconds"]
        record = [bench(task, args.repeats or 5, args.cloth_n or 40, noise, stick)
                  for task in args.task or TASKS]
        for row in record:
            print(json.dumps(row), flush=True)
    else:
        noise = 1e-3 if args.noise is None else args.noise
        if args.mode == "paper-scale":
            record = paper_scale(args.cloth_n or 100, noise, args.repeats or 1)
        elif args.mode == "authors":
            if args.external is None:
                parser.error("authors mode needs --external (the authors' ac_softagent folder)")
            record = authors(args.external, args.repeats or 1)
        else:
            record = compare(args.resolutions, noise)
        for row in record["goals"]:
            print(json.dumps(row), flush=True)
        print(json.dumps({"summary": record["summary"]}), flush=True)
    if args.out:
        write_text(args.out, json.dumps(record, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
