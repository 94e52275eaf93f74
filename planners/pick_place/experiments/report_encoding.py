"""The report of the drag-encoding sweep (``experiments/fig7_encoding.py``, result files of
experiment "fig7_encoding", ``planners.pick_place.encoding.encoding_summary``): its RESULTS.md
section, its headline, its staleness and its rebuild from its trials.

Per file (one fold): the settings in full (the physics mesh and sheet, the candidate counts
N, the drag encoding's decisions, substeps and step, CEM's budget and elites, the plan's
cost), the figure where docs/images holds one, per N and method the mean final cost with its
95 % interval, the paired Original - Simple and Random - Simple, and the trend of each against
log N with its Holm-adjusted p (over the two tests; with several folds also over all their
tests, ``report_paper.encoding_families``), and from the committed trials CEM(Original)'s
pick spread (``pick_spread``) and how far each method's plans get (``plan_diagnostics``: the
final cost against the flat sheet's, the drags that keep their point, executed against
planned). The claim and the README row:
``report_claims`` and ``report_map``.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict
from pathlib import Path

import numpy as np

from dopt.lab.experiment import own_trials
from dopt.lab.report.base import Result, _and, mm, num, pm, section, table
from dopt.lab.report.stale import _diff, command_preset
from dopt.lab.trialpack import StoredTrial, stored_trials
from planners.pick_place.drag_settings import DragSettings
from planners.pick_place.experiments.report_paper import (
    _label,
    encoding_families,
    encoding_key,
    family_note,
)
from planners.trial_progress import RUN_ONLY_SETTINGS

#: the methods of the table, in the figures' order (the statistics' names)
METHODS = ("simple", "original", "random")
#: the section's title (the claim's and the map row's details link here)
TITLE = "Key particles: the gain against the candidate count under the drag encoding"
#: the mean distance between two independent uniform points on a unit square (square line
#: picking: (2 + sqrt 2 + 5 ln(1 + sqrt 2)) / 15)
UNIFORM_PAIR = (2 + math.sqrt(2) + 5 * math.log(1 + math.sqrt(2))) / 15
#: the summary fields its trials give (``rebuild``)
TRIAL_FIELDS = ("sizes", "n_points", "per_size", "trend", "verdict", "trial_commits")


def _by_count(d: dict) -> list[tuple[int, dict]]:
    """(N, its recorded settings) of a summary, N ascending."""
    return sorted(((int(n), s) for n, s in d["settings"].items()), key=lambda x: x[0])


def _seeds(seeds: list) -> str:
    seeds = sorted(int(s) for s in seeds)
    if seeds and seeds == list(range(seeds[0], seeds[-1] + 1)) and len(seeds) > 2:
        return f"{seeds[0]}-{seeds[-1]} ({len(seeds)})"
    return f"{', '.join(map(str, seeds))} ({len(seeds)})"


def settings_lines(d: dict) -> list[str]:
    """The settings of a summary in words: those of its smallest N, and any that differ at
    another N (beside the candidate count)."""
    counts = _by_count(d)
    n0, s = counts[0]
    drag = DragSettings(**s["drag"])
    scene = ((d.get("physics") or {}).get(str(n0)) or {}).get("scene") or {}
    cost = ("the lowest Eq. 2 cost at the end of any decision, the executed plan stopping "
            "there (the authors')" if drag.best_over_trajectory else
            "Eq. 2 after the whole plan and the settle")
    lines = [f"The paper protocol's cloth {d.get('goal')} fold on one physics mesh of "
             f"{s['n']} x {s['n']} particles over a sheet of {mm(s['side'])} mm (physics "
             f"preset `{s.get('physics')}`, timestep {num(scene.get('timestep'), 4)} s, "
             f"self-collision {'on' if s.get('selfcollide') else 'off'}); N candidate pick "
             f"points {', '.join(str(n) for n, _ in counts)} (a sqrt N x sqrt N grid attached "
             f"to the mesh). Drag encoding: T = {drag.horizon} decisions of {drag.repeat} "
             f"substeps, each at most {mm(drag.step)} mm per axis (picker bound "
             f"{mm(s.get('bound'))} mm), {_plural(drag.substeps, 'MuJoCo step')} per "
             f"substep; CEM population {drag.population}, "
             f"{_plural(drag.iterations, 'iteration')}, elites fraction "
             f"{num(drag.elites_fraction, 2)} ({_plural(drag.elites, 'elite')}); a plan's "
             f"cost: {cost}. "
             f"Seeds {_seeds(d.get('seeds') or [])}; methods "
             f"{', '.join(d.get('methods_run') or [])}.", ""]
    first = {k: v for k, v in s.items() if k not in RUN_ONLY_SETTINGS}
    for n, other in counts[1:]:
        diff = _diff(first, other, skip=(*RUN_ONLY_SETTINGS, "drag.n_points"))
        if diff:
            lines += [f"At N {n} the settings differ from N {n0}'s: {', '.join(diff)}.", ""]
    return lines


def _cell(e: dict | None) -> str:
    e = e or {}
    return pm(mm(e.get("final_cost_mean")), mm(e.get("final_cost_ci95"))) + f" ({e.get('n', 0)})"


def _gap(e: dict | None) -> str:
    e = e or {}
    return pm(mm(e.get("mean")), mm(e.get("ci95")))


def _plural(k: int, word: str) -> str:
    return f"{k} {word}{'' if k == 1 else 's'}"


def _trend_line(key: str, t: dict) -> str:
    """One trend test of a summary ("trend": ``scaling_summary``'s) in words."""
    what = (f"- {key.replace('_minus_simple', '')} - simple, "
            f"{_plural(t['n_points'], 'paired seed')} over {_plural(t['n_sizes'], 'value')} "
            "of N: ")
    if t.get("slope") is None:
        return what + "**not testable** (too few values of N or seeds to fit a slope)"
    return (what + f"slope {pm(mm(t['slope']), mm(t.get('slope_ci95')))} mm per unit of "
            f"log N (95 % interval), Holm p {num(t.get('p_holm'), 3)}: **{t['verdict']}**")


def pick_spread(records: list[dict]) -> dict[int, tuple[float, int]]:
    """Per candidate count N, {N: (the mean over CEM(Original)'s trials of the mean distance
    (m) between its executed plan's consecutive picks, the trials with two picks or more)}.
    A trial's picks are its first stage's candidate indices (``-1``, None, skipped) into the
    m x m grid ``drag.grid_points`` lays over a flat sheet of side ``settings.side``. Against
    ``UNIFORM_PAIR`` x side: a plan whose picks were independent uniform draws. Records that
    are not drag trials with these fields are skipped."""
    from planners.pick_place.drag import grid_points

    per: dict[int, list[float]] = {}
    for rec in records:
        try:
            if rec["result"]["method"] != "original-drag":
                continue
            settings = rec["params"]["settings"]
            n, side = int(settings["drag"]["n_points"]), float(settings["side"])
            idx = np.asarray(rec["result"]["actions"][0]["particles"], dtype=int)
        except (KeyError, TypeError, ValueError, IndexError):
            continue
        m, idx = round(math.sqrt(n)), idx[idx >= 0]
        if len(idx) < 2 or m < 2:
            continue
        xy = grid_points(np.array([[0.0, 0.0, 0.0], [side, side, 0.0]]), m)[idx, :2]
        per.setdefault(n, []).append(float(np.linalg.norm(np.diff(xy, axis=0), axis=1).mean()))
    return {n: (float(np.mean(v)), len(v)) for n, v in sorted(per.items())}


def _records(r: Result, results_dir: Path) -> list[dict]:
    """The committed trial records a file's summary holds ([] where none are found)."""
    from dopt.lab.report.resummarize import records_of
    from dopt.lab.report.trials import summary_trials

    info = summary_trials(results_dir, r)
    return records_of(info) if info is not None else []


def _spread_line(r: Result, records: list[dict]) -> list[str]:
    """The sentence on CEM(Original)'s pick spread of a file's committed trials ([] without)."""
    spread = pick_spread(records)
    sides = {float(s["side"]) for s in r.data["settings"].values()}
    if not spread or len(sides) != 1:
        return []
    cells = " / ".join(f"{mm(d)} mm ({k})" for d, k in spread.values())
    return [f"CEM(Original)'s executed plan, the mean distance between consecutive picks (mean "
            f"over its trials, their number in brackets), N {' / '.join(map(str, spread))}: "
            f"{cells}; two independent uniform points on the sheet lie "
            f"{mm(UNIFORM_PAIR * sides.pop())} mm apart. Where they match, the plan carries no "
            "point from one drag to the next, and a narrower bin cannot hold it back further.",
            ""]


def plan_diagnostics(records: list[dict]) -> dict[str, dict]:
    """Per drag method, how its executed plans stand ({method: {"trials", "final" (mean final
    cost, m), "pairs" (consecutive drag pairs of the executed plans, None picks included),
    "carried" (the share of those pairs that pick the same point twice; nan without pairs),
    "held_gap" (mean of executed - planned, m: the final cost after the release and settle
    minus the plan's cost, the lowest of its CEM history), "largest" (the largest
    executed - planned, m, with its seed and N)}}, methods in ``METHODS``' order. Records
    that are not drag trials with these fields are skipped."""
    per: dict[str, dict] = {}
    for rec in records:
        try:
            res = rec["result"]
            method = str(res["method"])
            n = int(rec["params"]["settings"]["drag"]["n_points"])
            idx = np.asarray(res["actions"][0]["particles"], dtype=int).reshape(-1)
            final, planned = float(res["final_cost"]), float(min(res["cost_history"]))
        except (KeyError, TypeError, ValueError, IndexError):
            continue
        if not method.endswith("-drag"):
            continue
        e = per.setdefault(method.removesuffix("-drag"), {"finals": [], "gaps": [],
                                                          "pairs": 0, "carried": 0})
        e["finals"].append(final)
        e["gaps"].append((final - planned, int(res.get("seed", -1)), n))
        e["pairs"] += max(len(idx) - 1, 0)
        e["carried"] += int(np.sum((idx[1:] == idx[:-1]) & (idx[1:] >= 0)))
    out = {}
    for m in sorted(per, key=lambda k: METHODS.index(k) if k in METHODS else len(METHODS)):
        e = per[m]
        largest = max(e["gaps"])
        out[m] = {"trials": len(e["finals"]), "final": float(np.mean(e["finals"])),
                  "pairs": e["pairs"],
                  "carried": e["carried"] / e["pairs"] if e["pairs"] else math.nan,
                  "held_gap": float(np.mean([g for g, _, _ in e["gaps"]])),
                  "largest": {"gap": largest[0], "seed": largest[1], "n_points": largest[2]}}
    return out


def _flat_cost(d: dict) -> float | None:
    """The flat sheet's cost (m) to a drag-encoding file's goal (``scaling.fold_costs`` of its
    first recorded settings; the physics mesh and sheet are one for every N); None where the
    settings cannot be read."""
    from planners.pick_place.scaling import fold_costs

    try:
        s = _by_count(d)[0][1]
        return fold_costs(str(s["goal"]), int(s["n"]), float(s["side"]))[0]
    except (KeyError, TypeError, ValueError, IndexError):
        return None


def _diagnostics_lines(d: dict, records: list[dict]) -> list[str]:
    """The table of ``plan_diagnostics`` over a file's committed trials ([] without)."""
    diag, flat = plan_diagnostics(records), _flat_cost(d)
    if not diag:
        return []
    rows = []
    for m, e in diag.items():
        big = e["largest"]
        rows.append([_label(m), str(e["trials"]), mm(e["final"]),
                     num(e["final"] / flat, 2) if flat else "-",
                     "-" if math.isnan(e["carried"]) else
                     f"{num(100 * e['carried'], 0)} % of {e['pairs']}",
                     mm(e["held_gap"]),
                     f"{mm(big['gap'])} (seed {big['seed']}"
                     + (")" if m == "simple" else f", N {big['n_points']})")])
    flat_words = (f"the flat sheet lies {mm(flat)} mm from the goal" if flat
                  else "the flat sheet's cost could not be computed")
    return [f"How far the plans get, over all N ({flat_words}; a final cost / flat of 1 is no "
            "progress): the executed plans' drags that pick the point the drag before picked "
            "(consecutive pairs, None picks counted as pairs not kept), and the final cost "
            "after the release and settle minus the plan's cost, judged at its best decision "
            "with the cloth still held.", "",
            *table(["method", "trials", "final cost (mm)", "final / flat", "drags keeping "
                    "the point", "executed - planned (mm)", "largest (mm)"], rows)]


def encoding_section(results: list[Result], page: Path) -> list[str]:
    """RESULTS.md's section of the drag-encoding files."""
    _, family = encoding_families(results)

    def across(r: Result, key: str) -> str:   # the verdict of every fold's tests together
        return family_note(family.get((encoding_key(r), key)) if not r.quick else None)

    def body(r: Result) -> list[str]:
        d = r.data
        rows = []
        for n, count in zip(d["sizes"], d["n_points"], strict=True):
            e = d["per_size"][str(n)]
            rows.append([str(count), f"{n} x {n}",
                         *(_cell(e["methods"].get(m)) for m in METHODS),
                         *(_gap(e.get(f"{m}_minus_simple")) for m in METHODS[1:])])
        trends = [_trend_line(key, t) + across(r, key) for key, t in d["trend"].items()]
        records = _records(r, page.parent / "results")
        image = page.parent / "images" / f"{r.path.stem}.png"
        figure = ([f"![Final cost and the gaps to CEM(Simple) against the candidate count N "
                   f"under the drag encoding, {d.get('goal')} fold, 95 % intervals]"
                   f"(images/{image.name})", ""] if image.exists() else [])
        return [f"### {encoding_key(r)}: `{r.name}`", "", *figure, *settings_lines(d),
                "Final cost (mm, the mean particle distance to the goal): mean ± 95 % CI "
                "(seeds); the differences paired over the seeds both ran.", "",
                *table(["candidates N", "grid", *(_label(m) for m in METHODS),
                        "Original - Simple", "Random - Simple"], rows), "", *trends, "",
                *_spread_line(r, records), *_diagnostics_lines(d, records)]

    return section(TITLE,
                   "`python experiments/fig7_encoding.py`: CEM(Simple), CEM(Original) and "
                   "CEM(Random) planning a cloth fold in the authors' action encoding: T short "
                   "drags, each picking by an index scalar over N + 2 bins, re-drawn at every "
                   "drag, so that to carry one point across drags CEM(Original) must hold it in "
                   "a bin of width 1 / (N + 2). N candidate points are attached to one physics "
                   "mesh, so N grows without growing the simulation; CEM(Random) samples its "
                   "points among the N, CEM(Simple) plans over the key particles at any N (one "
                   "run per seed, paired with every N). Trend: the least-squares slope of each "
                   "seed's paired difference (method - Simple) against log N, its 95 % "
                   "interval, and the p-value Holm-adjusted over the two comparisons (with "
                   "several folds recorded, also over all their tests as one family); a "
                   "positive slope means Simple's gain grows with N. The paper (Sec. V) says "
                   "the improvement of the reduced action space over the original grows with "
                   "the number of particles; each verdict below is this test's over the values "
                   "of N its file holds.",
                   results, page, body, key=lambda r: (encoding_key(r), r.name))


def encoding_headline(r: Result) -> str:
    """One line: the fold, its N and seeds, and the library's verdict on both trends."""
    d = r.data
    return (f"{encoding_key(r)}, N {_and([str(n) for n in d['n_points']])}, "
            f"{_plural(len(d.get('seeds') or []), 'seed')}: {d['verdict']}")


# ------------------------------------------------------------------------ staleness
def _chosen(command: str) -> set[str] | None:
    """The ``DragSettings`` fields the recorded command set itself (its flags, --quick, the
    candidate counts); None where a --config file may have set any."""
    from planners.pick_place.experiments.encoding import QUICK_DRAG, drag_flags

    _, flags = command_preset(command)
    if "--config" in flags:
        return None
    chosen = {"n_points"} | {f.path for f in drag_flags().flags if f.flag in flags}
    if "--cost" in flags:
        chosen.add("best_over_trajectory")
    if "--quick" in flags:
        chosen |= set(QUICK_DRAG)
    return chosen


def encoding_stale(r: Result) -> list[str] | None:
    """What in a drag-encoding file today's code no longer gives (one sentence each, [] when
    current): the drag settings its command left to their defaults against ``DragSettings``'
    today; per N its recorded settings against ``encoding_settings`` of its own drag settings
    and side today (the paper protocol's preset, the mesh, the bound), and its recorded
    physics against what those resolve to (``resolved_physics``). None where a recorded
    settings entry cannot be read."""
    from planners.pick_place.encoding import encoding_settings

    d, found = r.data, {}
    try:
        counts = _by_count(d)
        chosen = _chosen(r.origin_command)
        if chosen is not None:
            diff = _diff(counts[0][1]["drag"], asdict(DragSettings()), skip=tuple(chosen))
            if diff:
                found[f"the drag encoding's defaults now set {', '.join(diff)}"] = None
        for n, s in counts:
            now = encoding_settings(d["goal"], DragSettings(**s["drag"]), s["side"])
            today = now.to_dict()
            diff = _diff(s, today, skip=RUN_ONLY_SETTINGS)
            if diff:
                found.setdefault(f"its settings are now {', '.join(diff)}", []).append(n)
            physics = (d.get("physics") or {}).get(str(n))
            diff = _diff(physics, now.resolved_physics()) if isinstance(physics, dict) else []
            if diff:
                found.setdefault(f"its physics now resolves to {', '.join(diff)}", []).append(n)
    except (KeyError, TypeError, ValueError, AttributeError):
        return None
    every = len(counts)
    return [text if ns is None or len(ns) == every else
            f"at N {_and([str(n) for n in ns])} {text}" for text, ns in found.items()]


def encoding_rebuild(data: dict, records: list[dict]) -> dict:
    """The ``TRIAL_FIELDS`` of a summary computed again from its trial records."""
    from dopt.lab.report.resummarize import commits_of
    from planners.pick_place.encoding import encoding_summary

    return {**encoding_summary(records, data["points"]), "trial_commits": commits_of(records)}


def encoding_trial_files(folder: Path, r: Result) -> list[StoredTrial]:
    """The trials of ``folder`` a drag-encoding summary holds: those its "trial_keys" names,
    else those of its methods and seeds at its candidate counts (each trial's params: method,
    seed, settings.drag.n_points)."""
    if isinstance(r.data.get("trial_keys"), list):
        return own_trials(folder, r)
    d = r.data
    methods, seeds = set(d.get("methods_run") or ()), set(d.get("seeds") or ())
    points = set(d.get("points") or ())
    out = []
    for p in stored_trials(Path(folder) / "trials"):
        try:
            params = json.loads(p.read_text())["params"]
            held = (params["method"] in methods and params["seed"] in seeds
                    and params["settings"]["drag"]["n_points"] in points)
        except (OSError, ValueError, KeyError, TypeError):
            held = False
        if held:
            out.append(p)
    return out
