"""Key particles of the paper's six goals (Fig. 4 and Sec. IV-C.1 of the key-particle paper).

For each task: run Alg. 1 on the goal (and on each intermediate goal of a multi-step task),
write the error-vs-size curve as CSV, a PNG with the curve, the goal and the simplified model
with its key particles, and DIR/summary.json with counts, indices, errors and times (and the
provenance: command, git commit, versions; --record PATH writes a copy to PATH). Unless
--quick, it also sweeps cloth resolutions x triangulations and goal noise, and reduces goals
made by the simulator (each fold made on the MuJoCo cloth by a line grasp, settled), and
records the key counts (the robustness tables of docs/RESULTS.md); the noise sweep appends one
line per goal to DIR/noise.jsonl as it goes, and a rerun resumes it (lines that cannot be
read, failed goals and goals of another dopt version are recomputed; --fresh moves the journal
to DIR/noise.jsonl.old and starts again). A goal whose reduction never reaches the threshold is a
result: the best model's keys, with "reached_threshold": false; an error is a failure:
summary.json lists it under "failed" ({what: error}), the other goals go on, and the script
exits 1.

    python experiments/key_particles.py --task all --out results/key_particles
"""
from __future__ import annotations

import argparse
import csv
import itertools
import logging
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from deformables import (
    ClothConfig,
    RopeConfig,
    cloth_key_particles,
    goal_sequence,
    make_goal,
    rope_key_particles,
)
from deformables.cloth import PANEL_MODES
from deformables.goals import CLOTH_REFERENCE_KEYS, TRIANGULATIONS, check_cloth_size
from dopt import atomic
from dopt.lab import jsonio
from dopt.lab.cli import (
    EPILOG,
    ArgumentParser,
    choices_type,
    guarded,
    int_at_least,
    nonneg_int,
    number_list,
    one_line,
    output_dir,
    output_file,
    positive_int,
)
from dopt.lab.console import print_outputs
from dopt.lab.flags import add_alias
from dopt.lab.provenance import code_version
from dopt.lab.record import check_outputs, settings_dict, write_summary
from dopt.tasks.pick.cloth_scene import PHYSICS_PRESETS
from planners.pick_place import GOAL_NAMES

ROPE_TASKS = ["rope_straighten", "rope_fold", "rope_fold_unequal"]
CLOTH_TASKS = [g.shape for g in GOAL_NAMES if g.shape.startswith("cloth_") and g.panel]
TASKS = ROPE_TASKS + CLOTH_TASKS
#: the counts the paper reports (Sec. IV-C.1): key particles for rope, triangles for cloth
PAPER = {"rope_straighten": {"keys": 2}, "rope_fold": {"keys": 4},
         "rope_fold_unequal": {"keys": 4}, "cloth_diagonal": {"triangles": 4, "keys": 4},
         "cloth_side": {"triangles": 6}, "cloth_reflective": {"triangles": 12},
         "cloth_underneath": {"triangles": 16}}

#: the smallest cloth the goals are defined for (particles per side)
MIN_CLOTH_N = 2
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
            "sizes": result.sizes.tolist(), "errors": result.errors.tolist(),
            "reached_threshold": result.reached_threshold}


def write_curve(path: Path, result) -> None:
    with atomic.writing(path) as tmp, open(tmp, "w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["size", "error", "threshold", "accepted"])
        for size, error in zip(result.sizes, result.errors, strict=True):
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
    with atomic.writing(path) as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)


def resolution_sweep(rng: np.random.Generator, cloth_config: ClothConfig,
                     resolutions: list[int]) -> tuple[list[dict], dict]:
    """Key counts of the noise-free cloth goals over resolutions x triangulations: (rows,
    {goal: error} of the goals that failed, which are rows with n_keys None and their "error";
    a goal whose reduction never reached the threshold has "reached_threshold": false)."""
    rows, failed = [], {}
    for task in CLOTH_TASKS:
        for n in resolutions:
            for triangulation in TRIANGULATIONS:
                try:
                    goal = make_goal(task, n=n, triangulation=triangulation, rng=rng)
                    r = reduce_goal(goal, RopeConfig(), cloth_config)
                    row = {"n_keys": r.n_keys, "n_elements": r.n_elements, "seconds": r.seconds,
                           "reached_threshold": r.reached_threshold}
                except Exception as exc:
                    row = {"n_keys": None, "n_elements": None}
                    row["error"] = failed[f"grid/{task}/n{n}/{triangulation}"] = one_line(exc)
                rows.append({"task": task, "n": n, "triangulation": triangulation, **row})
                logger.info("grid %s n=%d %s: %s", task, n, triangulation, row)
    return rows, failed


def _noise_key(row: dict) -> tuple:
    return (row["task"], row["n"], row["triangulation"], row["seed"], row["sigma_m"],
            row["panels"])


def _noise_name(row: dict) -> str:
    """A noise-sweep goal as the "failed" list names it."""
    cloth = f"/n{row['n']}/{row['triangulation']}/panels-{row['panels']}" if row["n"] else ""
    return f"noise/{row['task']}{cloth}/sigma{row['sigma_m']:g}/seed{row['seed']}"


def load_journal(journal: Path) -> dict:
    """{cell: row} of the noise journal's readable lines (a later line of a cell replaces an
    earlier one); a line that is not a row (a write cut short) is named in a warning and its
    goal is recomputed."""
    rows: dict = {}
    if not journal.exists():
        return rows
    for i, line in enumerate(journal.read_text().splitlines(), 1):
        if not line.strip():
            continue
        try:
            row = jsonio.loads(line, strict_numbers=False)
            rows[_noise_key(row)] = row
        except (ValueError, TypeError, KeyError) as exc:
            logger.warning("%s line %d is not a noise row (%s): its goal is recomputed",
                           journal, i, one_line(exc))
    return rows


def noise_sweep(journal: Path, rope_config: RopeConfig, cloth_config: ClothConfig,
                sigmas: list[float], resolutions: list[int], seeds: int,
                panel_modes: list[str]) -> tuple[list[dict], dict]:
    """Key counts under Gaussian goal noise, one JSON line per goal appended to ``journal`` as it
    is done (a rerun skips those already there, unless the line holds an error or was written
    by another dopt version). Rope at its default size; cloth at each of ``resolutions``
    particles per side x triangulations x ``panel_modes`` (ClothConfig.panels). Goal ``seed``
    draws the random triangulation, then the noise. Returns (the rows of these goals, {goal:
    error} of those that failed); each row holds ``code_version()`` under "code"."""
    code = code_version()
    done = {}
    for key, row in load_journal(journal).items():
        old = (row.get("code") or {}).get("version", code["version"])
        if "error" in row:
            logger.info("noise goal %s failed before (%s): recomputed", key, row["error"])
        elif old != code["version"]:
            logger.warning("noise goal %s was written by dopt %s, this is dopt %s: recomputed",
                           key, old, code["version"])
        else:
            done[key] = row
    reference = {task: reduce_goal(make_goal(task), rope_config, cloth_config).n_keys
                 for task in ROPE_TASKS}
    reference.update({task: CLOTH_REFERENCE_KEYS[task] for task in CLOTH_TASKS})
    cells = [(task, n, triangulation, sigma, seed, panels)
             for task in TASKS
             for n, triangulation, modes in (
                 itertools.product(resolutions, TRIANGULATIONS, [panel_modes])
                 if task in CLOTH_TASKS else [(None, None, ["-"])])
             for sigma, seed, panels in itertools.product(sigmas, range(seeds), modes)]
    rows, failed = [], {}
    if journal.exists() and journal.stat().st_size and not journal.read_bytes().endswith(b"\n"):
        with journal.open("a") as handle:     # a line cut short: the next row starts afresh
            handle.write("\n")
    with journal.open("a") as handle:
        for task, n, triangulation, sigma, seed, panels in cells:
            row = {"task": task, "n": n, "triangulation": triangulation, "seed": seed,
                   "sigma_m": sigma, "panels": panels}
            if _noise_key(row) in done:
                rows.append(done[_noise_key(row)])
                continue
            try:
                rng = np.random.default_rng(seed)
                cloth = task in CLOTH_TASKS
                goal = (make_goal(task, n=n, triangulation=triangulation, rng=rng) if cloth
                        else make_goal(task))
                noisy = goal.positions + rng.normal(0.0, sigma, goal.positions.shape)
                config = replace(cloth_config, panels=panels) if cloth else None
                result = reduce_goal(replace(goal, positions=noisy), rope_config, config)
                keys, reached = result.n_keys, result.reached_threshold
            except Exception as exc:
                keys = reached = None
                row["error"] = failed[_noise_name(row)] = one_line(exc)
                logger.error("%s failed: %s", _noise_name(row), row["error"])
            row.update(n_keys=keys, reached_threshold=reached, held=keys == reference[task],
                       code=code)
            handle.write(jsonio.dumps(row) + "\n")      # strict: no bare NaN
            handle.flush()
            rows.append(row)
    return rows, failed


#: fold_merge_deg values the simulated goals are also reduced under (ClothConfig's default: 60)
MERGE_SWEEP_DEG = (30.0, 45.0, 60.0, 90.0, 120.0)


def simulated_goals(resolutions: list[int], cloth_config: ClothConfig,
                    physics: tuple[str, ...] = ("default",),
                    settle: float = 1.0) -> tuple[list[dict], dict]:
    """Key counts of cloth goals made by the simulator: each fold made on the MuJoCo cloth (the
    experiments' scene under each of the ``physics`` presets, with self-collision) by the line
    grasp of ``dopt.tasks.pick.fold_goals``, then left to settle ``settle`` seconds holding
    nothing. The reduction sees what a user with a simulator has: the settled particle
    positions, the flex's own triangles and the settled flat start as the rest sheet. Returns
    (rows, {goal: error} of the goals that failed); a row holds the goal's mean and largest
    particle distance to its rigid fold (``ideal_folds``), whether the stability verdict
    flagged the folding, the layer gap ``estimate_layer_gap`` finds in the settled goal (before
    the reduction's panel projection), the gap the reduction's threshold is relative to
    (``KeyParticles.layer_gap``) and the counts, under ``cloth_config`` and, in ``row["fold"]``,
    under it with ``panels="fold"`` (every particle onto its panel: the mode for goals a
    simulator or a camera makes)."""
    from deformables.layers import estimate_layer_gap
    from dopt.tasks.pick.cloth_scene import make_cloth
    from dopt.tasks.pick.fold_goals import fold_goal, folds, ideal_folds
    from planners.pick_place import PickPlaceSettings

    rows, failed = [], {}
    for task, preset, n in itertools.product(CLOTH_TASKS, physics, resolutions):
        row = {"task": task, "n": n, "physics": preset,
               "reference_keys": CLOTH_REFERENCE_KEYS[task]}
        try:
            start = time.perf_counter()
            settings = replace(PickPlaceSettings.preset("cloth", task.removeprefix("cloth_")),
                               n=n, physics=preset, selfcollide=True)
            scene = make_cloth(settings.scene_config(), settings.picker())
            creases = folds(task, settings.side)
            made = fold_goal(scene, creases, settle=settle)
            goal, rest = made.positions, scene.positions(scene.initial_state)
            miss = np.linalg.norm(goal - ideal_folds(rest, creases, 2 * scene.radius), axis=1)
            gap = estimate_layer_gap(goal, scene.elements, settings.side / (n - 1))
            keys = cloth_key_particles(goal, scene.elements, rest_positions=rest,
                                       config=cloth_config)
            # the fold mode at the config's merge angle and over the sweep's range (a wrinkle
            # turns panels by tens of degrees, a fold by 90-180), each angle reduced once
            chosen = cloth_config.fold_merge_deg
            by_angle = {deg: cloth_key_particles(
                goal, scene.elements, rest_positions=rest,
                config=replace(cloth_config, panels="fold", fold_merge_deg=deg))
                for deg in sorted({*MERGE_SWEEP_DEG, chosen})}
            folded = by_angle[chosen]
            merge = {str(int(deg)): by_angle[deg].n_keys for deg in MERGE_SWEEP_DEG}
            row.update(selfcollide=settings.selfcollide,
                       fold_error_mm=1e3 * float(miss.mean()),
                       fold_error_max_mm=1e3 * float(miss.max()),
                       held_particles=[len(h) for h in made.held],
                       unstable=made.unstable, unstable_reason=made.reason,
                       layer_gap_mm=(1e3 * gap.gap if gap.found else None),
                       reduction_layer_gap_mm=1e3 * keys.layer_gap,
                       n_keys=keys.n_keys, n_elements=keys.n_elements,
                       reached_threshold=keys.reached_threshold,
                       held=keys.n_keys == CLOTH_REFERENCE_KEYS[task],
                       fold={"n_keys": folded.n_keys, "n_elements": folded.n_elements,
                             "reached_threshold": folded.reached_threshold,
                             "held": folded.n_keys == CLOTH_REFERENCE_KEYS[task],
                             "n_keys_by_merge_deg": merge},
                       seconds=time.perf_counter() - start)
        except Exception as exc:
            row["error"] = failed[f"simulated/{task}/n{n}/{preset}"] = one_line(exc)
            logger.error("simulated %s n=%d %s failed: %s", task, n, preset, row["error"])
        rows.append(row)
        logger.info("simulated %s n=%d %s: %s", task, n, preset, row)
    return rows, failed


def simulated_scenes(presets) -> dict:
    """{preset: every field of the cloth scene its simulated goals are made on} (the
    resolution's n aside): what each physics preset meant for this run."""
    from dopt.tasks.pick.cloth_scene import ClothSceneConfig

    return settings_dict({p: ClothSceneConfig.physics(p, selfcollide=True) for p in presets})


def noise_table(rows: list[dict]) -> dict:
    """Goals whose key count equals the reference, per task kind, panel mode and sigma."""
    table: dict = {}
    for r in rows:
        if "error" in r:                # a failure is listed under "failed", not counted
            continue
        kind = "rope" if r["task"] in ROPE_TASKS else f"cloth, panels {r['panels']}"
        cell = table.setdefault(kind, {}).setdefault(f"{r['sigma_m'] * 1e3:g} mm", [0, 0])
        cell[0] += bool(r["held"])
        cell[1] += 1
    return {kind: {sigma: f"{held}/{total}" for sigma, (held, total) in cells.items()}
            for kind, cells in table.items()}


def parser() -> argparse.ArgumentParser:
    ap = ArgumentParser(
        prog="key_particles.py",
        description="Key particles of the paper's rope and cloth goals (Fig. 4, Sec. IV-C.1).",
        epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--task", choices=TASKS + ["all"], default="all",
                    help="goal to reduce (rope_fold_unequal is the crossed triangle with "
                         "legs 1 : 1.3 : 1.6); 'all' runs every task")
    ap.add_argument("--out", type=output_dir, default=None,
                    help="output folder for summary.json, curve_<task>.csv, <task>.png, "
                         "noise.jsonl (default results/key_particles_<task>)")
    ap.add_argument("--record", type=output_file, default=None, metavar="PATH",
                    help="also write the summary to PATH (the committed result files under "
                         "docs/results/ that docs/RESULTS.md is generated from)")
    ap.add_argument("--seed", type=nonneg_int, default=0,
                    help="seed of the random triangulations of the resolution sweep (the "
                         "noise sweep uses goal seeds 0..--noise-seeds-1)")
    ap.add_argument("--quick", action="store_true",
                    help="smoke-sized run: 16 x 16 cloth, no robustness sweep")
    ap.add_argument("--n", type=int_at_least(MIN_CLOTH_N), default=None,
                    help=f"cloth particles per side, >= {MIN_CLOTH_N} (default 25, or 16 with "
                         "--quick)")
    add_alias(ap, "--cloth-n", "--n")
    ap.add_argument("--noise-n", type=number_list(int, MIN_CLOTH_N, "particles per side"),
                    default=[16, 25, 40],
                    help="cloth particles per side of the goal-noise sweep (comma-separated, "
                         f"each >= {MIN_CLOTH_N}; default 16,25,40)")
    ap.add_argument("--noise-seeds", type=positive_int, default=3,
                    help="goal seeds per noise level (triangulation draw and noise; default "
                         "%(default)s)")
    ap.add_argument("--noise-panels", type=choices_type(PANEL_MODES, "panel modes"),
                    default=["on", "off"],
                    help="ClothConfig.panels modes of the noise sweep (comma-separated; "
                         "default: the library default 'on' and the ablation 'off', ~2 s "
                         "per goal that does not converge)")
    ap.add_argument("--simulated-n", type=number_list(int, 3, "particles per side"),
                    default=[16, 25, 40],
                    help="cloth particles per side of the simulated goals (each fold made "
                         "on the MuJoCo cloth by a line grasp, settled; comma-separated, each "
                         ">= 3; default 16,25,40)")
    ap.add_argument("--simulated-physics", type=choices_type(tuple(PHYSICS_PRESETS),
                                                             "physics presets"),
                    default=["fast", "default"],
                    help="cloth physics presets the simulated goals are made under "
                         "(comma-separated, of " + ", ".join(PHYSICS_PRESETS) + "; default "
                         "fast,default)")
    ap.add_argument("--fresh", action="store_true",
                    help="recompute the noise sweep (DIR/noise.jsonl moves to "
                         "DIR/noise.jsonl.old) instead of resuming it")
    return ap


def check_sizes(ap: argparse.ArgumentParser, args) -> None:
    """A usage error naming the flag when a cloth size of the flags needs more memory than
    this machine has (``deformables.goals.check_cloth_size``), before any goal is built."""
    for flag, sizes in (("--n", [args.n or 2]), ("--noise-n", args.noise_n),
                        ("--simulated-n", args.simulated_n)):
        for n in sizes:
            try:
                check_cloth_size(n, f"argument {flag}")
            except ValueError as e:
                ap.error(str(e))


def reduce_tasks(tasks: list[str], cloth_n: int, rope_config: RopeConfig,
                 cloth_config: ClothConfig, curve_config: ClothConfig, out: Path,
                 summary: dict, commits: dict, commit: str) -> None:
    """Reduce each task's goal sequence (the Fig. 4 curves, with ``curve_config``): its
    entry in ``summary["tasks"]``, its curve and plot under ``out``, a failure listed in
    ``summary["failed"]`` (the other tasks go on), each success counted for ``commit``."""
    from tqdm import tqdm
    from tqdm.contrib.logging import logging_redirect_tqdm

    with logging_redirect_tqdm():
        for task in tqdm(tasks, desc="goals reduced", unit="goal"):
            _reduce_task(task, cloth_n, rope_config, cloth_config, curve_config, out, summary,
                         commits, commit)


def _reduce_task(task: str, cloth_n: int, rope_config: RopeConfig, cloth_config: ClothConfig,
                 curve_config: ClothConfig, out: Path, summary: dict, commits: dict,
                 commit: str) -> None:
    """One task of ``reduce_tasks``."""
    kwargs = {} if task in ROPE_TASKS else {"n": cloth_n}
    try:
        sequence = goal_sequence(task, **kwargs)
        results = [reduce_goal(goal, rope_config, curve_config) for goal in sequence]
    except Exception as exc:        # listed, the other tasks go on
        summary["failed"][task] = one_line(exc)
        logger.error("%s failed: %s", task, summary["failed"][task])
        return
    commits[commit] += 1
    goal, result = sequence[-1], results[-1]
    entry = record(result)
    entry["particles"] = len(goal.positions)
    if len(sequence) > 1:
        entry["intermediate_goals"] = [
            {"goal": g.name, **record(r)}
            for g, r in zip(sequence[:-1], results[:-1], strict=True)]
    summary["tasks"][task] = entry
    write_curve(out / f"curve_{task}.csv", result)
    plot_task(out / f"{task}.png", task, goal, result, cloth_config.z_scale)
    logger.info("%s: %d elements, %d key particles %s, %.4f s", task, result.n_elements,
                result.n_keys, result.indices.tolist(), result.seconds)


def robustness(args, rng: np.random.Generator, rope_config: RopeConfig,
               cloth_config: ClothConfig, summary: dict, commits: dict, commit: str) -> None:
    """The full run's robustness sweeps (noise, cloth resolution, simulated goals) into
    ``summary["robustness"]``; a sweep that fails as a whole is listed in
    ``summary["failed"]``, and each trial counted under the commit that ran it."""
    failed = summary["failed"]
    journal = args.out / "noise.jsonl"
    if args.fresh and journal.exists():
        journal.replace(args.out / "noise.jsonl.old")
    noise, grid = [], []
    try:
        noise, noise_failed = noise_sweep(
            journal, rope_config, cloth_config,
            sigmas=[2e-5, 5e-5, 1e-4, 3e-4, 5e-4, 1e-3, 2e-3], resolutions=args.noise_n,
            seeds=args.noise_seeds, panel_modes=args.noise_panels)
        failed.update(noise_failed)
    except Exception as exc:        # the sweep as a whole (its reference counts)
        failed["noise"] = one_line(exc)
    try:
        grid, grid_failed = resolution_sweep(rng, cloth_config,
                                             [12, 16, 21, 25, 28, 32, 40])
        failed.update(grid_failed)
    except Exception as exc:
        failed["grid"] = one_line(exc)
    simulated = []
    try:
        simulated, simulated_failed = simulated_goals(args.simulated_n, cloth_config,
                                                      tuple(args.simulated_physics))
        failed.update(simulated_failed)
    except Exception as exc:
        failed["simulated"] = one_line(exc)
    summary["robustness"] = {"cloth_grid": grid, "noise": noise_table(noise),
                             "simulated": simulated}
    summary["settings"]["simulated_scenes"] = simulated_scenes(args.simulated_physics)
    logger.info("noise: %s", summary["robustness"]["noise"])
    commits[commit] += sum("error" not in g for g in grid + simulated)
    for row in noise:
        if "error" not in row:
            c = str((row.get("code") or {}).get("commit") or "unknown")
            commits[c] = commits.get(c, 0) + 1


def parse_args(argv=None) -> argparse.Namespace:
    """Parsed flags; exit 2 with one line on a bad one."""
    ap = parser()
    args = ap.parse_args(argv)
    check_outputs(ap, args, f"key_particles_{args.task}")
    check_sizes(ap, args)
    return args


@guarded("key_particles.py")
def main(argv=None) -> int:
    args = parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")

    rng = np.random.default_rng(args.seed)
    cloth_n = args.n or (16 if args.quick else 25)
    rope_config, cloth_config = RopeConfig(), ClothConfig()
    # the Fig. 4 curves need every size's error in full (the default stops at the threshold);
    # the sweeps only count keys, and python -m deformables.bench times the default
    curve_config = replace(cloth_config, exact_errors=True)
    tasks = TASKS if args.task == "all" else [args.task]
    args.out.mkdir(parents=True, exist_ok=True)
    code = code_version()
    summary = {"experiment": "key_particles", "seed": args.seed, "quick": args.quick,
               "cloth_particles_per_side": cloth_n,
               "rope_config": vars(rope_config),
               "cloth_config": vars(curve_config),
               # every field of the configs the reductions ran (the noise and resolution
               # sweeps: cloth_config; the Fig. 4 curves: with exact errors)
               "settings": settings_dict({"rope_config": rope_config,
                                          "cloth_config": cloth_config,
                                          "curve_cloth_config": curve_config}),
               "paper": PAPER, "tasks": {}, "failed": {}}
    commits = {code["commit"]: 0}
    reduce_tasks(tasks, cloth_n, rope_config, cloth_config, curve_config, args.out, summary,
                 commits, code["commit"])
    if not args.quick:
        robustness(args, rng, rope_config, cloth_config, summary, commits, code["commit"])
    failed = summary["failed"]
    summary["trial_commits"] = {c: n for c, n in commits.items() if n}
    write_summary(summary, args.out, args.record, "experiments/key_particles.py", argv,
                  indent=1)
    for what, err in failed.items():
        print(f"FAILED {what}: {err}", file=sys.stderr)
    # goal shapes, no episodes: nothing for dopt-view
    print_outputs(args.out, [f"{task}.png" for task in tasks], viewer=False)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
