"""The gain of key particles against the particle count (issue #60, item 2; issue 89, item 1):
the Fig. 7 cloth folds at several sizes.

Every (size, seed, method) trial of one cloth goal at the paper protocol's settings
(``PickPlaceSettings.preset("cloth", goal, protocol="paper")``: 30 CEM iterations per stage,
population 32, 6 elites, the physics preset "default" at every size) with n, the particles
per side, changed (``planners.pick_place.scaling``) by ``--mode``: resolution (the default),
only n, on the preset's 0.3 m sheet; size, the sheet grown at the preset's spacing, the
picker's bound, the workspace and the mass scaled with its side (the paper's regime: SoftGym's
cloths keep their spacing and grow with N). The trials run through
``dopt.lab.sweep`` into OUT/trials (a rerun resumes); ``--reuse-from`` first copies the matching
finished trials of a Fig. 7 sweep folder (docs/results/runs/fig7-cloth-<goal>: its 20 x 20
trials, loose or packed) into OUT/trials, so they count. The statistics are the library's
(``scaling_summary``): per size and method the mean final cost with its 95 % interval, the
paired Original - Simple and Random - Simple differences, and the trend test (the OLS slope of
the paired difference against log N, Holm over the two comparisons), whose verdict is printed;
the same on the costs normalised by the flat sheet's cost to the goal (SoftGym's normalised
performance: ``flat_cost``).

Writes OUT/summary.json (experiment "fig7_scaling": the mode, the settings of every size in
full, the physics preset, the flat sheet's cost per size, the statistics, the failures, the
provenance), OUT/scaling.png (final cost and
the gaps against the particle count, 95 % bars; only where matplotlib is installed; with
--record also copied to docs/images/<record's name>.png, which RESULTS.md shows beside it).
Exits 1 if a trial failed, 2 on bad flags (one line).

    python experiments/fig7_scaling.py --goal diagonal --sizes 10,15,20,30 --trials 5 \\
        --out results/scaling-diagonal --reuse-from docs/results/runs/fig7-cloth-diagonal
    python experiments/fig7_scaling.py --goal side --mode size --trials 5 \\
        --out results/scaling-spacing-side --reuse-from docs/results/runs/fig7-cloth-side
"""

from __future__ import annotations

import argparse
import functools
import sys
import time
from pathlib import Path

from dopt import atomic
from dopt.lab.cli import (
    EPILOG,
    ArgumentParser,
    choices_type,
    nonneg_int,
    number_list,
    output_dir,
    output_file,
    positive_int,
)
from dopt.lab.console import print_outputs, run_with_console, sweep_main
from dopt.lab.flags import SettingsFlags, add_alias
from dopt.lab.record import (
    add_reuse_argument,
    check_outputs,
    record_figure,
    reuse_mode,
    settings_dict,
    write_summary,
)
from dopt.lab.trialpack import is_stored_trial, read_trial_text
from dopt.rollout import share_cores
from planners.pick_place.experiments.sweep import (
    SCHEMA,
    cem_trial,
    describe_result,
    iterations_held,
)
from planners.pick_place.scaling import (
    COMPARED,
    SCALING_MODES,
    flat_cost,
    scaling_settings,
    scaling_summary,
    scaling_trials,
)
from planners.pick_place.settings import PickPlaceSettings
from planners.pick_place.tasks import GOALS

#: the goals with a scaling run (the single-layer folds: no self-collision)
SCALING_GOALS = ("diagonal", "side")
#: the CEM methods compared (the scripted policy has no gain to scale)
SCALING_METHODS = ("simple", "original", "random")
COLOURS = {"simple": "tab:blue", "original": "tab:red", "random": "tab:green"}
#: the sizes of each mode by default (n per side): the size mode's are 0.14-0.38 m at the
#: 20 x 20 preset's spacing (issue 89; 30, 0.46 m, where the budget allows)
DEFAULT_SIZES = {"resolution": "10,15,20,30", "size": "10,15,20,25"}
#: the sizes of --quick (a smoke run: the preset's quick CEM budget, one trial)
QUICK_SIZES = "4,5"
#: trials per method and size by default
DEFAULT_TRIALS = 5


#: the settings a --config file may not set here: the sweep's own flags set them
CONFIG_REFUSED = {"n": "--sizes", "task": "the experiment (cloth)"}


def move_flag() -> SettingsFlags:
    """--move: the picker's move rule (``PickPlaceSettings.picker_move``), derived from it,
    and --config (``PickPlaceSettings`` fields changing the paper preset every size starts
    from; a run's summary gives the settings common to its sizes)."""
    return SettingsFlags(PickPlaceSettings, ["picker_move"], names={"picker_move": "--move"})


def parser() -> argparse.ArgumentParser:
    """The flags of the module docstring."""
    ap = ArgumentParser(prog="fig7_scaling.py", description=__doc__, epilog=EPILOG,
                        formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--goal", choices=[g for g in SCALING_GOALS if g in GOALS["cloth"]],
                    required=True, help="the cloth fold")
    ap.add_argument("--mode", choices=SCALING_MODES, default="resolution",
                    help="what grows with n: resolution (default), the 0.3 m sheet refined; "
                         "size, the sheet at the 20 x 20 preset's spacing, with the picker's "
                         "bound, the workspace and the mass scaled with its side")
    ap.add_argument("--sizes", type=number_list(int, 3, "sizes"), default=None,
                    help="particles per side, comma-separated (default: "
                         + "; ".join(f"{k} {v}" for k, v in DEFAULT_SIZES.items())
                         + f"; {QUICK_SIZES} with --quick)")
    ap.add_argument("--trials", type=positive_int, default=None,
                    help="trials per method and size, seeds SEED .. SEED+TRIALS-1 (default "
                         f"{DEFAULT_TRIALS}; 1 with --quick)")
    add_alias(ap, "--seeds", "--trials")
    ap.add_argument("--seed", type=nonneg_int, default=0, help="the first seed (default 0)")
    ap.add_argument("--quick", action="store_true",
                    help="smoke-sized run: the preset's quick CEM budget (population 8, 2 "
                         f"iterations), sizes {QUICK_SIZES}, one trial (unless --trials)")
    ap.add_argument("--methods", type=choices_type(SCALING_METHODS, "methods"),
                    default=",".join(SCALING_METHODS),
                    help="comma-separated subset of " + ", ".join(SCALING_METHODS))
    ap.add_argument("--workers", type=positive_int, default=1,
                    help="trials at once (processes; default 1); the cores are shared out "
                         "over them as simulation threads")
    ap.add_argument("--threads", type=nonneg_int, default=0,
                    help="simulation threads per trial (0, the default: the cores shared out "
                         "over the trials that run at once)")
    move_flag().add_to(ap)
    ap.add_argument("--out", type=output_dir, default=None,
                    help="the run's folder (default results/fig7_scaling_<goal>)")
    ap.add_argument("--record", type=output_file, default=None,
                    help="also write the summary here (committed code only)")
    ap.add_argument("--reuse-from", type=Path, default=None,
                    help="a Fig. 7 sweep folder (with trials/) whose matching finished "
                         "trials are copied into OUT/trials first")
    ap.add_argument("--fresh", action="store_true", help="recompute every trial")
    ap.add_argument("-v", "--verbose", action="store_true", help="log the cost of each stage")
    add_reuse_argument(ap)
    return ap


def parse(argv=None) -> argparse.Namespace:
    """Parsed flags; exit 2 with one line on a bad one."""
    ap = parser()
    args = ap.parse_args(argv)
    if args.sizes is None:
        args.sizes = number_list(int, 3, "sizes")(QUICK_SIZES if args.quick
                                                  else DEFAULT_SIZES[args.mode])
    if args.trials is None:                   # an explicit --trials stands with --quick
        args.trials = 1 if args.quick else DEFAULT_TRIALS
    config_base(ap, args)
    if "simple" not in args.methods:
        ap.error("argument --methods: the gains are against simple, which it must name")
    if args.reuse_from is not None and not (args.reuse_from / "trials").is_dir():
        ap.error(f"argument --reuse-from: {args.reuse_from}/trials is not a folder")
    check_outputs(ap, args, f"fig7_scaling_{args.goal}")
    return args


def config_base(ap: argparse.ArgumentParser, args) -> None:
    """``args.move`` and ``args.base``, the settings every size starts from: the paper preset
    of the goal (quick with --quick) < the --config file's settings < --move; a usage error
    naming --config for a setting the sweep's own flags give (``CONFIG_REFUSED``), another
    goal, or one the settings refuse."""
    flags = move_flag()
    config = flags.config(ap, args)
    for key, flag in CONFIG_REFUSED.items():
        if key in config and (key, config[key]) != ("task", "cloth"):
            ap.error(f"argument --config: {args.config}: {key} is set by {flag}")
    if config.pop("goal", args.goal) != args.goal:
        ap.error(f"argument --config: {args.config} holds settings of another goal, not "
                 f"{args.goal}")
    config.pop("task", None)
    args.config_threads = config.pop("threads", 0)
    args.move = flags.overrides(args).get("picker_move", config.pop("picker_move", None))
    preset = PickPlaceSettings.preset("cloth", args.goal, quick=args.quick, protocol="paper")
    args.base = flags.resolve(ap, args, preset, config) if config else None


def copy_finished(trials, source: Path, out: Path) -> int:
    """Copy the stored trials of ``source``/trials (loose or packed) of ``trials`` into
    ``out``/trials as loose files, where ``out`` has none yet: each under the name it is
    stored under, its key or else its older name (``SCHEMA.aliases``), never renamed. Returns
    how many were copied (the sweep still judges whether each may stand for this code)."""
    dest = out / "trials"
    dest.mkdir(parents=True, exist_ok=True)
    copied = 0
    for t in trials:
        names = (t.key, *SCHEMA.aliases_of(t.params))
        if any(is_stored_trial(dest / f"{name}.json") for name in names):
            continue
        src = next((source / "trials" / f"{name}.json" for name in names
                    if is_stored_trial(source / "trials" / f"{name}.json")), None)
        if src is not None:
            atomic.write_text(dest / src.name, read_trial_text(src))
            copied += 1
    return copied


def _experiment(args, argv) -> int:
    """The sweep, the summary, the plot and the printed verdict."""
    start = time.perf_counter()
    out = args.out
    n_trials = len(args.sizes) * args.trials * len(args.methods)
    threads = args.threads or args.config_threads or share_cores(min(args.workers, n_trials))
    seeds = range(args.seed, args.seed + args.trials)
    trials = scaling_trials(args.goal, args.sizes, seeds, args.methods, threads, args.move,
                            args.mode, args.quick, args.base)
    if args.reuse_from is not None:
        print(f"copied {copy_finished(trials, args.reuse_from, out)} finished trials from "
              f"{args.reuse_from}")
    settings = {n: scaling_settings(args.goal, n, threads, args.move, args.mode, args.quick,
                                    args.base) for n in args.sizes}
    flat = {n: flat_cost(s) for n, s in settings.items()}
    per_trial = next(iter(settings.values())).cem.iterations   # one stage: diagonal, side
    res = run_with_console(
        functools.partial(cem_trial, blowup_out=str(out)), trials, out, unit="it",
        desc="CEM iterations", workers=args.workers, fresh=args.fresh, schema=SCHEMA,
        reuse=reuse_mode(args), steps=lambda t: per_trial,
        held=lambda t: iterations_held([t], per_trial, out),
        describe=describe_result)
    keys = {t.key for t in trials}
    records = [r for k, r in res.records.items() if k in keys]
    stats = scaling_summary(records, {n: flat[n] for n in
                                      {int(r["params"]["settings"]["n"]) for r in records}})
    any_settings = next(iter(settings.values()))
    summary = {"experiment": "fig7_scaling", "task": "cloth", "goal": args.goal,
               "protocol": "paper", "mode": args.mode,
               "physics_preset": any_settings.physics,
               "sizes": list(args.sizes), "seeds": list(seeds),
               "methods_run": list(args.methods),
               "settings": {str(n): settings_dict(s) for n, s in settings.items()},
               "physics": {str(n): s.resolved_physics() for n, s in settings.items()},
               "flat_costs": {str(n): c for n, c in flat.items()},
               **stats, "failed": res.failed, "trial_commits": res.commits,
               "wall_s": time.perf_counter() - start}
    write_summary(summary, out, args.record, "experiments/fig7_scaling.py", argv)
    if plot(out / "scaling.png", stats, args.goal):        # never an older run's figure
        record_figure(out / "scaling.png", args.record)
    print(f"{args.goal} ({args.mode}), physics preset {any_settings.physics!r}: "
          f"{stats['verdict']}")
    print(f"normalised by the flat sheet's cost: {stats['verdict_normalised']}")
    print(f"wrote {out}/summary.json")
    for key, err in res.failed.items():
        print(f"FAILED {key}: {err}", file=sys.stderr)
    print_outputs(out, ["scaling.png"])
    return 1 if res.failed else 0


def plot(path: Path, stats: dict, goal: str,
         xlabel: str = "particles N = n x n (log scale)") -> bool:
    """Final cost per method and the gaps over CEM(Simple) against N = n * n (log axis, named
    ``xlabel``), with 95 % bars. Returns whether it wrote ``path`` (not where matplotlib is not
    installed)."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return False
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
    for m, colour in COLOURS.items():
        rows = [(n * n, e["methods"][m]) for n, e in
                ((int(k), v) for k, v in stats["per_size"].items()) if m in e["methods"]]
        if rows:
            a.errorbar([x for x, _ in rows], [r["final_cost_mean"] * 1e3 for _, r in rows],
                       yerr=[(r["final_cost_ci95"] or 0) * 1e3 for _, r in rows],
                       color=colour, marker="o", capsize=3, label=m)
    for m in COMPARED:
        rows = [(int(k) ** 2, v[f"{m}_minus_simple"]) for k, v in stats["per_size"].items()
                if v[f"{m}_minus_simple"]["mean"] is not None]
        if rows:
            b.errorbar([x for x, _ in rows], [r["mean"] * 1e3 for _, r in rows],
                       yerr=[(r["ci95"] or 0) * 1e3 for _, r in rows], color=COLOURS[m],
                       marker="o", capsize=3, label=f"{m} - simple")
    b.axhline(0, color="k", lw=0.5)
    from matplotlib.ticker import FixedLocator, NullLocator, ScalarFormatter

    sizes = sorted(int(k) ** 2 for k in stats["per_size"])
    for ax, ylabel in ((a, "final cost (mm), mean and 95 % CI"),
                       (b, "paired difference (mm), mean and 95 % CI")):
        ax.set_xscale("log")
        # a tick at every size run (log decades alone showed only 10^2 and 10^3)
        ax.xaxis.set_major_locator(FixedLocator(sizes))
        ax.xaxis.set_major_formatter(ScalarFormatter())
        ax.xaxis.set_minor_locator(NullLocator())
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        ax.legend(title="method")
    # the verdict line is longer than the figure is wide: one line per compared method
    fig.suptitle(f"{goal}: " + "\n".join(stats["verdict"].split("; ")), fontsize=8)
    fig.tight_layout()
    with atomic.writing(path) as tmp:
        fig.savefig(tmp, dpi=120)
    plt.close(fig)
    return True


#: the run of the module docstring, holding OUT's lock and logging; the exit code
main = sweep_main("fig7_scaling.py", parse, _experiment)


if __name__ == "__main__":
    sys.exit(main())
