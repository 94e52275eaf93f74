"""The README's map of the papers' figures and tables (the block between the results markers).

One row per figure or table of the two papers: the command that reproduces it, one headline
sentence read from the result files, and a link to its claim on its paper's page
(``MapRow.claim``, ``report_pages``) or, for a row beyond the papers' claims, to its section
of RESULTS.md, where every table, per-seed number, setting and recorded command is. No cell
is longer than ``MAX_CELL`` characters. A row whose files are stale or hold trials from
uncommitted code says so in its link cell. Standard library only (report.py's rule).
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from report_base import (
    KP,
    REGENERATE,
    SVR,
    Result,
    _label,
    as_flag,
    cell,
    mm,
    num,
    pm,
    table,
)
from report_claims import PAGE_FILES, claim_of, fig4_files
from report_fig7 import CLOTH_DIFFICULTY, _departs, fig7_claims
from report_stats import scaling_families
from report_svr import (
    MIN_KEPT_BASELINE,
    _table1_columns,
    kept_baseline,
    orderings,
    paper_preset_table1,
    paper_table1,
    verdict_counts,
)

#: the longest cell the map may have (characters, Markdown included)
MAX_CELL = 160
#: the RESULTS.md section of the headline of every result file (report.headlines_section)
HEADLINES_TITLE = "Headlines: every result file in one line"


def anchor(title: str) -> str:
    """GitHub's anchor of a Markdown heading: lower case, punctuation but hyphens and
    underscores dropped, spaces as hyphens."""
    return re.sub(r"[^\w\- ]", "", title.strip().lower()).replace(" ", "-")


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


def scaling_line(results: list[Result]) -> str | None:
    """Sec. V's claim per recorded scaling fold: whether the gap CEM(Original) - CEM(Simple)
    grows with the particle count (the trend test's verdict, "no trend" where it finds none,
    its slope per unit of log N with the 95 % interval), over which particle counts N and
    seeds (said once where every fold has the same). With several folds the verdicts are
    Holm's over all their trend tests together (``holm_slopes``); the line says so."""
    files, family = scaling_families(results)
    sizes, seeds, verdicts = [], [], []
    for goal, r in sorted(files.items(), key=lambda kv: str(kv[0])):
        d = r.data
        t = {**d["trend"]["original_minus_simple"],
             **family.get((goal, "original_minus_simple"), {})}
        counts = sorted({e["methods"].get(m, {}).get("n", 0) for e in d["per_size"].values()
                         for m in ("simple", "original")})
        seeds.append(str(counts[0]) if len(counts) == 1 else f"{counts[0]}-{counts[-1]}")
        sizes.append(f"N {d['n_particles'][0]}-{d['n_particles'][-1]}")
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


def table1_line(results: list[Result], preset: str = "authors") -> str | None:
    """The cheapest reduced row per task under the authors' protocol on the problems of
    ``preset`` (``authors``: theirs, ``paper``: ours), or where the summaries have them how
    many SVR rows Holm finds cheaper than baseline and than rand; and Kendall's tau of our
    order against the paper's printed one. A task whose baseline is kept (neither outlier
    nor unstable) in fewer than ``MIN_KEPT_BASELINE`` of its episodes says so instead of
    means over the few seeds left ("n/a" against baseline, "-" for its tau); its verdicts
    against rand stand."""
    _, published = paper_table1(results)
    parts, taus, counts = [], [], {}
    for task in ("clutter", "soft", "soft_rigid"):
        r = paper_preset_table1(results, task, (preset,))
        if r is None:
            continue
        kept = kept_baseline(r.data)
        few = bool(kept and kept[0] < MIN_KEPT_BASELINE * kept[1])
        verdicts = versus_counts(r.data.get("versus"))
        if few and verdicts:          # no baseline to compare with; the verdicts vs rand stand
            verdicts = {**verdicts, "baseline": f"n/a (kept {kept[0]}/{kept[1]})"}
        counts[task] = verdicts
        rows = {k: m["mpc_cost_normalised_mean"] for k, m in r.data["methods"].items()
                if k != "baseline" and isinstance(m.get("mpc_cost_normalised_mean"),
                                                  (int, float))}
        if few:
            parts.append(f"{task} n/a (baseline kept {kept[0]}/{kept[1]})")
        elif rows:
            best = min(rows, key=rows.get)
            parts.append(f"{task} {best} {num(rows[best])}")
        if task in published:
            taus.append("-" if few else
                        num(orderings(*_table1_columns(published[task], r.data))["kendall_tau"]))
    if not parts:
        return None
    refs = [ref for ref in ("baseline", "rand-t5")
            if counts and all(ref in v for v in counts.values())]
    if refs:
        text = (f"SVR cheaper:dearer/n vs {', '.join(refs)} (Holm): "
                + "; ".join(f"{task} {', '.join(v[ref] for ref in refs)}"
                            for task, v in counts.items()))
    else:
        text = "cheapest reduced row / baseline: " + ", ".join(parts)
    if taus:
        text += f"; tau vs paper {' / '.join(taus)}"
    return text


def versus_counts(v: dict | None) -> dict[str, str]:
    """{reference: "a:b/n"}: of a summary's n SVR rows, how many Holm finds cheaper (a) and
    dearer (b) than each reference ({} without ``versus``)."""
    return {ref: f"{c['cheaper']}:{c['dearer']}/{c['n']}" for ref, c in verdict_counts(v).items()}


def fig4_line(results: list[Result], problem: str = "ours") -> str | None:
    """The lowest MPC cost / baseline of the Fig. 4 sweep on ``problem`` and where it lies;
    on the authors' clutter also the scenes per point."""
    files = fig4_files(results, problem)
    if not files:
        return None
    d = files[-1].data
    points = [p for p in d.get("points") or [] if isinstance(p.get("mpc_cost_normalised_mean"),
                                                            (int, float))]
    if not points:
        return None
    best = min(points, key=lambda p: p["mpc_cost_normalised_mean"])
    rhos = sorted({p.get("rho") for p in points})
    scenes = (f"; {min(p.get('n_trials') or 0 for p in points)} scenes per point"
              if problem == "authors" else "")
    cost = pm(num(best["mpc_cost_normalised_mean"]), num(best.get("mpc_cost_normalised_ci90")))
    # every point against the baseline, one Holm family (summaries that hold "versus")
    holm = "".join(f"; Holm: {c['cheaper']}/{c['n']} points cheaper, {c['dearer']} dearer"
                   for c in verdict_counts(d.get("versus")).values())
    return (f"{d.get('task')}: lowest cost / baseline {cost} (90 % CI) at rho "
            f"{as_flag(best.get('rho'))}, theta {best.get('theta')}; {len(rhos)} rho from "
            f"{as_flag(rhos[0])} to {as_flag(rhos[-1])}{scenes}{holm}")


def authors_line(results: list[Result]) -> str | None:
    """The state-vector-reduction mechanism on the authors' problems: |C| at rho 1 and 500
    (theta 10) from their Fig. 4 file, and the contact share of sum-t10-r1 from svr_explain."""
    parts = []
    fig4 = fig4_files(results, "authors")
    if fig4:
        pts = {(p.get("theta"), p.get("rho")): p for p in fig4[-1].data.get("points") or []}
        a, b = pts.get((10, 1.0)), pts.get((10, 500.0))
        if a and b:
            parts.append(f"|C| {num(a.get('n_dofs_mean'), 1)} at rho 1, "
                         f"{num(b.get('n_dofs_mean'), 1)} at rho 500 (theta 10, "
                         f"{a.get('n_trials')} scenes)")
    explain = [r for r in results if r.kind == "svr_explain" and r.data.get("task") == "clutter"
               and r.data.get("problem") == "authors" and r.data.get("push_tail", True)]
    if explain:
        m = (explain[-1].data["rows"].get("sum-t10-r1") or {}).get("mechanism") or {}
        if m:
            parts.append(f"contact kept in {num(100 * m.get('contact_share', 0), 0)} % of "
                         f"optimisations, cylinder travel {num(100 * m.get('travel_median', 0), 0)}"
                         f" cm")
    return "; ".join(parts) or None


# --------------------------------------------------------------------------------- rows
@dataclass(frozen=True)
class MapRow:
    """A figure or table of a paper: the command that reproduces it (the short form; the
    recorded commands are in RESULTS.md), the RESULTS.md section with its details, the
    headline sentence from the result files, which files the row reads, and the title of its
    claim on its paper's page (``report_claims``; None: the row links to its section)."""

    paper: str
    item: str
    command: str
    section: str
    headline: Callable[[list[Result]], str | None]
    reads: Callable[[Result], bool]
    claim: str | None = None


def _fig7(task: str) -> Callable[[Result], bool]:
    return lambda r: (r.kind == "fig7" and r.data.get("task") == task and not r.quick
                      and r.data.get("protocol") == "paper" and not _departs(r))


def _table1(preset: str) -> Callable[[Result], bool]:
    return lambda r: (r.kind == "table1" and r.data.get("preset") == preset and not r.quick
                      and not r.data.get("derivatives_effect") and r.data.get("cost") != "ee"
                      and r.data.get("clock_ms") is None)


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
    MapRow(KP, "Sec. V: the gain against the particle count (a finer sheet of one size; a "
               "bigger sheet at fixed spacing)",
           "python experiments/fig7_scaling.py --goal diagonal",
           "Key particles: the gain against the particle count", scaling_line,
           lambda r: r.kind == "fig7_scaling" and not r.quick,
           "The gain grows with the particle count"),
    MapRow(KP, "Sec. IV-D: a Panda executes the plans",
           "python experiments/panda_execute.py --seeds 3",
           "Key particles, Sec. IV-D: a Panda executes the plans", panda_line,
           lambda r: r.kind == "panda_execute" and not r.quick,
           "A robot arm executes the plans"),
    MapRow(SVR, "Table 1 on the authors' problems: clutter, soft, soft_rigid",
           "python experiments/mpc.py --task clutter --preset authors --layouts DIR",
           "State-vector reduction, Table 1 beside the paper", table1_line,
           _table1("authors"), "SVR costs less than the baseline"),
    MapRow(SVR, "Table 1 on dopt's own push tasks (a second benchmark)",
           "python experiments/mpc.py --task clutter --preset paper",
           "State-vector reduction, Table 1: iLQR-SVR in asynchronous MPC",
           lambda results: table1_line(results, "paper"), _table1("paper")),
    MapRow(SVR, "Fig. 4 on the authors' clutter: rho and theta",
           "python experiments/rho_sweep.py --task clutter --preset authors --layouts DIR",
           "State-vector reduction, Fig. 4: importance threshold rho and random DoFs theta",
           lambda results: fig4_line(results, "authors"),
           lambda r: (r.kind == "fig4" and not r.quick and r.data.get("problem") == "authors"),
           "The best rho is moderate"),
    MapRow(SVR, "Fig. 4 on dopt's own clutter (a second benchmark)",
           "python experiments/rho_sweep.py --task clutter --preset paper",
           "State-vector reduction, Fig. 4: importance threshold rho and random DoFs theta",
           fig4_line, lambda r: (r.kind == "fig4" and not r.quick
                                 and r.data.get("problem", "ours") != "authors")),
    MapRow(SVR, "The authors' clutter: SVR engages",
           "python experiments/svr_explain.py --preset authors --layouts DIR",
           "State-vector reduction: which DoFs each method holds, and what rho cuts",
           authors_line, lambda r: (r.kind in ("fig4", "svr_explain") and not r.quick
                                    and r.data.get("problem") == "authors"),
           "A larger rho keeps fewer DoFs"),
)


def _notes(files: list[Result]) -> str:
    """"stale" and "N of M trials from uncommitted code" over a row's files ("" for none)."""
    notes = []
    if any(r.notes.get("stale") for r in files):
        notes.append("**stale**")
    infos = [r.notes.get("trials") for r in files if r.notes.get("trials") is not None]
    dirty, total = sum(i.uncommitted for i in infos), sum(i.n for i in infos)
    if dirty:
        notes.append(f"**{dirty} of {total} trials from uncommitted code**")
    return "".join(f"; {n}" for n in notes)


def readme_rel(results_md: Path, readme: Path, name: str) -> str:
    """The path, relative to the README, of the page ``name`` beside RESULTS.md."""
    return Path(os.path.relpath(Path(results_md).parent / name, Path(readme).parent)).as_posix()


def map_block(results: list[Result], readme: Path, results_md: Path) -> str:
    """The README's block (between the markers, markers excluded)."""
    rel = Path(os.path.relpath(results_md, Path(readme).parent)).as_posix()
    rows = []
    for row in ROWS:
        headline = row.headline(results)
        files = [r for r in results if row.reads(r)]
        # a row no file feeds yet has no section to link to; a row with a claim links to the
        # claim on its paper's page, the others to their section of RESULTS.md
        if row.claim is not None:
            where = f"{readme_rel(results_md, readme, PAGE_FILES[claim_of(row.claim).paper])}"
            link = f"[{Path(where).stem}]({where}#{anchor(row.claim)})"
        else:
            link = f"[RESULTS.md]({rel}#{anchor(row.section)})"
        details = (link + _notes(files)) if files else "-"
        rows.append([row.paper, row.item, f"`{row.command}`",
                     headline if headline is not None else "not recorded yet", details])
    for r in rows:
        for c in r:
            if len(cell(c)) > MAX_CELL:
                raise ValueError(f"README map cell over {MAX_CELL} characters: {c!r}")
    return "\n".join([
        f"<!-- generated by experiments/report.py from the result files; edit those, then run "
        f"`{REGENERATE}` -->",
        *table(["paper", "figure / table", "command", "headline", "details"], rows), "",
        "Each paper's claims with our verdicts: "
        + ", ".join(f"[{Path(where).stem}]({where})" for where in
                    (readme_rel(results_md, readme, name) for name in PAGE_FILES.values()))
        + f"; their index [{rel}]({rel}) holds every table and setting with its recorded "
        f"command, the [{HEADLINES_TITLE.split(':')[0].lower()}]({rel}#"
        f"{anchor(HEADLINES_TITLE)}) of every result file, and what goes beyond the papers "
        "(cost terms, derivatives, control limits, clocks, physics presets, benchmarks)."])
