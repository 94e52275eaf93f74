"""The common part of the report engine: the result files (``Result``, ``load_results``) and
the Markdown helpers every section uses (the paper slices' report modules use them too).

A recorded command is shown naming no folder of the machine that recorded it
(``dopt.lab.provenance.recorded_command``).
"""

from __future__ import annotations

import json
import math
import os
import statistics
from dataclasses import dataclass, field
from pathlib import Path

from dopt.lab.experiment import bench_kind
from dopt.lab.provenance import recorded_command

#: the checkout the default folders are in
ROOT = Path(__file__).resolve().parents[3]
BEGIN, END = "<!-- results:begin -->", "<!-- results:end -->"
REGENERATE = "python experiments/report.py"

#: what every result file's "provenance" holds (``dopt.lab.provenance.provenance()``)
PROVENANCE_FIELDS = ("command", "git_commit", "versions")
PROVENANCE_VERSIONS = ("dopt", "mujoco", "torch")


# ------------------------------------------------------------------------------ loading
@dataclass(frozen=True)
class Result:
    """A result file: its path, its "experiment" kind and its contents; ``notes``: what
    the engine's ``generate`` found about it besides (its committed trials, "trials"; whether
    today's presets still give its settings, "stale")."""

    path: Path
    data: dict
    notes: dict = field(default_factory=dict, compare=False, repr=False)

    @property
    def kind(self) -> str:
        """Its "experiment" field; a benchmark's file (a "bench" field instead): the kind of
        the registered experiment that reads that bench (``Experiment.benches``)."""
        if "experiment" not in self.data and isinstance(self.data.get("bench"), str):
            kind = bench_kind(self.data["bench"])
            if kind is not None:
                return kind
        return str(self.data.get("experiment", "(none)"))

    @property
    def name(self) -> str:
        return self.path.name

    @property
    def provenance(self) -> dict:
        p = self.data.get("provenance")
        return p if isinstance(p, dict) else {}

    @property
    def origin(self) -> dict:
        """The provenance of the experiment whose trials this summary holds: for a summary
        rebuilt from its trials by experiments/resummarize.py ("resummarized_from"), the
        original run's; else its own."""
        o = self.data.get("resummarized_from")
        return o if isinstance(o, dict) else self.provenance

    @property
    def origin_command(self) -> str:
        return str(self.origin.get("command") or "")

    @property
    def command(self) -> str:
        """The experiment's command line (the one that reruns it, also for a re-summarised
        file), its absolute paths shown relative (``recorded_command``)."""
        command = self.origin.get("command")
        return recorded_command(str(command)) if command else "(no provenance: command unknown)"

    @property
    def commit(self) -> str:
        """The short commit ("-dirty" kept: the run had uncommitted changes)."""
        return short_commit(self.provenance.get("git_commit"))

    @property
    def date(self) -> str:
        return str(self.provenance.get("date") or "unknown date")

    @property
    def quick(self) -> bool:
        """A smoke-sized run (--quick): its numbers are not the paper's settings."""
        return bool(self.data.get("quick")) or "--quick" in self.command.split()


def provenance_gaps(r: Result) -> list[str]:
    """What the result's provenance lacks of the command, the git commit and the versions of
    dopt, mujoco and torch (empty when complete)."""
    p = r.provenance
    gaps = [k for k in PROVENANCE_FIELDS if not p.get(k)]
    versions = p.get("versions") if isinstance(p.get("versions"), dict) else {}
    gaps += [f"versions.{k}" for k in PROVENANCE_VERSIONS if not versions.get(k)]
    return gaps


class ReportError(Exception):
    """A result file that cannot be read or rendered."""


def load_results(results_dir: Path) -> list[Result]:
    """Every ``*.json`` under ``results_dir`` (not recursive), sorted by name; a missing folder
    is no results."""
    out = []
    for path in sorted(Path(results_dir).glob("*.json")):
        try:
            data = json.loads(path.read_text())
        except (OSError, ValueError) as e:
            raise ReportError(f"{path}: not a readable JSON file ({e})") from e
        if not isinstance(data, dict):
            raise ReportError(f"{path}: expected a JSON object, got {type(data).__name__}")
        out.append(Result(path, data))
    return out


# ---------------------------------------------------------------------------- formatting
def _finite(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def num(x, digits: int = 2, scale: float = 1.0) -> str:
    """x * scale with ``digits`` decimals; "n/a" for None, NaN or a non-number."""
    return f"{x * scale:.{digits}f}" if _finite(x) else "n/a"


def as_flag(x) -> str:
    """A number as the commands write it: 50, 0.5, 1e6."""
    return f"{x:g}".replace("e+0", "e").replace("e+", "e") if isinstance(x, (int, float)) \
        else str(x)


def sci(x) -> str:
    """x in scientific notation with two significant digits; "-" for None."""
    return "-" if x is None else (f"{x:.1e}" if _finite(x) else "n/a")


def clip(text: str, n: int) -> str:
    """``text`` cut to its first ``n`` characters, "..." marking a cut."""
    return text[:n] + ("..." if len(text) > n else "")


def mm(x, digits: int = 1) -> str:
    """Metres as millimetres, one decimal."""
    return num(x, digits, 1e3)


def travel_cell(authors: dict | None, ours: dict) -> str:
    """How far the goal object came toward its goal (median, cm): the authors' run of the row
    (a summary's "authors_rows", ``--authors-data``) / ours ("-" where either is unknown)."""
    def cm(v):
        return "-" if not isinstance(v, (int, float)) else f"{100 * v:.1f}"
    return f"{cm((authors or {}).get('travel_median'))} / {cm(ours.get('travel_median'))}"


def pm(mean: str, ci: str) -> str:
    """"mean ± ci", or the mean alone when there is no interval."""
    return mean if ci == "n/a" or mean == "n/a" else f"{mean} ± {ci}"


def span(interval) -> str:
    """An interval [lo, hi] as "lo-hi" (empty for none)."""
    return "-".join(num(x) for x in interval or [])


def cell(text) -> str:
    """Text safe inside a Markdown table cell."""
    return str(text).replace("|", "\\|").replace("\n", " ")


def table(header: list[str], rows: list[list]) -> list[str]:
    lines = ["| " + " | ".join(cell(h) for h in header) + " |", "|" + "---|" * len(header)]
    return lines + ["| " + " | ".join(cell(c) for c in row) + " |" for row in rows]


def link(r: Result, page: Path) -> str:
    """A Markdown link to the result file, relative to the page that shows it."""
    rel = Path(os.path.relpath(r.path, Path(page).parent)).as_posix()
    return f"[{r.name}]({rel})"


def source(r: Result, page: Path) -> str:
    """'file (commit)' of a result, as the tables cite it."""
    return f"{link(r, page)} ({r.commit})"


def source_lines(results: list[Result], page: Path) -> list[str]:
    """The source files of a table, each with its commit, date and command line, how it was
    re-summarised (where it was), its committed trials and whether it is stale
    (``Result.notes``)."""
    lines = []
    for r in results:
        lines.append(f"Source: {link(r, page)}, commit `{r.commit}`, {r.date}"
                     + (", **quick (smoke-sized) run**" if r.quick else "") + ":  ")
        if "resummarized_from" in r.data:
            o = r.origin
            lines[-1] = (f"Source: {link(r, page)}, re-summarised from its committed trials at "
                         f"commit `{r.commit}`, {r.date}, by "
                         f"`{recorded_command(str(r.provenance.get('command')))}`; "
                         f"the experiment ran at `{short_commit(o.get('git_commit'))}`, "
                         f"{o.get('date') or 'unknown date'}:  ")
        notes = [n for n in (r.notes.get("trials_line"), r.notes.get("stale_line")) if n]
        lines.append(f"`{r.command}`" + ("  " if notes else ""))
        lines += [n + ("  " if i < len(notes) - 1 else "") for i, n in enumerate(notes)]
    return lines


def short_commit(c) -> str:
    """A recorded commit, short ("-dirty" kept)."""
    if not c or not isinstance(c, str):
        return "unknown commit"
    head, dirty = (c[:-6], "-dirty") if c.endswith("-dirty") else (c, "")
    return head[:8] + dirty


def failed_lines(r: Result) -> list[str]:
    failed = r.data.get("failed") or {}
    if not failed:
        return []
    return ["", f"**{len(failed)} failed trial(s)** (not in the numbers above):", ""] + [
        f"- `{k}`: {cell(v)}" for k, v in sorted(failed.items())]


def section(title: str, intro: str | None, results: list[Result], page: Path, body,
            key=lambda r: (str(r.data.get("task")), r.name)) -> list[str]:
    """A page section: "## title", its intro, then per result file (in ``key`` order) the
    lines ``body(r)`` gives (its heading, settings and tables), its source and failed trials."""
    lines = [f"## {title}", ""] + ([intro, ""] if intro else [])
    for r in sorted(results, key=key):
        lines += [*body(r), "", *source_lines([r], page), *failed_lines(r), ""]
    return lines[:-1]


def _median(xs: list) -> float | None:
    xs = [x for x in xs if _finite(x)]
    return statistics.median(xs) if xs else None



def _and(words: list[str]) -> str:
    """"a", "a and b", "a, b and c"."""
    return words[0] if len(words) == 1 else f"{', '.join(words[:-1])} and {words[-1]}"



def _display(path: Path) -> str:
    try:
        return Path(path).resolve().relative_to(ROOT).as_posix()
    except ValueError:
        return Path(path).as_posix()

