"""Fig. 7 of the key-particle paper: the command line of experiments/cloth_fold.py (the cloth
folds, ``main(task="cloth")``) and experiments/rope.py (``main(task="rope")``).

The pipeline is library code (``planners.pick_place``); this module turns flags into
``PickPlaceSettings`` (the settings' flags derived from the dataclass, ``dopt.lab.flags``:
preset < ``--config`` < flags), runs every (method, seed) trial through ``dopt.lab.sweep``
(``sweep``: one record per finished trial under OUT/trials, a rerun resumes; the key holds a
hash of the settings), shows progress, and writes the report: summary.json (with the command
line, git commit and package versions), curves.csv, cost_curves.png and, for the first seed
of each method, the renders goal_vs_<method>.png and plan_<method>.gif (``pictures``), and a
blow-up capture of each executed plan the stability verdict flags, OUT/blowups/<trial
key>-<stage> (named on the console and under summary.json's "blowups"; ``dopt-view`` opens it
at the flagged step).
"""

from __future__ import annotations

import argparse
import functools
import sys
import time
from dataclasses import replace
from pathlib import Path

from dopt.blowup import captures_of
from dopt.lab.cli import (
    EPILOG,
    ArgumentParser,
    choices_type,
    guarded,
    nonneg_int,
    output_dir,
    output_file,
    positive_int,
)
from dopt.lab.console import duration, print_captures, print_outputs, sweep_session
from dopt.lab.flags import SettingsFlags, add_alias, default_text
from dopt.lab.record import add_reuse_argument, check_outputs, reuse_mode, write_summary
from dopt.lab.sweep import Trial, is_finished
from dopt.rollout import share_cores
from planners.pick_place import (
    GOALS,
    METHODS,
    PROTOCOL_SEEDS,
    PROTOCOLS,
    PickPlaceSettings,
    capture_label,
    make_problem,
    seconds_per_action,
    summarize,
    trial_key,
)
from planners.pick_place.budget import budget_problem
from planners.pick_place.experiments.pictures import plot_curves, render_report, write_curves
from planners.pick_place.experiments.sweep import SCHEMA, iterations_held, run_trials

#: the files a run writes under --out (besides its trials and renders): checked first
RUN_FILES = ("summary.json", "curves.csv", "cost_curves.png")
#: trials per method of a command that names neither --trials nor --preset: a first answer
#: in minutes (the protocols' seeds, ``PROTOCOL_SEEDS``, are a flag away)
FIRST_SEEDS = 1
#: the settings fields with a flag, per task (``dopt.lab.flags``)
SETTINGS_FIELDS = ("n", "cem.population", "cem.elites", "cem.iterations", "cem.horizon",
                   "bound", "physics", "planning_physics", "max_stretch", "picker_speed",
                   "rest_speed", "picker_move")
TASK_FIELDS = {"cloth": SETTINGS_FIELDS + ("fold_start",), "rope": SETTINGS_FIELDS}
#: the script file of each task (its usage line; a console script shows its own name)
SCRIPTS = {"cloth": "cloth_fold.py", "rope": "rope.py"}

DOCS = {"cloth": """Fig. 7 (c-f) of the key-particle paper: cloth folds planned by CEM over key
particles.

Four methods (default all) on one fold goal: CEM(Simple) over the key particles of the goal,
CEM(Original) over all particles, CEM(Random) over a random subset as large as the key set, and
the scripted policy (each key particle above its goal, release). The bare command runs one seed
per method, a first answer in minutes, and says before it starts how long it will take (timed
by a short calibration rollout); ``--preset ours`` runs the experiments' three seeds,
``--preset paper`` the paper's protocol (ten seeds on a 20 x 20 cloth), ``--trials N`` any.
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
The settings start from the protocol's preset; --config FILE (TOML or JSON settings, or a
run's summary.json) changes them, and the settings flags change them again.
Exits 1 if a trial failed (summary.json lists it under "failed") or the run failed (one line on
stderr).

    python experiments/cloth_fold.py --goal diagonal                  # one seed: a first answer
    python experiments/cloth_fold.py --goal diagonal --preset ours    # the experiments' 3 seeds
    python experiments/cloth_fold.py --goal reflective --preset paper --fold-start chained
    python experiments/cloth_fold.py --config results/cloth_diagonal/summary.json --trials 5
""",
        "rope": """Fig. 7 (a-b) of the key-particle paper: rope straightening and rope folding
with CEM.

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
"""}
#: the help texts that differ between the tasks (the settings' come from their fields)
HELP = {
    "cloth": {
        "seed": "first seed; runs use seed .. seed+trials-1 (default %(default)s)",
        "quick": "smoke-sized run: 8x8 cloth, population 8, 2 iterations, 1 trial (unless "
                 "--trials)"},
    "rope": {
        "seed": "first seed; runs use seed .. seed+trials-1; the seed also picks the crumpled "
                "start of straighten (default %(default)s)",
        "quick": "smoke-sized run: 20 particles, population 8, 2 iterations, horizon 2, 1 "
                 "trial (unless --trials)"}}


def _get(settings, path: str):
    return functools.reduce(getattr, path.split("."), settings)


def preset_text(task: str, path: str) -> str | None:
    """The default of a settings field in the help: its value in each protocol's presets of
    ``task``'s goals ("32; 16 reflective, underneath"; per protocol where they differ,
    ``dopt.lab.flags.default_text``), or None where no preset sets it (the field's
    documentation says what unset means)."""
    return default_text({protocol: {g: _get(PickPlaceSettings.preset(task, g, protocol=protocol),
                                            path) for g in GOALS[task]}
                         for protocol in PROTOCOLS})


def settings_flags(task: str) -> SettingsFlags:
    """The settings flags of ``task``'s experiment, the move under the name it had."""
    return SettingsFlags(PickPlaceSettings, TASK_FIELDS[task], names={"picker_move": "--move"},
                         defaults=functools.partial(preset_text, task))


def parser(task: str) -> argparse.ArgumentParser:
    """The flags of an experiment on ``task`` ("cloth" or "rope")."""
    ap = ArgumentParser(prog=SCRIPTS[task], description=DOCS[task], epilog=EPILOG,
                        formatter_class=argparse.RawDescriptionHelpFormatter)
    goals = GOALS[task]
    ap.add_argument("--goal", choices=goals, default=None,
                    help=f"the task's goal (default {goals[0]}, or the --config file's)")
    ap.add_argument("--methods", type=choices_type(METHODS, "methods"),
                    default=",".join(METHODS),
                    help="comma-separated subset of " + ", ".join(METHODS) + " (default: all)")
    ap.add_argument("--preset", choices=tuple(PROTOCOLS), default=None,
                    help="the protocol: ours (the experiments' settings, "
                         f"{PROTOCOL_SEEDS['ours']} seeds per method, minutes on 2 cores) or "
                         "paper (the paper's 30 CEM iterations per stage and ten runs per "
                         "method; a 20 x 20 cloth). Without it: ours's settings with "
                         f"{FIRST_SEEDS} seed per method, a first answer")
    ap.add_argument("--trials", type=positive_int, default=None,
                    help=f"trials (seeds) per method (default {FIRST_SEEDS}; with --preset its "
                         "protocol's: " + ", ".join(f"{k} {v}" for k, v in PROTOCOL_SEEDS.items())
                         + ")")
    add_alias(ap, "--seeds", "--trials")
    ap.add_argument("--seed", type=nonneg_int, default=0, help=HELP[task]["seed"])
    ap.add_argument("--out", type=output_dir, default=None,
                    help=f"output folder (default results/{task}_<goal>); finished trials "
                         "are kept under OUT/trials and a rerun resumes")
    ap.add_argument("--fresh", action="store_true",
                    help="recompute every trial (old trial files go to OUT/trials/outdated/)")
    add_reuse_argument(ap)
    ap.add_argument("--record", type=output_file, default=None, metavar="PATH",
                    help="also write the summary to PATH (the committed result files under "
                         "docs/results/ that docs/RESULTS.md is generated from)")
    ap.add_argument("--quick", action="store_true", help=HELP[task]["quick"])
    settings_flags(task).add_to(ap)
    ap.add_argument("--threads", type=nonneg_int, default=0,
                    help="simulation threads per trial (0, the default: the cores shared out "
                         "over the trials that run at once: all of them for one, one each "
                         "with --workers as many as the cores)")
    ap.add_argument("--workers", type=positive_int, default=1,
                    help="trials run at once on a local process pool (default %(default)s: "
                         "one after another in this process, with a bar of CEM iterations)")
    ap.add_argument("--no-render", action="store_true",
                    help="skip the renders (goal_vs_<method>.png, plan_<method>.gif)")
    ap.add_argument("-v", "--verbose", action="store_true", help="log the cost of each stage")
    return ap


def parse(ap: argparse.ArgumentParser, task: str, argv) -> tuple[argparse.Namespace,
                                                                  PickPlaceSettings]:
    """Parse the flags and build the typed settings: the preset of the protocol, then the
    --config file's settings, then the flags (argparse usage error, exit 2, on any bad value:
    the settings' own checks are reported as usage errors too, naming the flag)."""
    args = ap.parse_args(argv)
    flags = settings_flags(task)
    config = flags.config(ap, args)
    if config.pop("task", task) != task:
        ap.error(f"argument --config: {args.config} holds settings of another task, not "
                 f"{task}")
    if config.get("goal") is not None and config["goal"] not in GOALS[task]:
        ap.error(f"argument --config: unknown {task} goal {config['goal']!r}")
    args.goal = args.goal or config.pop("goal", None) or GOALS[task][0]
    config.pop("goal", None)
    config_threads = config.pop("threads", 0)
    named = args.preset is not None               # a protocol asked for: its seeds too
    args.preset = args.preset or "ours"
    if args.trials is None:                   # an explicit --trials stands with --quick
        args.trials = (1 if args.quick else PROTOCOL_SEEDS[args.preset] if named
                       else FIRST_SEEDS)
    try:
        preset = PickPlaceSettings.preset(task, args.goal, quick=args.quick,
                                          protocol=args.preset)
    except (ValueError, TypeError) as e:
        ap.error(str(e))
    s = flags.resolve(ap, args, preset, config)
    threads = args.threads or config_threads or share_cores(
        min(args.workers, args.trials * len(args.methods)))
    s = flags_apply_threads(ap, s, threads)
    if (too_big := budget_problem(s)) is not None:   # what the sizes need, before any is made
        flag = {f.path: f.flag for f in flags.flags}[too_big.field]
        ap.error(f"argument {flag}: {too_big}")
    check_outputs(ap, args, f"{task}_{args.goal}", files=RUN_FILES)
    return args, s


def flags_apply_threads(ap, settings: PickPlaceSettings, threads: int) -> PickPlaceSettings:
    """``settings`` with ``threads`` (a usage error naming --threads if refused)."""
    try:
        return replace(settings, threads=threads)
    except (ValueError, TypeError) as e:
        ap.error(f"argument --threads: {e}")


def main(argv=None, task: str = "cloth") -> int:
    """The whole Fig. 7 experiment on ``task``: every trial (resuming), the report, a printed
    table. Returns the exit code (1 when a trial failed, the failures listed in summary.json,
    or when the run failed: one line on stderr; 2 bad flags)."""
    if task not in SCRIPTS:
        raise ValueError(f"unknown task {task!r}; choose from {', '.join(SCRIPTS)}")
    return guarded(SCRIPTS[task])(_main)(task, argv)


def cloth(argv=None) -> int:
    """experiments/cloth_fold.py: ``main(argv, task="cloth")``."""
    return main(argv, task="cloth")


def rope(argv=None) -> int:
    """experiments/rope.py: ``main(argv, task="rope")``."""
    return main(argv, task="rope")


def _main(task: str, argv=None) -> int:
    ap = parser(task)
    args, settings = parse(ap, task, argv)
    with sweep_session(args.out, args.verbose):
        return _experiment(task, f"experiments/{SCRIPTS[task]}", args, settings, argv)


def _experiment(task: str, script: str, args, settings: PickPlaceSettings, argv) -> int:
    """The run of ``_main`` once its flags are checked and it holds its folder."""
    out = args.out
    seeds = range(args.seed, args.seed + args.trials)
    problem = make_problem(settings, seeds[0])
    print(f"{task} ({problem.scene.n_particles} particles), goal {args.goal}: "
          + "; ".join(f"{s.name}: {len(s.keys)} key particles {s.keys.tolist()}"
                      for s in problem.stages))
    start = time.perf_counter()
    trials = [Trial(trial_key(m, seed, settings),
                    {"settings": settings.to_dict(), "method": m, "seed": int(seed)})
              for seed in seeds for m in args.methods]
    iterations = settings.cem.iterations * len(problem.stages)
    print(estimate_line(problem, settings, trials, iterations, out, args))
    records, res = run_trials(trials, iterations, out, args.fresh, args.workers,
                              reuse=reuse_mode(args))
    results = [r["result"] for r in records]
    failed = res.failed
    summary = {"experiment": "fig7", "task": task, "goal": args.goal, "protocol": args.preset,
               "settings": settings.to_dict(),
               # the flags that changed the protocol: such a run is judged apart from it
               "departures": settings.departures(args.preset, args.quick),
               "physics": settings.resolved_physics(),
               "methods": summarize(records, args.methods, problem.metric_names),
               "failed": failed, "trial_commits": res.commits,
               "blowups": print_captures(out, captures_of(
                   out, [capture_label(res.stored_key(t.key), s.name) for t in trials
                         for s in problem.stages])),
               # this run's wall time (a resumed run reuses finished trials), and the trials'
               # own wall times summed, wherever and whenever they ran
               "wall_s": time.perf_counter() - start,
               "trials_wall_s": float(sum(r["wall_s"] for r in results))}
    write_summary(summary, out, args.record, script, argv)
    write_curves(out / "curves.csv", results)
    plot_curves(out / "cost_curves.png", results, args.methods,
                f"{args.goal}: best cost per iteration")
    if not args.no_render:
        render_report(out, problem, results, args.methods, seeds[0])
    for m, e in summary["methods"].items():
        print(method_line(m, e))
    print(f"wrote {out}/summary.json in {summary['wall_s']:.0f} s")
    print_outputs(out, ["cost_curves.png", *(f"{kind}_{m}.{ext}" for m in args.methods
                                             for kind, ext in (("goal_vs", "png"),
                                                               ("plan", "gif")))])
    for key, err in failed.items():
        print(f"FAILED {key}: {err}", file=sys.stderr)
    return 1 if failed else 0


def method_line(m: str, e: dict) -> str:
    """One method's line of the printed table: its mean final cost and what was left out."""
    mean, ci = e["final_cost_mean"], e["final_cost_ci95"]
    line = (f"{m:9s} final cost "
            + (f"{mean * 1e3:6.1f} mm" if mean is not None else "   n/a (not finite)")
            + (f" +- {ci * 1e3:.1f}" if ci is not None else ""))
    if e.get("end_to_end_ratio_mean") is not None:
        line += f", end-to-end / length {e['end_to_end_ratio_mean']:.3f}"
    if e["n_unstable_trials"]:
        line += f"  [{e['n_unstable_trials']} unstable trial(s) left out: seeds " \
                f"{e['unstable_seeds']}]"
    return line + (f"  ({e['n_candidates']} candidates, {e['n_unstable_rollouts']} of "
                   f"{e['n_rollouts']} rollouts unstable)")


def estimate_line(problem, settings: PickPlaceSettings, trials: list[Trial], iterations: int,
                  out: Path, args) -> str:
    """What the run will take, said before it starts: the CEM iterations left (a rerun's
    finished trials and checkpoints counted out), each ``population x horizon`` actions at
    the seconds per action of the calibration step (``seconds_per_action``), over the
    workers; the executed plans and the scripted policy at one action each. Renders are not
    counted. The seeds it runs, and how to run a protocol's."""
    cem = [t for t in trials if t.params["method"] != "scripted"]
    held = 0 if args.fresh else iterations_held(cem, iterations, out)
    left = len(cem) * iterations - held
    open_trials = sum(args.fresh or not is_finished(out, t.key, schema=SCHEMA,
                                                    params=t.params) for t in trials)
    n = len({t.params["seed"] for t in trials})
    m = len(args.methods)
    seeds = f"{n} seed{'s' if n > 1 else ''} x {m} method{'s' if m > 1 else ''}"
    if n == FIRST_SEEDS and not args.quick:
        seeds += (f" (a first answer: --preset ours for its {PROTOCOL_SEEDS['ours']} seeds, "
                  f"--preset paper for the paper's protocol)")
    if not open_trials:
        return f"{seeds}: every trial is finished under {out}; nothing to simulate"
    per_action, plans = seconds_per_action(problem, settings)
    H = settings.cem.horizon
    actions = left * settings.cem.population * H + open_trials * len(problem.stages) * H
    seconds = actions * per_action / min(args.workers, open_trials)
    return (f"{seeds}: about {duration(seconds)} for {left} CEM iterations of "
            f"{settings.cem.population} plans x {H} actions in {open_trials} trials, at "
            f"{per_action:.2f} s per action timed here now (a calibration rollout of {plans} "
            f"random plans; renders not counted)")
