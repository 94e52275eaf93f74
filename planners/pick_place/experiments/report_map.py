"""The key-particle paper's rows of README's map (``dopt.lab.report.map``): a headline sentence
per figure or table, read from the result files."""

from __future__ import annotations

from collections.abc import Callable

from dopt.lab.report.base import Result, mm, num, pm
from dopt.lab.report.map import MapRow
from planners.pick_place.experiments.report_encoding import TITLE as ENCODING_TITLE
from planners.pick_place.experiments.report_fig7 import CLOTH_DIFFICULTY, _departs, fig7_claims
from planners.pick_place.experiments.report_paper import (
    KP,
    _label,
    encoding_families,
    n_range,
    scaling_families,
)


def _paper(results: list[Result], kind: str, **where) -> list[Result]:
    """The files of ``kind`` (not quick) whose fields equal ``where``; Fig. 7 files that
    depart from their protocol are left out (RESULTS.md shows them beside it)."""
    return [r for r in results if r.kind == kind and not r.quick and not _departs(r)
            and all(r.data.get(k) == v for k, v in where.items())]


# ---------------------------------------------------------------------------- headlines
def kp_line(results: list[Result]) -> str | None:
    """Key counts of the library's goals against the paper's (rope keys, cloth triangles)."""
    files = _paper(results, "key_particles")
    if not files:
        return None
    d = files[-1].data
    tasks, paper = d.get("tasks") or {}, d.get("paper") or {}

    def counts(prefix: str, field: str, source: dict) -> str:
        return " / ".join(str((source.get(t) or {}).get(field, "-")) for t in tasks
                          if t.startswith(prefix))

    return (f"rope keys {counts('rope', 'n_keys', tasks)} (paper "
            f"{counts('rope', 'keys', paper)}); cloth keys {counts('cloth', 'n_keys', tasks)} "
            f"on {counts('cloth', 'n_elements', tasks)} triangles (paper "
            f"{counts('cloth', 'triangles', paper)})")


def kp_authors_line(results: list[Result]) -> str | None:
    """The authors' own cloth goals: how many reduce to the paper's counts, and with keys where
    the authors' are."""
    files = _paper(results, "kp_authors")
    if not files:
        return None
    s = files[-1].data["summary"]
    return (f"the paper's triangles on {s['paper_elements_held']} of {s['goals']} goals (2 folds "
            f"x 4 triangulations), its keys on {s['keys_held']}, keys by the authors' on "
            f"{s['keys_agree']}; {num(s['mean_seconds'], 2)} s each (paper "
            f"{num(s['paper_seconds'], 2)})")


def _closest(r: Result) -> str:
    """Which method ends closest to the goal on a Fig. 7 file, and CEM(Simple)'s distance."""
    ms = {m: e for m, e in r.data["methods"].items()
          if isinstance(e.get("final_cost_mean"), (int, float))}
    if not ms:
        return f"{r.data.get('goal')}: no finite result"
    best = min(ms, key=lambda m: ms[m]["final_cost_mean"])
    text = f"{r.data.get('goal')}: {_label(best)} closest, {mm(ms[best]['final_cost_mean'])} mm"
    if best != "simple" and "simple" in ms:
        text += f" (Simple {mm(ms['simple']['final_cost_mean'])})"
    return text


def rope_line(results: list[Result]) -> str | None:
    """The closest method on each rope panel under the paper's protocol."""
    files = [r for goal in ("straighten", "fold")
             for r in _paper(results, "fig7", task="rope", goal=goal, protocol="paper")[-1:]]
    if not files:
        return None
    seeds = max(e.get("n") or 0 for r in files for e in r.data["methods"].values())
    return "; ".join(_closest(r) for r in files) + f" ({seeds} seeds)"


def cloth_line(results: list[Result]) -> str | None:
    """Under the paper's protocol: on how many folds CEM(Simple) ends closest, the family's
    differences that exclude zero under Holm, and whether the gap to Original grows."""
    files = [r for goal in CLOTH_DIFFICULTY
             for r in _paper(results, "fig7", task="cloth", goal=goal, protocol="paper")[-1:]]
    if not files:
        return None
    claims = fig7_claims(files)
    closest = sum(
        min(ms, key=lambda m: ms[m]["final_cost_mean"]) == "simple"
        for r in files
        if (ms := {m: e for m, e in r.data["methods"].items()
                   if isinstance(e.get("final_cost_mean"), (int, float))}))
    n = (files[0].data.get("settings") or {}).get("n")
    seeds = max(e.get("n") or 0 for r in files for e in r.data["methods"].values())
    text = (f"CEM(Simple) closest on {closest} of {len(files)} folds ({n} x {n}, "
            f"{seeds} seeds)")
    family = next((f for f in claims["families"] if f["task"] == "cloth"), None)
    if family and family["m"] > 1:
        text += f"; {len(family['rejected'])} of {family['m']} differences exclude zero (Holm)"
    grows = next((g["grows"] for g in claims["cloth"]), None)
    if grows is not None:
        text += "; the gap to Original " + ("grows" if grows else "does not grow")
    return text


def scaling_line(mode: str) -> Callable[[list[Result]], str | None]:
    """Sec. V's claim per recorded scaling fold of the sweep ``mode`` (``fig7_scaling.py
    --mode``; a file without one refined the fixed sheet) but quick runs (``trend_line``: the
    particle counts N), each fold named by its goal, with the Holm family of that sweep's
    folds."""
    def line(results: list[Result]) -> str | None:
        files, family = scaling_families(results)
        goal = {k: r.data.get("goal") for k, r in files.items() if _scaling_mode(mode)(r)}
        return trend_line({goal[k]: files[k] for k in goal},
                          {(goal[k], t): v for (k, t), v in family.items() if k in goal},
                          "n_particles")
    return line


def _scaling_mode(mode: str) -> Callable[[Result], bool]:
    """Whether a result is a recorded (not quick) scaling file of the sweep ``mode``."""
    return lambda r: (r.kind == "fig7_scaling" and not r.quick
                      and r.data.get("mode", "resolution") == mode)


def encoding_line(results: list[Result]) -> str | None:
    """Sec. V's claim per recorded drag-encoding fold (``trend_line``: the candidate counts N
    of the authors' encoding on one physics mesh)."""
    return trend_line(*encoding_families(results), "n_points")


def trend_line(files: dict, family: dict, counts: str) -> str | None:
    """Per file of ``files`` ({key: a scaling summary}): whether the gap CEM(Original) -
    CEM(Simple) grows with N (the trend test's verdict, "no trend" where it finds none, its
    slope per unit of log N with the 95 % interval), over which N (the summary's ``counts``
    field) and seeds (said once where every fold has the same). With several folds the
    verdicts are Holm's over all their trend tests together (``family``: ``trend_families``);
    the line says so. None without files."""
    sizes, seeds, verdicts = [], [], []
    for goal, r in sorted(files.items(), key=lambda kv: str(kv[0])):
        d = r.data
        t = {**d["trend"]["original_minus_simple"],
             **family.get((goal, "original_minus_simple"), {})}
        counts_of = sorted({e["methods"].get(m, {}).get("n", 0) for e in d["per_size"].values()
                            for m in ("simple", "original")})
        seeds.append(str(counts_of[0]) if len(counts_of) == 1
                     else f"{counts_of[0]}-{counts_of[-1]}")
        sizes.append(n_range(r, counts))
        slope = (f" ({pm(mm(t['slope']), mm(t.get('slope_ci95')))} mm)"
                 if t.get("slope") is not None else "")
        verdict = t["verdict"] if t["verdict"] in ("grows", "shrinks") else "no trend"
        verdicts.append((goal, f"{verdict}{slope}"))
    if not verdicts:
        return None
    same_sizes, same_seeds = len(set(sizes)) == 1, len(set(seeds)) == 1
    shared = [x for x, same in ((sizes[0], same_sizes), (f"{seeds[0]} seeds", same_seeds))
              if same]
    parts = []
    for (goal, v), z, n in zip(verdicts, sizes, seeds, strict=True):
        own = [x for x, same in ((z, same_sizes), (f"{n} seeds", same_seeds)) if not same]
        parts.append(f"{goal} ({', '.join(own)}) {v}" if own else f"{goal} {v}")
    m = next(iter(family.values()))["m"] if family else 0
    tail = f"; Holm over {m} tests" if len(files) > 1 and m else ""
    return ("Original - Simple gap per log N" + (f" ({', '.join(shared)})" if shared else "")
            + ": " + ", ".join(parts) + tail)


def panda_line(results: list[Result]) -> str | None:
    """How far the Panda's executions end from the goal against the picker's, per goal."""
    files = _paper(results, "panda_execute")
    if not files:
        return None
    goals = files[-1].data["goals"]

    def each(field: str) -> str:
        return " / ".join(mm(e[field]) for e in goals.values())

    seeds = " / ".join(sorted({str(e["n"]) for e in goals.values()}))
    return (f"the Panda ends {each('panda_final_cost_mean')} mm from the goal, the picker "
            f"{each('picker_final_cost_mean')} ({' / '.join(goals)}, {seeds} seeds)")


def _fig7(task: str) -> Callable[[Result], bool]:
    return lambda r: (r.kind == "fig7" and r.data.get("task") == task and not r.quick
                      and r.data.get("protocol") == "paper" and not _departs(r))


ROWS = (
    MapRow(KP, "Fig. 4, Sec. IV-C.1: key particles of each goal",
           "python experiments/key_particles.py --task all",
           "Key particles, Fig. 4 and Sec. IV-C.1: key particles of each goal", kp_line,
           lambda r: r.kind == "key_particles" and not r.quick, "Few key particles per goal"),
    MapRow(KP, "Sec. IV-C.1 on the authors' own cloth goals",
           "python -m deformables.bench authors --external DIR",
           "Key particles on the authors' own goals", kp_authors_line,
           lambda r: r.kind == "kp_authors", "The same keys on the authors' goals"),
    MapRow(KP, "Fig. 7 (a, b): rope straightening, folding",
           "python experiments/rope.py --preset paper --goal straighten",
           "Key particles, Fig. 7: final cost of pick-and-place", rope_line, _fig7("rope"),
           "Rope: Simple beats Original, Random is worst"),
    MapRow(KP, "Fig. 7 (c-f): cloth diagonal, side, reflective, underneath folds",
           "python experiments/cloth_fold.py --preset paper --goal diagonal",
           "Key particles, Fig. 7: final cost of pick-and-place", cloth_line, _fig7("cloth"),
           "Cloth: Simple beats Original on every fold"),
    MapRow(KP, "Sec. V: the gain against the particle count (a finer sheet of one size)",
           "python experiments/fig7_scaling.py --goal diagonal",
           "Key particles: the gain against the particle count",
           scaling_line("resolution"), _scaling_mode("resolution"),
           "The gain grows with the particle count"),
    MapRow(KP, "Sec. V: the gain against the particle count (a bigger sheet at fixed spacing)",
           "python experiments/fig7_scaling.py --goal diagonal --mode size",
           "Key particles: the gain against the particle count",
           scaling_line("size"), _scaling_mode("size"),
           "The gain grows with the particle count", hidden_until_recorded=True),
    MapRow(KP, "Sec. V under the authors' drag encoding: the gain against N candidate points "
               "on one physics mesh",
           "python experiments/fig7_encoding.py --goal diagonal",
           ENCODING_TITLE,
           encoding_line, lambda r: r.kind == "fig7_encoding" and not r.quick,
           "The gain grows with the candidate count under the authors' encoding",
           hidden_until_recorded=True),
    MapRow(KP, "Sec. IV-D: a Panda executes the plans",
           "python experiments/panda_execute.py --trials 3",
           "Key particles, Sec. IV-D: a Panda executes the plans", panda_line,
           lambda r: r.kind == "panda_execute" and not r.quick,
           "A robot arm executes the plans"),
)
