"""Fig. 7 sweeps in progress (RESULTS.md): committed trials that no recorded summary holds yet,
seed by seed, with the checkpoints of trials stopped part-way.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

from dopt.lab.experiment import own_trials
from dopt.lab.report.base import ReportError, Result, _finite, _median, mm, num, table
from dopt.lab.trialpack import PackError, StoredTrial, stored_trials
from planners.pick_place.encoding import BASE
from planners.pick_place.experiments.report_fig7 import fold_notes
from planners.pick_place.experiments.report_paper import (
    _in_label_order,
    _label,
    _panel_of,
    _panel_rank,
)
from planners.trial_progress import RUN_ONLY_SETTINGS, iterations_done


# ----------------------------------------------------------------- sweeps in progress
def ran_settings(summary: dict, settings: dict) -> bool:
    """Whether a Fig. 7 sweep's ``summary`` can hold a trial with these ``settings``: its
    "settings" (one sweep's) equal to them on every key but ``RUN_ONLY_SETTINGS``, a key only
    one side holds counting as None (a setting added since the summary was recorded, such
    as ``fold_start``, left at None by its trials); always where the summary records per-size
    settings (a scaling study's: ``held_seeds`` matches those by size) or none."""
    recorded = summary.get("settings")
    if "per_size" in summary or not isinstance(recorded, dict) or not isinstance(settings, dict):
        return True
    keys = (set(recorded) | set(settings)) - set(RUN_ONLY_SETTINGS)
    return all(recorded.get(k) == settings.get(k) for k in keys)


def held_seeds(summary: dict, method: str, settings: dict) -> set:
    """The seeds of ``method`` that a recorded Fig. 7 ``summary`` holds for trials with these
    ``settings``: a sweep's (``methods.<m>.seeds``), or a scaling study's for the trial's size
    (``per_size.<n>.methods.<m>.seeds``, ``fig7_scaling.py``; the drag encoding's,
    ``fig7_encoding.py``: its size the side of the trial's grid of candidate points, its method
    the one it stands for, ``planners.pick_place.encoding.BASE``); none where ``summary`` is
    empty or ran other settings (``ran_settings``)."""
    if not ran_settings(summary, settings):
        return set()
    if "per_size" in summary:
        size = settings.get("n")
        drag = settings.get("drag")
        if "n_points" in summary and isinstance(drag, dict):
            size, method = round(drag.get("n_points", 0) ** 0.5), BASE.get(method, method)
        summary = summary["per_size"].get(str(size), {})
    return set(summary.get("methods", {}).get(method, {}).get("seeds") or ())


def unrecorded_sweeps(results_dir: Path, results: list[Result]) -> dict[str, list[dict]]:
    """{folder name: its trial records} of every ``runs/fig7-*`` folder under ``results_dir``
    with committed trials (``trials/*.json`` as ``dopt.lab.sweep`` writes them, or packed:
    ``dopt.lab.trialpack.stored_trials``) that its recorded summary ``<folder>.json`` among
    ``results`` (``load_results(results_dir)``) does not hold: all of them while no summary
    is recorded, else those whose method and seed (and a scaling study's size: ``held_seeds``)
    the summary lacks (a sweep recorded for some methods, seeds or sizes, more committed
    since). Folders in name order, records in file-name order; a folder whose trials the
    summary holds all of is left out, unless trials of it stopped part-way (its
    ``trials/checkpoints/``: then with no records)."""
    recorded = {r.path.stem: r.data for r in results}
    out = {}
    for folder in sorted(Path(results_dir).glob("runs/fig7-*")):
        try:
            files = stored_trials(folder / "trials")
        except PackError as e:
            raise ReportError(str(e)) from e
        summary = recorded.get(folder.name, {})
        records = []
        for path in files:
            try:
                data = json.loads(path.read_text())
                # dopt.lab.sweep.RECORD_FIELDS (copied: this script imports no dopt.lab.sweep)
                missing = [k for k in ("key", "params", "result") if k not in data]
                if missing:
                    raise KeyError(", ".join(missing))
                params, result = data["params"], data["result"]
                record = {"settings": params["settings"], "method": result["method"],
                          "seed": result["seed"], "result": result}
            except (OSError, ValueError, KeyError, TypeError) as e:
                raise ReportError(f"{path}: not a trial record of a Fig. 7 sweep "
                                  f"({type(e).__name__}: {e})") from e
            if record["seed"] not in held_seeds(summary, record["method"], record["settings"]):
                records.append(record)
        if records or any(folder.glob("trials/checkpoints/*.json")):
            out[folder.name] = records
    return out


def _checkpoints(folder: Path) -> list[tuple[dict, int, float]]:
    """(trial, CEM iterations done, seconds so far) per checkpoint under
    ``folder/trials/checkpoints/`` (``dopt.lab.sweep.Checkpoint``: a trial stopped part-way that
    a rerun resumes), in file-name order; ``ReportError`` naming the file for one that is not
    a Fig. 7 trial's."""
    out = []
    for path in sorted(Path(folder).glob("trials/checkpoints/*.json")):
        try:
            progress = json.loads(path.read_text())["progress"]
            trial = progress["trial"]
            if not isinstance(trial, dict) or not isinstance(trial.get("settings") or {}, dict):
                raise TypeError("its trial or the trial's settings is not a mapping")
            missing = [k for k in ("method", "seed") if k not in trial]
            if missing:
                raise KeyError(f"its trial has no {' or '.join(missing)}")
            out.append((trial, iterations_done(progress), progress["wall_s"]))
        except (OSError, ValueError, KeyError, TypeError) as e:
            raise ReportError(f"{path}: not a checkpoint of a Fig. 7 trial "
                              f"({type(e).__name__}: {e})") from e
    return out


def checkpointed_trials(checkpoints: list[tuple[dict, int, float]]) -> list[str]:
    """"<method label> seed <s>: <n> CEM iterations done, <t> s" per checkpoint of
    ``_checkpoints``, in its order."""
    return [f"{_label(trial['method'])} seed {trial['seed']}: {n} CEM "
            f"iteration{'s' if n != 1 else ''} done, {num(wall, 0)} s"
            for trial, n, wall in checkpoints]


def _sweep_heading(name: str, settings: dict, label: str = "") -> list[str]:
    """The blank line and "### `<sweep>`: Fig. 7 <panel>" heading of one sweep's block,
    "### `<sweep>` at <label>: ..." for one of its settings groups (``_group_labels``)."""
    at = f" at {label}" if label else ""
    return ["", f"### `{name}`{at}: Fig. 7 "
                f"{_panel_of(settings.get('task'), settings.get('goal'))}"]


def _size_key(s: dict) -> tuple:
    """A settings group's place in its sweep: by the cloth's (or rope's) particles, then by
    the drag encoding's candidate points."""
    drag = s.get("drag") if isinstance(s.get("drag"), dict) else {}
    n, points = s.get("n"), drag.get("n_points")
    return (n if isinstance(n, int) else 0, points if isinstance(points, int) else 0)


def _group_labels(groups: list[dict]) -> list[str]:
    """What tells one sweep's settings ``groups`` apart in their headings: the drag
    encoding's candidate points, else the cloth's "<n> x <n>" (a rope's "<n> particles");
    numbered "settings <i> of <k>" where those do not tell them apart; none for one group."""
    if len(groups) < 2:
        return [""] * len(groups)
    labels = [f"{s['drag'].get('n_points')} candidate points"
              if isinstance(s.get("drag"), dict) else _grid_words(s) for s in groups]
    if len(set(labels)) < len(labels):
        return [f"settings {i} of {len(groups)}" for i in range(1, len(groups) + 1)]
    return labels


def _group_table(group: list[dict]) -> list[str]:
    """One settings group's table: per method its seeds, their final costs, the median
    cost of an iteration and of a trial, and its flagged rollouts and unstable plans."""
    rows = []
    for m in _in_label_order(r["method"] for r in group):
        runs = sorted((r for r in group if r["method"] == m), key=lambda r: r["seed"])
        res = [r["result"] for r in runs]
        flagged = [x.get("n_unstable_rollouts") for x in res]
        rollouts = [x.get("n_rollouts") for x in res]
        rows.append([_label(m), ", ".join(str(r["seed"]) for r in runs),
                     ", ".join(mm(x.get("final_cost")) for x in res),
                     num(_median([x.get("s_per_iteration") for x in res]), 1),
                     num(_median([x.get("wall_s") for x in res]), 0),
                     f"{sum(flagged)} / {sum(rollouts)}"
                     if all(_finite(x) for x in flagged + rollouts) else "not judged",
                     str(sum(bool(x.get("unstable")) for x in res))])
    return table(["method", "seeds", "final cost per seed (mm)",
                  "s / CEM iteration (median)", "s / trial (median)",
                  "planning rollouts flagged", "executed plans unstable"], rows)


def _grid_words(s: dict) -> str:
    """"<n> x <n>" for a cloth trial's settings, "<n> particles" for a rope's."""
    n = s.get("n")
    return f"{n} x {n}" if s.get("task") == "cloth" else f"{n} particles"


def _size_words(s: dict) -> str:
    """"<n> x <n> particles (<side> m a side, <spacing> mm apart)" for a cloth trial's
    settings (its side when they name one), "<n> particles" for a rope's."""
    if s.get("task") != "cloth":
        return _grid_words(s)
    n, side = s.get("n"), s.get("side")
    if not (_finite(side) and isinstance(n, int) and n > 1):
        return f"{_grid_words(s)} particles"
    return (f"{_grid_words(s)} particles ({num(side, 3)} m a side, "
            f"{num(side / (n - 1) * 1e3, 1)} mm apart)")


def _budget(s: dict) -> str:
    """A trial's planning budget in words: CEM's per stage, or the drag encoding's (its
    candidate points, decisions and CEM budget, ``DragSettings``)."""
    drag = s.get("drag")
    if isinstance(drag, dict):
        return (f"drag encoding, {drag.get('n_points')} candidate points, T = "
                f"{drag.get('horizon')} drags, CEM population {drag.get('population')}, "
                f"{drag.get('iterations')} iterations")
    cem = s.get("cem") or {}
    return (f"CEM population {cem.get('population')}, elites {cem.get('elites')}, "
            f"{cem.get('iterations')} iterations per stage, horizon {cem.get('horizon')}")


def sweeps_in_progress_section(results_dir: Path, results: list[Result]) -> list[str]:
    """Per unrecorded Fig. 7 sweep (``unrecorded_sweeps``) and per settings in it (those
    that name a trial: ``RUN_ONLY_SETTINGS`` such as the thread count left out; smallest
    first, each heading naming its size where the sweep has more than one): each
    method's committed seeds with their final costs, and the measured cost of a trial. No
    means or claims: those wait for the recorded summary."""
    sweeps = unrecorded_sweeps(results_dir, results)
    if not sweeps:
        return []
    lines = ["## Fig. 7 sweeps in progress", "",
             "Trials committed under `docs/results/runs/<sweep>/trials/` that the sweep's "
             "summary (`docs/results/<sweep>.json`) does not hold yet (not recorded, or recorded "
             "for other methods, seeds or sizes), and trials stopped part-way: each seed's "
             "final cost (mean particle distance, mm) as its trial file holds it, and what a "
             "trial cost. Means, intervals and the paper's claims wait for the recorded "
             "summary; the command in the results table above (with these methods in "
             "`--methods` and enough `--trials`) resumes the sweep where it stopped."]
    summaries = {r.path.stem for r in results}
    checkpoints = {name: _checkpoints(Path(results_dir) / "runs" / name) for name in sweeps}

    def settings_of(name: str, records: list[dict]) -> dict:
        """A trial's settings, or (none finished) those of its first checkpoint."""
        if records:
            return records[0]["settings"]
        trial, _, _ = checkpoints[name][0]
        return trial.get("settings") or {}

    def panel_order(item) -> tuple:
        s = settings_of(*item)
        return _panel_rank(s.get("task"), s.get("goal")), item[0]

    for name, records in sorted(sweeps.items(), key=panel_order):
        if not records:
            lines += _sweep_heading(name, settings_of(name, records)) + [
                "", "No trial has finished yet" + (" beyond those its summary holds"
                                                   if name in summaries else "") + "."]
        by_settings: dict[str, list[dict]] = {}
        for rec in records:
            named = {k: v for k, v in rec["settings"].items() if k not in RUN_ONLY_SETTINGS}
            by_settings.setdefault(json.dumps(named, sort_keys=True), []).append(rec)
        groups = sorted(by_settings.values(), key=lambda g: _size_key(g[0]["settings"]))
        labels = _group_labels([g[0]["settings"] for g in groups])
        for group, label in zip(groups, labels, strict=True):
            s = group[0]["settings"]
            lines += _sweep_heading(name, s, label) + [
                "", f"{_size_words(s)}, self-collision "
                    f"{'on' if s.get('selfcollide') else 'off'}, physics {s.get('physics')}"
                    + (f", {s['fold_start']} start" if s.get("fold_start") else "")
                    + f"; {_budget(s)}.", ""]
            lines += _group_table(group)
            lines += fold_notes(s, [(r["method"], r["result"]) for r in group])
            wall = sum(x for r in group if _finite(x := r["result"].get("wall_s")))
            n = len(group)
            lines += ["", f"{n} trial{'s' if n != 1 else ''}, {num(wall, 0)} s of trials "
                          f"({num(wall / 3600, 1)} h of one core)."]
        stopped = checkpointed_trials(checkpoints[name])
        if stopped:
            lines += ["", "Stopped part-way, their progress committed under "
                          "`trials/checkpoints/` (a rerun resumes each where it stopped): "
                      + "; ".join(stopped) + "."]
    return lines


# ------------------------------------------------------- the trials a summary holds
#: a pick-and-place trial's key (``planners.pick_place.experiments`` sweeps' ``trial_key``)
FIG7_KEY = re.compile(r"^(?P<method>[a-z]+)-seed(?P<seed>\d+)-[0-9a-f]{8}$")


def fig7_trials(folder: Path, r: Result) -> list[StoredTrial]:
    """The trials of ``folder`` a Fig. 7 summary holds: those its "trial_keys" names, else
    its methods' seeds (the key is ``<method>-seed<seed>-<settings hash>``)."""
    if isinstance(r.data.get("trial_keys"), list):
        return own_trials(folder, r)
    held = {m: set(e.get("seeds") or ()) for m, e in (r.data.get("methods") or {}).items()}
    return [p for p in stored_trials(folder / "trials") if (m := FIG7_KEY.match(p.stem))
            and int(m["seed"]) in held.get(m["method"], ())
            and ran_settings(r.data, _trial_settings(p))]


def _trial_settings(path: Path | StoredTrial) -> dict | None:
    """A pick-and-place trial's settings (its params' "settings"; None unreadable)."""
    try:
        settings = json.loads(path.read_text())["params"]["settings"]
    except (OSError, ValueError, KeyError, TypeError):
        return None
    return settings if isinstance(settings, dict) else None


def scaling_trials(folder: Path, r: Result) -> list[StoredTrial]:
    """The trials of ``folder`` a scaling summary holds: those its "trial_keys" names, else
    its methods, seeds and cloth sizes (each trial's settings "n")."""
    if isinstance(r.data.get("trial_keys"), list):
        return own_trials(folder, r)
    d = r.data
    methods, seeds = set(d.get("methods_run") or ()), set(d.get("seeds") or ())
    sizes = set(d.get("sizes") or ())
    return [p for p in stored_trials(folder / "trials") if (m := FIG7_KEY.match(p.stem))
            and m["method"] in methods and int(m["seed"]) in seeds and _cloth_size(p) in sizes]


def _cloth_size(path: Path | StoredTrial) -> int | None:
    """The particles per side a pick-and-place trial ran on (its params' settings "n")."""
    n = (_trial_settings(path) or {}).get("n")
    return n if isinstance(n, int) else None
