"""The per-paper result pages: docs/KEY-PARTICLES.md and docs/STATE-VECTOR-REDUCTION.md.

Each page is what a person reads about one paper: its claims (``report_claims.CLAIMS``) in a
table with our verdicts, then one short section per claim (what the paper says and where, what
we measured, the verdict, the result files it read with their commits, and a link to the
section of the index, docs/RESULTS.md, that holds the tables, settings and commands behind
it), then our figures and tables beside the paper's (the pictures under docs/images/ that
exist, the headline tables). Every number is read from a result file; the pages are written
beside the index (``page_paths``) and ``report.py --check`` compares them like the index.
Standard library only (report.py's rule).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from report_base import (
    FIG7_PANELS,
    KP,
    REGENERATE,
    SVR,
    Result,
    _display,
    _label,
    link,
    mm,
    num,
    pm,
    source,
    table,
)
from report_claims import CLAIMS, PAGE_FILES, TASKS, Claim, Finding, fig4_files
from report_fig7 import _departs, fig7_cell
from report_map import _notes, anchor
from report_svr import fig4_against_paper, paper_preset_table1, paper_table1


@dataclass(frozen=True)
class Page:
    """A paper's page: its file name beside the index, its title, the paper it reads (a
    citation) and the pictures under docs/images/ it shows where they exist ((name, caption);
    a result file's own figure, images/<its name>.png, is shown too)."""

    file: str
    title: str
    cite: str
    pictures: tuple[tuple[str, str], ...]
    #: {result kind: the caption of a file's own figure, from its data}
    figures: dict[str, Callable[[dict], str]]


def _whose(d: dict) -> str:
    """Whose problem a Fig. 4 summary ran: "the authors'" or "our"."""
    return "the authors'" if d.get("problem") == "authors" else "our"


PAGES = {
    KP: Page(PAGE_FILES[KP], "Key particles: the paper's claims beside our runs",
             "S. Wang, R. Papallas, M. Leonetti, M. Dogar, *Goal-Conditioned Action Space "
             "Reduction for Deformable Object Manipulation*, ICRA 2023",
             (("fold-diagonal.png", "CEM(Simple) folds the cloth along its diagonal (goal "
                                    "left, result right)"),
              ("panda-diagonal.png", "A Panda executes the diagonal fold's plan")),
             {"fig7_scaling": lambda d: f"Sec. V, the {d.get('goal')} fold: final cost and "
                                        "the gaps to CEM(Simple) against the particle count, "
                                        "95 % intervals"}),
    SVR: Page(PAGE_FILES[SVR],
              "State-vector reduction: the paper's claims beside our runs",
              "D. Russell, R. Papallas, M. Dogar, *Online State Vector Reduction During Model "
              "Predictive Control with Gradient-Based Trajectory Optimisation*, WAFR 2024",
              (("push-clutter.png", "iLQR-SVR MPC pushes the green cylinder to its goal "
                                    "through clutter"),),
              {"fig4": lambda d: f"Fig. 4 on {_whose(d)} {d.get('task')}: MPC cost / "
                                 "baseline and mean |C| against rho, ours (solid) and the "
                                 "authors' (dashed)"}),
}


def page_paths(index: Path) -> dict[str, Path]:
    """{paper: the path of its page}: beside the index page (docs/RESULTS.md)."""
    return {paper: Path(index).parent / p.file for paper, p in PAGES.items()}


def _rel(target: Path, page: Path) -> str:
    return Path(os.path.relpath(target, Path(page).parent)).as_posix()


# ------------------------------------------------------------------------------- claims
def judged(results: list[Result], paper: str) -> list[tuple[Claim, Finding | None]]:
    """The paper's claims, each with its finding on ``results`` (None: no file yet)."""
    return [(c, c.judge(results)) for c in CLAIMS if c.paper == paper]


def claims_table(found: list[tuple[Claim, Finding | None]]) -> list[str]:
    """One row per claim: its title (a link to its section below), where the paper says it,
    our verdict."""
    return table(["the paper's claim", "where", "our verdict"],
                 [[f"[{c.title}](#{anchor(c.title)})", c.where,
                   f"**{f.verdict}**" if f else "not recorded yet"] for c, f in found])


def claim_lines(c: Claim, f: Finding | None, page: Path, index: Path,
                index_titles: set[str]) -> list[str]:
    """A claim's section: what the paper says, what we measured, the verdict, the files and
    where the details are (the index's section, where it has one)."""
    lines = [f"### {c.title}", "", f"*The paper ({c.where}):* {c.says}", ""]
    if f is None:
        return lines + ["Not recorded yet: no result file bears on it."]
    details = (f" Details: [{_rel(index, page)}]({_rel(index, page)}#{anchor(c.details)})."
               if c.details in index_titles else "")
    notes = _notes(list(f.files))
    return lines + [f"*We measured:* {f.measured}.", "",
                    f"*Verdict:* **{f.verdict}**{notes}. Result files: "
                    + ", ".join(source(r, page) for r in f.files) + "." + details]


# ----------------------------------------------------------------------- beside the paper
def figures(page_def: Page, results: list[Result], page: Path) -> list[str]:
    """The page's pictures and the figures of its result files that exist under
    docs/images/."""
    images = page.parent / "images"
    lines = [f"![{caption}]({_rel(images / name, page)})" for name, caption in page_def.pictures
             if (images / name).exists()]
    for r in results:
        image = images / f"{r.path.stem}.png"
        if r.kind in page_def.figures and not r.quick and image.exists():
            lines.append(f"![{page_def.figures[r.kind](r.data)} ({r.name})]"
                         f"({_rel(image, page)})")
    return [x for line in lines for x in (line, "")]


def kp_tables(results: list[Result], page: Path) -> list[str]:
    """The paper's key-particle counts beside ours, and Fig. 7 under the paper's protocol."""
    lines = []
    keys = [r for r in results if r.kind == "key_particles" and not r.quick]
    if keys:
        r = keys[-1]
        tasks, paper = r.data.get("tasks") or {}, r.data.get("paper") or {}
        rows = [[goal.replace("_", " "), str((paper.get(goal) or {}).get("keys", "-")),
                 str(e.get("n_keys")), str((paper.get(goal) or {}).get("triangles", "-")),
                 str(e.get("n_elements")) if goal.startswith("cloth") else "-"]
                for goal, e in tasks.items()]
        lines += ["### Key particles per goal (Fig. 4)", "",
                  *table(["goal", "paper keys", "our keys", "paper triangles",
                          "our triangles"], rows), "", f"Source: {source(r, page)}.", ""]
    fig7 = sorted((r for r in results if r.kind == "fig7" and not r.quick and not _departs(r)
                   and r.data.get("protocol") == "paper"),
                  key=lambda r: list(FIG7_PANELS).index((r.data.get("task"), r.data.get("goal")))
                  if (r.data.get("task"), r.data.get("goal")) in FIG7_PANELS else 99)
    if fig7:
        methods = ("simple", "original", "random", "scripted")
        rows = [[FIG7_PANELS.get((r.data.get("task"), r.data.get("goal")), r.name),
                 *(fig7_cell(r.data["methods"].get(m)) for m in methods),
                 str(max((e.get("n") or 0) for e in r.data["methods"].values())),
                 source(r, page)] for r in fig7]
        lines += ["### Fig. 7: final cost under the paper's protocol", "",
                  "The paper plots cost curves; these are the final mean particle distances to "
                  "the goal (mm, mean ± 95 % interval over the seeds).", "",
                  *table(["panel", *(_label(m) for m in methods), "seeds", "source"], rows), ""]
    panda = [r for r in results if r.kind == "panda_execute" and not r.quick]
    if panda:
        r = panda[-1]
        rows = [[goal, pm(mm(e["picker_final_cost_mean"]), mm(e["picker_final_cost_ci95"])),
                 pm(mm(e["panda_final_cost_mean"]), mm(e["panda_final_cost_ci95"])),
                 str(e["n"])] for goal, e in r.data["goals"].items()]
        lines += ["### Sec. IV-D: the plans on a Panda (simulated)", "",
                  *table(["goal", "picker final cost (mm)", "Panda final cost (mm)", "seeds"],
                         rows), "", f"Source: {source(r, page)}.", ""]
    return lines


def svr_tables(results: list[Result], page: Path) -> list[str]:
    """Table 1 on the authors' problems beside the paper's printed one, and Fig. 4 beside
    the authors' runs."""
    ref, published = paper_table1(results)
    lines = []
    for task in TASKS:
        r = paper_preset_table1(results, task, ("authors",))
        if r is None or task not in published:
            continue
        ms = r.data["methods"]
        rows = [[row, pm(num(p["mpc_cost"]), num(p.get("mpc_cost_ci90"), 3)),
                 pm(num(m.get("mpc_cost_normalised_mean")),
                    num(m.get("mpc_cost_normalised_ci90"))),
                 f"{num(p.get('n_dofs'), 1)} / {num(m.get('n_dofs_mean'), 1)}",
                 f"{num(p.get('opt_ms'), 0)} / {num(m.get('opt_ms_mean'), 0)}"]
                for row, p in published[task].items() if (m := ms.get(row)) is not None]
        lines += [f"### Table 1, {task}: the paper's beside ours", "",
                  *table(["row", "paper MPC cost", "our MPC cost", "DoFs paper / ours",
                          "opt. ms paper / ours"], rows), "",
                  f"Sources: {source(r, page)} (the authors' problems), {source(ref, page)} "
                  "(the paper's printed table).", ""]
    if lines:
        lines[:0] = ["MPC cost normalised by the baseline's (mean ± 90 % interval), "
                     "optimisation time and DoFs, on the authors' problems.", ""]
    beside = [f"- {link(r, page)}: {line}" for problem in ("authors", "ours")
              for r in fig4_files(results, problem)[-1:] if ref is not None
              if (line := fig4_against_paper(r.data, ref.data))]
    if beside:
        lines += ["### Fig. 4 beside the authors' runs", "",
                  "Kendall tau-b of our points' order against theirs on the median cost, and of "
                  "each side's cost against its mean |C|:", "", *beside, ""]
    return lines


TABLES = {KP: kp_tables, SVR: svr_tables}


# --------------------------------------------------------------------------------- page
def paper_page(paper: str, results: list[Result], results_dir: Path, page: Path, index: Path,
               index_titles: set[str]) -> str:
    """The text of ``paper``'s page at ``page`` from ``results`` (read from ``results_dir``);
    ``index``: the index page (docs/RESULTS.md) and ``index_titles`` its section titles (a
    claim links to its details there)."""
    p = PAGES[paper]
    rel = _rel(index, page)
    others = [f"[{PAGES[q].file}]({_rel(path, page)})" for q, path in page_paths(index).items()
              if q != paper]
    lines = [f"# {p.title}", "",
             f"*Generated by `experiments/report.py` from `{_display(results_dir)}/"
             f"*.json`: do not edit by hand. Regenerate with `{REGENERATE}`.*", "",
             f"{p.cite}. Each claim below is one the paper makes, judged on our recorded "
             "result files; every number is read from a file. The index "
             f"[{rel}]({rel}) holds every result file with its tables, settings and the "
             f"command that recorded it; the other paper: {', '.join(others)}.", "",
             "## The claims and our verdicts", "",
             "Verdicts: **holds**; **partly holds** (in some of its cases); **does not hold**; "
             "**not shown** (the test finds no effect either way); **not judged** (a "
             "demonstration, or no case a file can decide).", ""]
    found = judged(results, paper)
    lines += claims_table(found) + [""]
    for c, f in found:
        lines += [*claim_lines(c, f, page, index, index_titles), ""]
    beside = figures(p, results, page) + TABLES[paper](results, page)
    if beside:
        lines += ["## Our figures and tables beside the paper's", "", *beside]
    while lines and lines[-1] == "":
        lines.pop()
    return "\n".join(lines) + "\n"
