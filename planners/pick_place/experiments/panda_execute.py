"""The key-particle paper's real-robot part (Sec. IV-D) in simulation: a Franka Panda with a
parallel gripper executes CEM(Simple)'s cloth plans open-loop through inverse kinematics.

For each goal (``--goal``, default the paper's two: diagonal and side) and seed, one trial
plans with CEM(Simple) on the floating picker (``planners.pick_place``, the goal's preset),
then replays the executed plan's actions with the arm (``dopt.tasks.pick.panda_gripper``) from
the same start. Trials are resumable files under OUT/trials.

Writes OUT/summary.json (experiment "panda_execute"): per goal the final cost (mean particle
distance to the goal, m) of the picker's and the arm's execution (mean and 95 % CI over the
seeds), their paired difference, the mean distance between the two final cloths, the largest
grasp distance and carry tracking error, and the actions the arm skipped because the pinch did
not reach the particle; per trial the same; and "blowups", the blow-up captures of the arm's
replays that failed the stability verdict (OUT/blowups/<trial key>, each also named on the
console; ``dopt-view`` opens them at the failing step). And OUT/panda_<goal>.png, the
first seed's execution as a strip (start, then grasp / carry / release of each action;
each panel labelled, the goal shape as blue dots, the final costs below; MUJOCO_GL=egl,
skipped with --no-render). Exits 1 if a trial failed, 2 on a bad flag.

    python experiments/panda_execute.py --trials 3 --out results/panda \\
        --record docs/results/panda-execute.json
"""

from __future__ import annotations

import argparse
import functools
import logging
import os
import sys
from dataclasses import replace

import numpy as np

from dopt import atomic
from dopt.blowup import captures_of, retire_captures
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
from dopt.lab.console import print_captures, print_outputs, run_with_console
from dopt.lab.flags import add_alias
from dopt.lab.record import add_reuse_argument, check_outputs, reuse_mode, write_summary
from dopt.lab.stats import finite_mean_ci
from dopt.lab.sweep import Schema, Trial, is_finished
from planners.pick_place import (
    PickPlaceSettings,
    make_planner,
    make_problem,
    run_problem,
    trial_key,
)

GOALS = ("diagonal", "side")


def parser() -> argparse.ArgumentParser:
    ap = ArgumentParser(prog="panda_execute.py", description=__doc__, epilog=EPILOG,
                        formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--goal", dest="goals", type=choices_type(GOALS, "goal(s)"),
                    default=",".join(GOALS),
                    help="a cloth goal or a comma list (default %(default)s, the paper's)")
    add_alias(ap, "--goals", "--goal")
    ap.add_argument("--trials", type=positive_int, default=None,
                    help="trials (seeds) per goal (default 3; 1 with --quick)")
    add_alias(ap, "--seeds", "--trials")
    ap.add_argument("--seed", type=nonneg_int, default=0, help="first seed (default 0)")
    ap.add_argument("--n", type=positive_int, default=None,
                    help="cloth particles per side (default: the goal's preset)")
    ap.add_argument("--quick", action="store_true",
                    help="smoke run: one trial (unless --trials), 8 x 8 cloth, 2 CEM "
                         "iterations")
    ap.add_argument("--out", type=output_dir, default=None,
                    help="output folder (default results/panda_execute); finished trials are "
                         "kept under OUT/trials")
    ap.add_argument("--fresh", action="store_true", help="recompute every trial")
    add_reuse_argument(ap)
    ap.add_argument("--workers", type=positive_int, default=1,
                    help="trials run at once on a local process pool (default %(default)s)")
    ap.add_argument("--threads", type=nonneg_int, default=0,
                    help="simulation threads per trial (default 0: one per core)")
    ap.add_argument("-v", "--verbose", action="store_true", help="log each stage's cost")
    ap.add_argument("--record", type=output_file, default=None, metavar="PATH",
                    help="also write the summary to PATH (docs/results/...)")
    ap.add_argument("--no-render", action="store_true", help="skip the PNG strips")
    return ap


def settings_of(goal: str, args) -> PickPlaceSettings:
    s = replace(PickPlaceSettings.preset("cloth", goal, quick=args.quick),
                threads=args.threads)
    return s if args.n is None else replace(s, n=args.n)


def plan_actions(actions: list[dict]) -> tuple[np.ndarray, np.ndarray]:
    """Every stage's executed actions in order (a trial's "actions"): (H,) particles, (H, 3)
    displacements."""
    parts = [p for a in actions for p in a["particles"]]
    disps = [d for a in actions for d in a["displacements"]]
    return np.asarray(parts, dtype=np.int64), np.asarray(disps, dtype=float).reshape(-1, 3)


def replay(problem, actions: list[dict], snapshots: bool = False, blowup_out=None,
           blowup_label: str = "panda"):
    """The arm executing ``actions`` from the problem's start: (executor, PandaExecution);
    ``blowup_out``: the run folder of a blow-up capture (``PandaExecutor.execute``)."""
    from dopt.tasks.pick.panda_gripper import PandaExecutor

    parts, disps = plan_actions(actions)
    held = sorted({int(p) for p in parts if p >= 0}) or [0]
    arm = PandaExecutor(problem.scene, pickable=held)
    return arm, arm.execute(problem.start_state, parts, disps, snapshots=snapshots,
                            blowup_out=blowup_out, blowup_label=blowup_label)


def trial_identity(params: dict) -> dict:
    """What names a trial of ``params`` ({"goal", "seed", "settings"}): its goal, seed and
    ``PickPlaceSettings.identity`` (not the threads). A stored record whose params give
    another is another trial's, recomputed (``SCHEMA``)."""
    return {"goal": params["goal"], "seed": int(params["seed"]),
            "settings": PickPlaceSettings.from_dict(params["settings"]).identity()}


def panda_key(params: dict) -> str:
    """A trial's key (its file under OUT/trials, its capture under OUT/blowups): the pick
    rule, ``planners.pick_place.trial_key``, labelled by the goal."""
    return trial_key(params["goal"], int(params["seed"]),
                     PickPlaceSettings.from_dict(params["settings"]))


def legacy_trial_key(goal: str, seed: int, n: int, quick: bool) -> str:
    """The key of a trial written before the one identity (``<goal>-seed<seed>-n<n>``, and
    ``-quick`` for a smoke run's): only to find those trials (``trial_aliases``)."""
    return f"{goal}-seed{seed}-n{n}{'-quick' if quick else ''}"


def trial_aliases(params: dict) -> tuple[str, ...]:
    """The older keys a trial of ``params`` may be stored under (``legacy_trial_key``, with
    and without ``-quick``: the params do not say; the identity check tells them apart)."""
    n = int(params["settings"]["n"])
    return tuple(legacy_trial_key(params["goal"], int(params["seed"]), n, quick)
                 for quick in (False, True))


#: what a stored trial must be to be reused: the trial it is stored for (``trial_identity``),
#: under its key or its older one (``trial_aliases``)
SCHEMA = Schema(identity=trial_identity, aliases=trial_aliases)


def panda_trial(params: dict, report=None, blowup_out: str | None = None) -> dict:
    """Plan with CEM(Simple) on the picker, replay with the arm; the two final costs and how
    far apart the two final cloths are (m). ``report`` (the sweep's) is called after each CEM
    iteration. ``blowup_out``: the run folder that receives a blow-up capture of the arm's
    replay as blowups/<trial key> (``panda_key``; an earlier run's moves to
    blowups/outdated/)."""
    from dopt.tasks.pick.scene import mean_distance

    s = PickPlaceSettings.from_dict(params["settings"])
    seed = params["seed"]
    problem = make_problem(s, seed)
    res = run_problem(problem, make_planner("simple", s, seed), method="simple", seed=seed,
                      on_iteration=None if report is None else (lambda i, best: report()))
    label = panda_key(params)
    if blowup_out is not None:
        retire_captures(blowup_out, [label])
    _, done = replay(problem, res.actions, blowup_out=blowup_out, blowup_label=label)
    return {"seed": seed, "n_actions": int(sum(len(a["particles"]) for a in res.actions)),
            "picker_final_cost": float(res.metrics["final_cost"]),
            "panda_final_cost": float(mean_distance(done.positions, problem.final_goal)),
            "picker_vs_panda": float(mean_distance(done.positions,
                                                   problem.scene.positions(res.final_state))),
            "grasp_distance_max": max(done.grasp_distance, default=0.0),
            "missed_actions": [int(k) for k in done.missed],
            "carry_errors": [float(e) for e in done.carry_error],
            "picker_unstable": bool(res.unstable), "panda_unstable": done.unstable,
            "panda_unstable_reason": done.stability.reason[0], "panda_steps": done.steps,
            "actions": res.actions,
            "blowups": [os.path.relpath(b, blowup_out) for b in done.blowups]}


def summarize(records: list[dict]) -> dict:
    """Per goal: both final costs (mean, 95 % CI), their paired difference, the distance
    between the final cloths, the worst grasp distance and carry error."""
    by: dict = {}
    for r in records:
        by.setdefault(r["params"]["goal"], []).append(r["result"])
    out = {}
    for goal, rs in by.items():
        entry = {"n": len(rs), "seeds": [r["seed"] for r in rs]}
        for key in ("picker_final_cost", "panda_final_cost", "picker_vs_panda"):
            entry[f"{key}_mean"], entry[f"{key}_ci95"] = finite_mean_ci([r[key] for r in rs])
        entry["difference_mean"], entry["difference_ci95"] = finite_mean_ci(
            [r["panda_final_cost"] - r["picker_final_cost"] for r in rs])
        entry["grasp_distance_max"] = max(r["grasp_distance_max"] for r in rs)
        entry["missed_actions"] = int(sum(len(r["missed_actions"]) for r in rs))
        entry["n_actions"] = int(sum(r["n_actions"] for r in rs))
        entry["carry_error_max"] = max((e for r in rs for e in r["carry_errors"]), default=0.0)
        entry["picker_unstable_seeds"] = [r["seed"] for r in rs if r["picker_unstable"]]
        entry["panda_unstable_seeds"] = [r["seed"] for r in rs if r.get("panda_unstable")]
        out[goal] = entry
    return out


#: colours of the strip's goal dots and of the cloth's legend swatch (its flex_rgba)
GOAL_DOTS, CLOTH = (0, 90, 255), (204, 77, 51)
#: what each snapshot of an executed action shows (``PandaExecutor.execute``)
PHASES = ("grasped", "carried", "released")


def strip_labels(n_snapshots: int) -> list[str]:
    """The label of each snapshot: "start", then per executed action its grasp, carry and
    release."""
    return ["start"] + [f"action {k // 3 + 1}: {PHASES[k % 3]}"
                        for k in range(n_snapshots - 1)]


def render_strip(path, arm, done, goal_positions, title: str) -> None:
    """The snapshots side by side from one oblique camera framing the cloth and the hand,
    each labelled (``strip_labels``), the goal shape (N, 3) as blue dots in every panel (the
    picker, parked above, hidden), and below them ``title`` and the legend."""
    import imageio.v3 as iio
    from PIL import Image, ImageDraw

    from dopt.render import draw_markers, fit_camera, project, render_states
    from dopt.tasks.pick.panda_gripper import SNAPSHOT_SPEC
    from dopt.view.legend import LegendItem
    from dopt.view.still import annotate, font

    model, width, height = arm.model, 320, 240
    points = np.concatenate([arm.positions(), arm.positions() + [0, 0, 0.25]])
    cam = fit_camera(points, azimuth=200.0, elevation=-35.0, fill=0.8)
    picker = [g for g in range(model.ngeom) if model.geom_bodyid[g]
              and model.body(int(model.geom_bodyid[g])).name == "picker"]
    frames = render_states(model, np.asarray(done.snapshots), SNAPSHOT_SPEC, cam, width,
                           height, hide_geoms=picker)
    goal_px = project(np.asarray(goal_positions), cam, width, height,
                      float(model.vis.global_.fovy))
    panels = []
    for frame, label in zip(frames, strip_labels(len(frames)), strict=True):
        image = Image.fromarray(draw_markers(frame, goal_px, GOAL_DOTS, radius=3.0,
                                             outline=None))
        ImageDraw.Draw(image).text((6, 4), label, fill=(0, 0, 0), font=font(14))
        panels.append(np.asarray(image))
    legend = [LegendItem("cloth", CLOTH, "patch"),
              LegendItem("goal shape (the cloth's particles at the goal)", GOAL_DOTS, "dot")]
    with atomic.writing(path) as tmp:
        iio.imwrite(tmp, annotate(np.concatenate(panels, axis=1), [title], legend),
                    extension=".png")


def strip_title(goal: str, seed: int, result: dict) -> str:
    """The strip's caption: the goal, the seed and both final costs."""
    return (f"{goal}, seed {seed}: CEM(Simple)'s plan executed by the Panda; final cost "
            f"{result['panda_final_cost'] * 1e3:.1f} mm (the floating picker's: "
            f"{result['picker_final_cost'] * 1e3:.1f} mm)")


def parse_args(argv=None) -> argparse.Namespace:
    """Parsed flags; exit 2 with one line on a bad one."""
    ap = parser()
    args = ap.parse_args(argv)
    if args.trials is None:                     # an explicit --trials stands with --quick
        args.trials = 1 if args.quick else 3
    check_outputs(ap, args, "panda_execute")
    return args


@guarded("panda_execute.py")
def main(argv=None) -> int:
    args = parse_args(argv)
    logging.basicConfig(level=logging.INFO if args.verbose else logging.WARNING)
    seeds = range(args.seed, args.seed + args.trials)
    trials = []
    for goal in args.goals:
        s = settings_of(goal, args)
        for seed in seeds:
            params = {"goal": goal, "seed": int(seed), "settings": s.to_dict()}
            trials.append(Trial(panda_key(params), params))
    iterations = {g: settings_of(g, args).cem.iterations
                  * len(make_problem(settings_of(g, args), args.seed).stages)
                  for g in args.goals}
    res = run_with_console(
        functools.partial(panda_trial, blowup_out=str(args.out)), trials,
        args.out, unit="it", desc="CEM iterations (the arm's replays uncounted)",
        steps=lambda t: iterations[t.params["goal"]],
        held=lambda t: iterations[t.params["goal"]] if is_finished(
            args.out, t.key, schema=SCHEMA, params=t.params) else 0,
        describe=lambda rec: (f"picker {rec['result']['picker_final_cost'] * 1e3:.1f} mm, "
                              f"Panda {rec['result']['panda_final_cost'] * 1e3:.1f} mm"),
        workers=args.workers, fresh=args.fresh, schema=SCHEMA, reuse=reuse_mode(args))
    for key, err in res.failed.items():
        print(f"FAILED {key}: {err}", file=sys.stderr)
    wanted = {t.key for t in trials}
    records = [r for k, r in res.records.items() if k in wanted]
    goals = summarize(records)
    write_summary({"experiment": "panda_execute", "task": "cloth", "goals": goals,
                   "protocol": "ours",
                   # every field, and what the presets resolve to (scene, picker, stability)
                   "settings": {g: settings_of(g, args).to_dict() for g in args.goals},
                   "physics": {g: settings_of(g, args).resolved_physics()
                               for g in args.goals},
                   "failed": res.failed, "trial_commits": res.commits,
                   "blowups": print_captures(args.out, captures_of(
                       args.out, [res.stored_key(t.key) for t in trials]))},
                  args.out, args.record, "experiments/panda_execute.py", argv)
    for goal, e in goals.items():
        print(f"{goal}: picker {e['picker_final_cost_mean'] * 1e3:.1f} mm, panda "
              f"{e['panda_final_cost_mean'] * 1e3:.1f} mm, final cloths "
              f"{e['picker_vs_panda_mean'] * 1e3:.1f} mm apart ({e['n']} seeds)")
    if not args.no_render:
        for goal in args.goals:
            first = next((t for t in trials if t.params["goal"] == goal), None)
            if first is not None and first.key in res.records:
                problem = make_problem(PickPlaceSettings.from_dict(first.params["settings"]),
                                       first.params["seed"])
                result = res.records[first.key]["result"]
                arm, done = replay(problem, result["actions"], snapshots=True)
                render_strip(args.out / f"panda_{goal}.png", arm, done, problem.final_goal,
                             strip_title(goal, first.params["seed"], result))
    # the arm's replays are no trial dopt-view opens (it replays the picker's plans)
    print_outputs(args.out, [f"panda_{goal}.png" for goal in args.goals], viewer=False)
    return 1 if res.failed else 0


if __name__ == "__main__":
    sys.exit(main())
