"""The per-paper result pages: docs/KEY-PARTICLES.md and docs/STATE-VECTOR-REDUCTION.md.

Each page is what a person reads about one paper: its claims (``Experiment.claims``) in a
table with our verdicts, then one short section per claim (what the paper says and where, what
we measured, the verdict, the result files it read with their commits, and a link to the
section of the index, docs/RESULTS.md, that holds the tables, settings and commands behind
it), then our figures and tables beside the paper's (the pictures under docs/images/ that
exist, the headline tables). Every number is read from a result file; the pages are written
beside the index (``page_paths``) and ``report.py --check`` compares them like the index.
A paper's page is registered by its slice (``dopt.lab.experiment.register_page``).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from dopt.lab.experiment import pages
from dopt.lab.report.base import REGENERATE, Result, _display, source, table
from dopt.lab.report.claims import Claim, Finding, all_claims
from dopt.lab.report.map import _notes, anchor


@dataclass(frozen=True)
class Page:
    """A paper's page: the paper (as its experiments name it), its file name beside the
    index, its title, the paper it reads (a citation), the pictures under docs/images/ it
    shows where they exist ((name, caption); a result file's own figure, images/<its
    name>.png, is shown too) and its tables beside the paper's (``tables(results, page)``)."""

    paper: str
    file: str
    title: str
    cite: str
    pictures: tuple[tuple[str, str], ...]
    #: {result kind: the caption of a file's own figure, from its data}
    figures: dict[str, Callable[[dict], str]]
    #: the page's tables beside the paper's: (results, page path) -> lines
    tables: Callable[[list[Result], Path], list[str]]


def page_paths(index: Path) -> dict[str, Path]:
    """{paper: the path of its page}: beside the index page (docs/RESULTS.md)."""
    return {paper: Path(index).parent / p.file for paper, p in pages().items()}


def _rel(target: Path, page: Path) -> str:
    return Path(os.path.relpath(target, Path(page).parent)).as_posix()


# ------------------------------------------------------------------------------- claims
def judged(results: list[Result], paper: str) -> list[tuple[Claim, Finding | None]]:
    """The paper's claims, each with its finding on ``results`` (None: no file yet; a claim
    ``hidden_until_recorded`` is then left out)."""
    found = [(c, c.judge(results)) for c in all_claims() if c.paper == paper]
    return [(c, f) for c, f in found if f is not None or not c.hidden_until_recorded]


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


# --------------------------------------------------------------------------------- page
def paper_page(paper: str, results: list[Result], results_dir: Path, page: Path, index: Path,
               index_titles: set[str]) -> str:
    """The text of ``paper``'s page at ``page`` from ``results`` (read from ``results_dir``);
    ``index``: the index page (docs/RESULTS.md) and ``index_titles`` its section titles (a
    claim links to its details there)."""
    p = pages()[paper]
    rel = _rel(index, page)
    others = [f"[{pages()[q].file}]({_rel(path, page)})" for q, path in page_paths(index).items()
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
    beside = figures(p, results, page) + p.tables(results, page)
    if beside:
        lines += ["## Our figures and tables beside the paper's", "", *beside]
    while lines and lines[-1] == "":
        lines.pop()
    return "\n".join(lines) + "\n"
