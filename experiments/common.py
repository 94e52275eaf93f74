"""Shared machinery of the key-particle experiments (cloth_fold.py, rope.py).

A trial is one method on one seed: plan every stage of the task (one stage, or the intermediate
goals of Sec. III-D in turn), execute the plan, measure the final state. Trials go through
``dopt.sweep.run_sweep``, so each finished trial is written at once to
``OUT/trials/<key>.json`` and a rerun skips it (the key holds a hash of the settings, so
changed settings are rerun, not mixed in; the hash does not cover the code, so delete
OUT/trials after changing the library, e.g. the key-particle extraction). Then ``write_report`` writes summary.json,
curves.csv, the Fig. 7-style plot and one rendered image of the final state per method.

Methods (the paper's Sec. IV-C.2):
    simple    CEM over the key particles of each stage's goal (CEM(Simple))
    original  CEM over all particles (CEM(Original))
    random    CEM over a random subset as large as the key set (CEM(Random))
    scripted  pick each key particle, move it above its goal, release
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import json
import logging
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from dopt.rollout import RolloutConfig, RolloutService
from dopt.sweep import Trial, run_sweep
from dopt.tasks.deformable_task import DeformableScene, PickPlaceTask
from planners.cem import CEM, CEMConfig
from planners.scripted import ScriptedConfig, scripted
from cli_args import choices_list
from stats import mean_ci

log = logging.getLogger(__name__)

METHODS = ("simple", "original", "random", "scripted")
LABELS = {"simple": "CEM(Simple)", "original": "CEM(Original)", "random": "CEM(Random)",
          "scripted": "Scripted"}
COLOURS = {"simple": "tab:blue", "original": "tab:red", "random": "tab:green",
           "scripted": "tab:gray"}


@dataclass(frozen=True)
class Stage:
    """One (intermediate) goal: goal (N, 3) particle positions in the scene's frame, keys (K,)
    its key particles, name for the logs."""

    name: str
    goal: np.ndarray
    keys: np.ndarray


@dataclass(frozen=True)
class Problem:
    """What a trial plans on: the scene, the start state (ns,), the stages in order, and the
    metrics of a final state ({"final_cost": metres, ...}; the last stage's goal)."""

    scene: DeformableScene
    start_state: np.ndarray
    stages: Sequence[Stage]
    metrics: Callable[[np.ndarray], dict]


SCRIPTED = {"lift": 0.02, "tolerance": 0.01, "per_particle": 3, "max_actions": 12}


def experiment_parser(doc: str, goals: Sequence[str], kind: str, help_: dict,
                      bound: float) -> argparse.ArgumentParser:
    """The flags both experiments share. ``help_`` holds the experiment-specific help texts of
    "goal", "seed", "quick", "n", "population", "elites", "iterations", "horizon"."""
    ap = argparse.ArgumentParser(description=doc,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--goal", choices=goals, default=goals[0], help=help_["goal"])
    ap.add_argument("--methods", default=",".join(METHODS),
                    help="comma-separated subset of " + ", ".join(METHODS) + " (default: all)")
    ap.add_argument("--seeds", type=int, default=3, help="seeds per method (default %(default)s)")
    ap.add_argument("--seed", type=int, default=0, help=help_["seed"])
    ap.add_argument("--out", type=Path, default=None,
                    help=f"output folder (default results/{kind}_<goal>)")
    ap.add_argument("--quick", action="store_true", help=help_["quick"])
    ap.add_argument("--n", type=int, default=None, help=help_["n"])
    ap.add_argument("--population", type=int, default=None, help=help_["population"])
    ap.add_argument("--elites", type=int, default=None, help=help_["elites"])
    ap.add_argument("--iterations", type=int, default=None, help=help_["iterations"])
    ap.add_argument("--horizon", type=int, default=None, help=help_["horizon"])
    ap.add_argument("--bound", type=float, default=bound,
                    help="largest picker displacement per axis, metres (default %(default)s)")
    ap.add_argument("--threads", type=int, default=0,
                    help="simulation threads (0: one per core, the default)")
    ap.add_argument("--no-render", action="store_true", help="skip the PNG renders")
    ap.add_argument("-v", "--verbose", action="store_true", help="log the cost of each stage")
    return ap


def parse_experiment_args(ap: argparse.ArgumentParser, argv, min_n: int) -> argparse.Namespace:
    """Parse and check: counts >= 1, --n >= min_n, known methods (exits with a usage error)."""
    args = ap.parse_args(argv)
    for name in ("seeds", "population", "elites", "iterations", "horizon"):
        v = getattr(args, name)
        if v is not None and v < 1:
            ap.error(f"--{name} must be >= 1")
    if args.n is not None and args.n < min_n:
        ap.error(f"--n must be >= {min_n}")
    if not args.bound > 0:
        ap.error("--bound must be > 0")
    try:
        args.methods = choices_list(args.methods, METHODS, "methods")
    except ValueError as e:
        ap.error(str(e))
    return args


def cem_settings(args: argparse.Namespace, iterations: int, horizon: int,
                 population: int = 32, elites: int = 6) -> dict:
    """CEMConfig fields from the flags, else the given defaults; --quick shrinks the population
    and iterations. prob_floor 0.25 keeps every pick candidate at >= a quarter of the uniform
    probability after a refit (5 % of 4 keys + None): with the four keys of the diagonal fold
    the categorical otherwise collapsed on a wrong corner in one seed of three (71 mm; 18.6 mm
    with the floor)."""
    quick = args.quick
    return {"population": args.population or (8 if quick else population),
            "elites": args.elites or (2 if quick else elites),
            "iterations": args.iterations or (2 if quick else iterations),
            "horizon": args.horizon or horizon, "smoothing": 0.3, "init_std": 1.0,
            "min_std": 0.05, "prob_floor": 0.25}


def run_experiment(args: argparse.Namespace, kind: str, settings: dict,
                   build: Callable[[dict], Problem], metrics: Sequence[str],
                   distance: float) -> dict:
    """The whole experiment: every trial (resuming), then the report; prints a table.

    ``settings`` are the JSON-able trial settings without method and seed; ``build(params)``
    makes a trial's problem; ``distance`` is the render camera's distance (m)."""
    logging.basicConfig(level=logging.INFO if args.verbose else logging.WARNING,
                        format="%(levelname)s %(name)s: %(message)s")
    out = args.out or Path("results") / f"{kind}_{args.goal}"
    out.mkdir(parents=True, exist_ok=True)
    seeds = range(args.seed, args.seed + (1 if args.quick else args.seeds))
    problem = build({**settings, "seed": seeds[0]})
    print(f"{kind} ({problem.scene.n_particles} particles), goal {args.goal}: "
          + "; ".join(f"{s.name}: {len(s.keys)} key particles {s.keys.tolist()}"
                      for s in problem.stages))
    start = time.perf_counter()
    per_trial = settings["cem"]["iterations"] * len(problem.stages)
    results = run_trials(build, settings, args.methods, seeds, out, per_trial)
    summary = write_report(out, args.goal, results, args.methods, metrics, settings,
                           problem.scene, problem.stages[-1].goal, not args.no_render,
                           distance, wall_s=time.perf_counter() - start)
    for m, e in summary["methods"].items():
        ci = e["final_cost_ci95"]
        line = (f"{m:9s} final cost {e['final_cost_mean'] * 1e3:6.1f} mm"
                + (f" +- {ci * 1e3:.1f}" if ci is not None else ""))
        if "end_to_end_ratio_mean" in e:
            line += f", end-to-end / length {e['end_to_end_ratio_mean']:.3f}"
        print(line + f"  ({e['n_candidates']} candidates)")
    print(f"wrote {out}/summary.json in {summary['wall_s']:.0f} s")
    return summary


def candidates(method: str, keys: np.ndarray, n_particles: int,
               rng: np.random.Generator) -> np.ndarray:
    """Candidate particles of a CEM method: the keys, all N, or |keys| random ones (sorted)."""
    if method == "simple":
        return np.asarray(keys, dtype=int)
    if method == "original":
        return np.arange(n_particles)
    if method == "random":
        return np.sort(rng.choice(n_particles, size=len(keys), replace=False))
    raise ValueError(f"{method!r} is not a CEM method")


def run_trial(build: Callable[[dict], Problem], params: dict,
              on_iteration: Callable[[int, float], None] | None = None) -> dict:
    """One method on one seed (``params["method"]``, ``params["seed"]``), every stage in turn.

    ``build(params)`` makes the problem; ``params["cem"]`` / ``params["scripted"]`` hold the
    configs, ``params["threads"]`` the simulation threads. Returns a JSON-able dict.
    """
    start = time.perf_counter()
    problem = build(params)
    method, seed = params["method"], int(params["seed"])
    service = RolloutService(problem.scene.scene, RolloutConfig(threads=params["threads"]))
    generator = torch.Generator().manual_seed(seed)
    rng = np.random.default_rng(seed)
    cem = CEM(CEMConfig(**params["cem"]))
    state = problem.start_state
    history, stage_of, n_cand, seconds, actions, stage_costs = [], [], [], [], [], []
    for k, stage in enumerate(problem.stages):
        task = PickPlaceTask(problem.scene, stage.goal, state, service)
        if method == "scripted":
            res = scripted(task, stage.keys, ScriptedConfig(**params["scripted"]))
            state, cost, hist = res.final_state, res.cost, [res.cost]
            n_cand.append(len(stage.keys))
        else:
            cand = candidates(method, stage.keys, problem.scene.n_particles, rng)
            res = cem.plan(task, cand, generator, on_iteration)
            state = task.execute(res.particles, res.displacements)
            cost, hist = res.cost, res.cost_history.tolist()
            seconds += res.seconds_per_iteration.tolist()
            n_cand.append(len(cand))
        history += hist
        stage_of += [k] * len(hist)
        stage_costs.append(float(cost))
        actions.append({"stage": stage.name, "particles": res.particles.tolist(),
                        "displacements": np.round(res.displacements, 6).tolist()})
        log.info("%s seed %d stage %s: cost %.1f mm", method, seed, stage.name, cost * 1e3)
    return {"method": method, "seed": seed, **problem.metrics(state),
            "cost_history": history, "stage_of_iteration": stage_of,
            "stage_costs": stage_costs, "n_candidates": n_cand,
            "s_per_iteration": float(np.mean(seconds)) if seconds else None,
            "actions": actions, "final_state": state.tolist(),
            "wall_s": time.perf_counter() - start}


def trial_key(params: dict) -> str:
    """<method>-seed<seed>-<hash of the settings that change results (not threads)>."""
    rest = {k: v for k, v in params.items() if k not in ("method", "seed", "threads")}
    digest = hashlib.sha1(json.dumps(rest, sort_keys=True).encode()).hexdigest()[:8]
    return f"{params['method']}-seed{params['seed']}-{digest}"


def run_trials(build: Callable[[dict], Problem], base: dict, methods: Sequence[str],
               seeds: Sequence[int], out: Path, iterations_per_trial: int) -> dict:
    """Every (method, seed) trial not finished yet under ``out``, with a progress bar of CEM
    iterations. Returns {(method, seed): result}."""
    from functools import partial

    from tqdm import tqdm

    trials = []
    for seed in seeds:
        for method in methods:
            params = {**base, "method": method, "seed": int(seed)}
            trials.append(Trial(trial_key(params), params))
    n_cem = sum(1 for t in trials if t.params["method"] != "scripted")
    with tqdm(total=n_cem * iterations_per_trial, unit="it", desc="CEM iterations") as bar:
        def tick(i, best):
            bar.update(1)
            bar.set_postfix(best_mm=f"{best * 1e3:.1f}")

        def done(key, rec):
            bar.write(f"finished {key}" if rec else f"FAILED {key}")

        res = run_sweep(partial(run_trial, build, on_iteration=tick), trials, out,
                        progress=done)
    if res.failed:
        raise RuntimeError(f"trials failed: {res.failed}")
    keys = {t.key for t in trials}
    return {(r["params"]["method"], r["params"]["seed"]): r["result"]
            for k, r in res.records.items() if k in keys}


# --------------------------------------------------------------------------------- report
def _finite(x: float) -> float | None:
    return None if x is None or not math.isfinite(x) else float(x)


def summarize(goal: str, results: dict, methods: Sequence[str], metrics: Sequence[str],
              settings: dict) -> dict:
    """summary.json content: per method the mean and 95 % CI half-width of each metric over the
    seeds (null CI with one seed), candidates, seconds per CEM iteration."""
    out = {"goal": goal, "settings": settings, "methods": {}}
    for m in methods:
        runs = [r for (method, _), r in sorted(results.items()) if method == m]
        if not runs:
            continue
        entry = {}
        for name in metrics:
            mean, ci = mean_ci([r[name] for r in runs])
            entry[f"{name}_mean"], entry[f"{name}_ci95"] = _finite(mean), _finite(ci)
            entry[f"{name}s"] = [r[name] for r in runs]
        entry["n_candidates"] = int(runs[0]["n_candidates"][-1])
        entry["n_candidates_per_stage"] = runs[0]["n_candidates"]
        secs = [r["s_per_iteration"] for r in runs if r["s_per_iteration"] is not None]
        entry["s_per_iteration"] = float(np.mean(secs)) if secs else None
        entry["seeds"] = [r["seed"] for r in runs]
        out["methods"][m] = entry
    return out


def write_curves(path: Path, results: dict) -> None:
    """CSV: method, seed, iteration, stage, best_cost_m (scripted: one row per stage)."""
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["method", "seed", "iteration", "stage", "best_cost_m"])
        for (method, seed), r in sorted(results.items()):
            for i, (c, s) in enumerate(zip(r["cost_history"], r["stage_of_iteration"])):
                w.writerow([method, seed, i + 1, s, f"{c:.6g}"])


def plot_curves(path: Path, results: dict, methods: Sequence[str], title: str) -> None:
    """Fig. 7-style plot: best cost per CEM iteration, mean and 95 % CI band over the seeds;
    the scripted policy as a dashed line at its mean final cost."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5.5, 3.8))
    n_iter = 1
    for m in methods:
        runs = [r for (method, _), r in sorted(results.items()) if method == m]
        if not runs or m == "scripted":
            continue
        curves = np.array([r["cost_history"] for r in runs]) * 1e3          # (seeds, I)
        x = np.arange(1, curves.shape[1] + 1)
        n_iter = max(n_iter, len(x))
        stats_ = [mean_ci(c) for c in curves.T]
        mean = np.array([s[0] for s in stats_])
        ci = np.nan_to_num(np.array([s[1] for s in stats_]))
        ax.plot(x, mean, color=COLOURS[m], label=LABELS[m])
        ax.fill_between(x, mean - ci, mean + ci, color=COLOURS[m], alpha=0.2)
        stages = np.asarray(runs[0]["stage_of_iteration"])
        for b in np.flatnonzero(np.diff(stages)) + 1.5:
            ax.axvline(b, color="k", lw=0.5, ls=":")
    if "scripted" in methods:
        runs = [r for (method, _), r in results.items() if method == "scripted"]
        if runs:
            ax.axhline(np.mean([r["final_cost"] for r in runs]) * 1e3, color=COLOURS["scripted"],
                       ls="--", label=LABELS["scripted"] + " (final)")
    ax.xaxis.get_major_locator().set_params(integer=True)
    ax.set_xlabel("CEM iteration")
    ax.set_ylabel("best cost: mean particle distance to goal (mm)")
    ax.set_title(title)
    ax.set_xlim(1, max(n_iter, 2))
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def render_state(scene: DeformableScene, state: np.ndarray, path: Path, title: str,
                 distance: float = 0.6) -> None:
    """Two offscreen views (oblique, top) of a state row (ns,) into a PNG (needs
    MUJOCO_GL=egl or another offscreen GL set before mujoco is imported)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import mujoco

    m = scene.model
    data = mujoco.MjData(m)
    mujoco.mj_setState(m, data, np.asarray(state, dtype=float), scene.scene.layout.spec)
    mujoco.mj_forward(m, data)
    h, w = min(360, m.vis.global_.offheight), min(480, m.vis.global_.offwidth)
    images = []
    with mujoco.Renderer(m, h, w) as renderer:
        for azimuth, elevation in ((135.0, -35.0), (90.0, -89.9)):
            cam = mujoco.MjvCamera()
            cam.lookat[:] = (0.0, 0.0, 0.0)
            cam.distance, cam.azimuth, cam.elevation = distance, azimuth, elevation
            renderer.update_scene(data, cam)
            images.append(renderer.render())
    fig, axes = plt.subplots(1, 2, figsize=(8, 3.2))
    for ax, im in zip(axes, images):
        ax.imshow(im)
        ax.axis("off")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def write_report(out: Path, goal: str, results: dict, methods: Sequence[str],
                 metrics: Sequence[str], settings: dict, scene: DeformableScene,
                 final_goal: np.ndarray, render: bool, distance: float,
                 wall_s: float | None = None) -> dict:
    """summary.json, curves.csv, cost_curves.png, final_<method>.png (first seed) and goal.png.
    Returns the summary."""
    summary = summarize(goal, results, methods, metrics, settings)
    summary["wall_s"] = wall_s
    with open(out / "summary.json", "w") as f:
        json.dump(summary, f, indent=2)
    write_curves(out / "curves.csv", results)
    plot_curves(out / "cost_curves.png", results, methods, f"{goal}: best cost per iteration")
    if render:
        try:
            goal_state = scene.with_positions(scene.initial_state, final_goal)
            render_state(scene, goal_state, out / "goal.png", f"{goal}: goal", distance)
            for m in methods:
                runs = sorted((s, r) for (method, s), r in results.items() if method == m)
                if runs:
                    seed, r = runs[0]
                    render_state(scene, np.array(r["final_state"]), out / f"final_{m}.png",
                                 f"{LABELS[m]}, seed {seed}: {r['final_cost'] * 1e3:.1f} mm",
                                 distance)
        except Exception as e:  # the numbers are written; a missing GL only loses images
            log.warning("rendering failed (%s: %s); set MUJOCO_GL=egl", type(e).__name__, e)
    return summary
