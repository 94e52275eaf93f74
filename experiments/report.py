"""Generate the result pages and README.md's map of the papers' figures from the result files.

Every number in the docs comes from a result file ``docs/results/*.json`` that an experiment
wrote itself (``--record PATH``; each file holds a "provenance": command, git commit, package
versions, date, machine). This script reads them all and writes

- ``docs/RESULTS.md``: the headline of every result file (``headlines_section``: its command
  and numbers, Fig. 7's claims, Table 1 against the paper's), then every table behind the
  papers' figures, each naming its source file, the file's commit and the command that
  produced it (generated: never edit it by hand), and, for each sweep whose trials are
  committed under ``docs/results/runs/`` but whose summary is not recorded yet, what it holds
  so far (Fig. 7: its seeds and what a trial cost; an MPC sweep: its trials per row and scene);
- per paper, a page beside it that a person reads (``report_pages``: docs/KEY-PARTICLES.md,
  docs/STATE-VECTOR-REDUCTION.md): the paper's claims, each with our verdict, what we measured
  and its result files (``report_claims``), and our figures and tables beside the paper's;
  RESULTS.md is their index (its sections hold each claim's details);
- the block between ``<!-- results:begin -->`` and ``<!-- results:end -->`` in README.md:
  the compact map (``report_map``): one row per paper figure or table, its command, one
  headline sentence and a link to its claim on its paper's page (else its RESULTS.md
  section) (README.md is left alone, with a note, when it has no such markers).

Beside each summary, RESULTS.md gives its committed trials (``docs/results/runs/<sweep>/``) and
the commits and machines they were written at, and the README says "N of M trials from
uncommitted code" where any were (``report_trials``); a result whose named presets no longer
resolve to the fields it ran with is shown **stale** in both (``report_stale``, against the
snapshot that ``experiments/presets_snapshot.py`` writes). The families of comparisons behind
the papers' claims (Fig. 7's Simple-vs-Original/Random differences per setup, Table 1's pairwise
orderings per column) are judged with Holm's correction (``report_stats``, ``dopt.lab.multiple``),
and the sentences say so.

Result kinds (the file's "experiment" field): "fig7" (experiments/cloth_fold.py, rope.py),
"table1" (experiments/mpc.py), "fig4" (experiments/rho_sweep.py), "svr_explain"
(experiments/svr_explain.py), "clock_model" (python -m planners.bench clock), "cem_limit"
(python -m planners.bench cem-limit), "key_particles" (experiments/key_particles.py),
"random_reach" (experiments/random_reach.py), "fig7_scaling" (experiments/fig7_scaling.py).
Files of other kinds are listed by name.

    python experiments/report.py            # regenerate the pages and the README's map
    python experiments/report.py --check    # exit 1 if any is not what it would write

A result file that cannot be read exits 2 naming it; one whose provenance lacks the command,
the git commit or the versions of dopt, mujoco and torch is named in a note on stderr.
Standard library only (with dopt.lab.cli, the command-line types, dopt.lab.multiple, Holm's
correction, dopt.lab.trialpack, the reader of committed trials, loose or packed, with
dopt.lab.jsonio, dopt.lab.provenance, which shows a recorded command without its machine's folders,
and planners.trial_progress, the reader of a trial's checkpoint, all standard library
themselves), so it runs without torch, numpy or MuJoCo. Its sections live in
report_base.py, report_fig7.py, report_kp.py, report_svr.py, report_sweeps.py and
report_clock.py (the MPC clocks and the machine speed behind the virtual clock's sweeps), the
README's map in report_map.py.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass, field
from pathlib import Path

from report_base import (
    BEGIN,
    END,
    FIG7_PANELS,
    KP,
    REGENERATE,
    ROOT,
    SVR,
    ReportError,
    Result,
    _display,
    link,
    load_results,
    provenance_gaps,
    source,
    table,
)
from report_clock import (
    clock_check_headline,
    clock_check_section,
    clock_model_section,
    host_speed_section,
)
from report_fig7 import (
    HOLM_NOTE,
    _departs,
    _fig7_physics,  # noqa: F401  (re-exported: report.<name> in the tests)
    comparison,  # noqa: F401
    fig7_claims,  # noqa: F401
    fig7_claims_lines,
    fig7_departures,
    fig7_headline,
    fig7_section,
)
from report_kp import (
    cem_limit_section,
    cloth_steps_section,
    cloth_warp_section,
    kp_authors_section,
    kp_compare_section,
    kp_headline,
    kp_paper_scale_section,
    kp_section,
    panda_headline,
    panda_section,
    physics_section,
    random_reach_section,
    scaling_section,
    settle_rest_section,
)
from report_map import HEADLINES_TITLE, map_block
from report_pages import page_paths, paper_page
from report_physics import physics_reference_section
from report_stale import (
    SNAPSHOT,
    SVR_KINDS,
    code_findings,
    load_snapshot,
    needs_backfill,
    stale_findings,
    stale_note,
)
from report_svr import (
    _table1_columns,
    fig4_headline,
    fig4_section,
    fig4_vs_paper_section,
    ilqr_bench_section,
    kendall_tau_b,  # noqa: F401
    ordering_sentence,
    orderings,
    paper_preset_table1,
    paper_svr_section,
    paper_table1,
    svr_explain_section,
    table1_headline,
    table1_section,
    table1_vs_paper_section,
)
from report_sweeps import mpc_sweeps_in_progress_section, sweeps_in_progress_section
from report_trials import first_params, summary_trials, trials_line, uncommitted_note

from dopt import atomic

# experiments/ is on the path: it is the script's folder (pytest: pythonpath in pyproject)
from dopt.lab.cli import EPILOG, ArgumentParser, existing_dir, file_problem, guarded


@dataclass(frozen=True)
class Entry:
    """One row of the README's headline table: a paper's figure or table, the command that
    reproduces it, and which result files hold its numbers (``match(result)``)."""

    paper: str
    item: str
    command: str
    kind: str
    where: dict = field(default_factory=dict)

    def match(self, r: Result) -> bool:
        """Its kind, and each ``where`` field equal to the value (a callable: true of it)."""
        return r.kind == self.kind and all(v(r.data.get(k)) if callable(v) else
                                           r.data.get(k) == v for k, v in self.where.items())


def has_variant(tag: str):
    """A ``where`` test of a Table 1 file's "derivatives_effect": a row with ``tag``
    (``+skip``, ``+boxqp``, ``+central``)."""
    return lambda effect: any(tag in row for row in effect or {})


#: the paper's Table 1 trials per task
TABLE1_TRIALS = {"clutter": 100, "soft": 20, "soft_rigid": 20}
#: trials per task of the Table 1 runs with the end-effector cost term
TABLE1_EE_TRIALS = {"clutter": 20, "soft": 10, "soft_rigid": 10}

#: what the papers report and the scripts that reproduce it (the README's headline rows)
CATALOGUE = (
    [Entry(KP, "Fig. 4, Sec. IV-C.1: key particles of each goal",
           "python experiments/key_particles.py --task all", "key_particles")]
    + [Entry(KP, f"Fig. 7 {panel}",
             f"python experiments/{'cloth_fold' if task == 'cloth' else 'rope'}.py "
             f"--goal {goal}", "fig7", {"task": task, "goal": goal})
       for (task, goal), panel in FIG7_PANELS.items()]
    + [Entry(KP, "Sec. IV-D: a Panda executes the diagonal and side plans",
             "python experiments/panda_execute.py --seeds 3 --out docs/results/runs/panda "
             "--record docs/results/panda-execute.json", "panda_execute")]
    + [Entry(SVR, f"Table 1: {task}", f"python experiments/mpc.py --task {task} --preset paper "
             f"--trials {n} --workers 2 --no-render --out docs/results/runs/table1-{task} "
             f"--record docs/results/table1-{task}.json", "table1",
             {"task": task, "derivatives_effect": None, "cost": lambda c: c != "ee"})
       for task, n in TABLE1_TRIALS.items()]
    + [Entry(SVR, f"Table 1 with the end-effector term (ours), {task}",
             f"python experiments/mpc.py --task {task} --preset paper --cost ee --trials {n} "
             f"--workers 2 --no-render --out docs/results/runs/table1-{task}-ee "
             f"--record docs/results/table1-{task}-ee.json", "table1",
             {"task": task, "derivatives_effect": None, "cost": "ee"})
       for task, n in TABLE1_EE_TRIALS.items()]
    + [Entry(SVR, f"Beyond the paper: FD at every K-th timestep on sum-t10-r1, {task}",
             f"python experiments/mpc.py --task {task} --preset paper --rows "
             f"baseline,sum-t10-r1,sum-t10-r1+skip5,sum-t10-r1+skip10 --trials {n} --workers 2 "
             f"--no-render --out docs/results/runs/keypoints-{task} "
             f"--record docs/results/keypoints-{task}.json", "table1",
             {"task": task, "derivatives_effect": has_variant("+skip")})
       for task, n in TABLE1_TRIALS.items()]
    + [Entry(SVR, f"Beyond the paper: control limits in iLQR's backward pass (box QP), {task}",
             f"python experiments/mpc.py --task {task} --preset paper --rows "
             f"baseline,sum-t10-r1,sum-t10-r1+boxqp --trials 10 --workers 2 --no-render "
             f"--out docs/results/runs/boxqp-{task} --record docs/results/boxqp-{task}.json",
             "table1", {"task": task, "derivatives_effect": has_variant("+boxqp")})
       for task in TABLE1_TRIALS]
    + [Entry(SVR, "Finite differences: the authors' central (eps 1e-6) against our forward "
                  "(eps 1e-3), clutter",
             "python experiments/mpc.py --task clutter --preset paper --rows "
             "baseline,sum-t10-r1,sum-t10-r1+central --trials 20 --workers 2 --no-render "
             "--out docs/results/runs/fd-central-clutter "
             "--record docs/results/fd-central-clutter.json", "table1",
             {"task": "clutter", "derivatives_effect": has_variant("+central")})]
    + [Entry(SVR, "Table 1's virtual clock against the real clock",
             "python experiments/clock_check.py --task clutter --preset paper --rows "
             "baseline,rand-t5,sum-t10-r1 --trials 10 --out docs/results/runs/clock-check-clutter "
             "--record docs/results/clock-check-clutter.json", "clock_check",
             {"nominal_threads": 2.0})]
    + [Entry(SVR, "The virtual clock at 1.3 nominal threads (the first check's speed-up), "
                  "on a second machine",
             "python experiments/clock_check.py --task clutter --preset paper --rows "
             "baseline,rand-t5,sum-t10-r1 --seed 10 --trials 10 --nominal-threads 1.3 "
             "--out docs/results/runs/clock-check-clutter "
             "--record docs/results/clock-check-clutter-1.3.json", "clock_check",
             {"nominal_threads": 1.3})]
    + [Entry(SVR, "Fig. 4: rho, theta sweep",
             "python experiments/rho_sweep.py --task clutter --preset paper --rhos "
             "0,0.1,0.5,1,5,10,20,50,100,500,1e6 --thetas 0,5,10 --trials 20 --workers 2 "
             "--paper-reference docs/results/paper-svr.json --out docs/results/runs/fig4-clutter "
             "--record docs/results/fig4-clutter.json", "fig4")])


# ----------------------------------------------------------------------------- pages
SECTIONS = {"key_particles": kp_section, "kp_compare": kp_compare_section,
            "kp_paper_scale": kp_paper_scale_section, "kp_authors": kp_authors_section,
            "fig7": fig7_section,
            "table1": table1_section, "fig4": fig4_section, "physics": physics_section,
            "clock_model": clock_model_section, "svr_explain": svr_explain_section,
            "ilqr_bench": ilqr_bench_section, "clock_check": clock_check_section,
            "paper_svr": paper_svr_section, "panda_execute": panda_section,
            "cloth_steps": cloth_steps_section, "cem_limit": cem_limit_section,
            "settle_rest": settle_rest_section,
            "cloth_warp": cloth_warp_section,
            "random_reach": random_reach_section, "fig7_scaling": scaling_section,
            "physics_reference": physics_reference_section}
HEADLINES = {"key_particles": kp_headline, "fig7": fig7_headline, "table1": table1_headline,
             "fig4": fig4_headline, "panda_execute": panda_headline,
             "clock_check": clock_check_headline}



def _rendered(r: Result, fn, *args):
    try:
        return fn(*args)
    except (KeyError, TypeError, AttributeError, ValueError) as e:
        raise ReportError(f"{r.path}: malformed {r.kind!r} result ({type(e).__name__}: {e})") \
            from e


def results_md(results: list[Result], results_dir: Path, page: Path) -> str:
    """The text of RESULTS.md for ``results`` (from ``results_dir``), to be written at
    ``page`` (links are relative to it)."""
    where = _display(results_dir)
    pages = ", ".join(f"[{p.name}]({p.name})" for p in page_paths(page).values())
    lines = ["# Results: the index of every result file", "",
             f"*Generated by `experiments/report.py` from `{where}/*.json`: do not edit by hand. "
             f"Regenerate with `{REGENERATE}` (`--check` tells whether this page is current).*",
             "", f"To read what each paper claims and how our runs judge it, start at its page: "
             f"{pages}. This page is the catalogue behind them.", "",
             "Each number below is read from a result file that an experiment wrote itself "
             "(`--record PATH`); each table names its file, the git commit the run was made at "
             "(`-dirty`: with uncommitted changes) and its command line.", ""]
    if not results:
        return "\n".join(lines + [f"No results yet: `{where}/` holds no result file. Run an "
                                  "experiment with `--record "
                                  f"{where}/<name>.json`, then `{REGENERATE}`.", ""])
    lines += headlines_section(results, page)
    lines += ["", "## Result files", ""]
    lines += table(["file", "experiment", "paper figure / table", "commit", "date"],
                   [[link(r, page), r.kind, _items(r), r.commit, r.date] for r in results])
    for kind, section in SECTIONS.items():
        chosen = [r for r in results if r.kind == kind]
        if chosen:
            for r in chosen:                # a malformed file: an error that names it
                _rendered(r, section, [r], page)
            lines += ["", *section(chosen, page)]
    for beside in (table1_vs_paper_section(results, page),
                   fig4_vs_paper_section(results, page)):
        if beside:
            lines += ["", *beside]
    for in_progress in (sweeps_in_progress_section(results_dir, results),
                        mpc_sweeps_in_progress_section(results_dir, results),
                        host_speed_section(results_dir)):
        if in_progress:
            lines += ["", *in_progress]
    other = [r for r in results if r.kind not in SECTIONS]
    if other:
        lines += ["", "## Other result files", "",
                  "Files of a kind this script does not render (field \"experiment\"):", ""]
        lines += [f"- {link(r, page)}: experiment `{r.kind}`, commit `{r.commit}`, "
                  f"`{r.command}`" for r in other]
    return "\n".join(lines) + "\n"


def _items(r: Result) -> str:
    names = [f"{e.paper}: {e.item}" for e in CATALOGUE if e.match(r)]
    return "; ".join(names) or "-"


def headlines_section(results: list[Result], page: Path) -> list[str]:
    """RESULTS.md's headline of every result file: per catalogue entry (``CATALOGUE``) its
    command and headline numbers, Fig. 7's claims on the recorded files and Table 1 under the
    authors' protocol against the paper's printed one. (README.md's block is the compact map
    of ``report_map``, one row per figure or table, that links here.)"""
    rows = []
    for e in CATALOGUE:
        # a Fig. 7 run that departs from its protocol is in its section, beside the protocol's
        matched = [r for r in results if e.match(r) and not _departs(r)]
        if not matched:
            rows.append([e.paper, e.item, f"`{e.command}`", "not recorded yet"])
        for r in matched:
            headline = _rendered(r, HEADLINES[r.kind], r)
            rows.append([e.paper, e.item + (" (quick run)" if r.quick else ""),
                         f"`{r.command}`", f"{headline}; {source(r, page)}{readme_notes(r)}"])
    for r in results:                  # a known kind the catalogue has no row for
        if r.kind in HEADLINES and not _departs(r) and not any(e.match(r) for e in CATALOGUE):
            rows.append(["-", f"{r.kind}: {r.data.get('task', '')} {r.data.get('goal', '')}"
                         .strip(), f"`{r.command}`",
                         f"{_rendered(r, HEADLINES[r.kind], r)}; {source(r, page)}"
                         f"{readme_notes(r)}"])
    departing = "; ".join(sorted({fig7_departures(r) for r in results if _departs(r)}))
    claims = fig7_claims_lines(results, page)
    ref, published = paper_table1(results)
    beside = [(t, r) for t in published if (r := paper_preset_table1(results, t))]
    lines = [f"## {HEADLINES_TITLE}", "",
             "What each paper figure or table came to, one line per result file, with the "
             "command that recorded it; the sections below hold each file's tables."
             + (f" Fig. 7 runs that change a protocol's settings ({departing}) are in the "
                f"Fig. 7 section, each beside its protocol's file." if departing else ""), "",
             *table(["paper", "figure / table", "command", "headline numbers (source file, "
                     "commit)"], rows)]
    if claims:
        lines += ["", "Fig. 7's claims on the recorded files (each panel on the paper's metric, "
                      "named; 95 % intervals separate or overlapping; difference: the other "
                      f"method's mean minus Simple's ± its Welch 95 % interval; {HOLM_NOTE}):",
                  "", *claims]
    if beside:
        lines += ["", "Table 1 under `--preset authors` (else `paper`) against the paper's "
                      "printed Table 1 (MPC cost / baseline, means; the rows side by side are "
                      "in \"State-vector reduction, Table 1 beside the paper\" below):", ""]
        lines += [f"- {task}: paper cheapest first {', '.join(o['paper_order'][:3])}; ours "
                  f"{', '.join(o['our_order'][:3])}. {ordering_sentence(o)}; {source(r, page)}."
                  for task, r in beside
                  for o in [orderings(*_table1_columns(published[task], r.data))]]
    return lines


def readme_block(results: list[Result], readme: Path, results_md_path: Path) -> str:
    """The README's block between the markers (markers excluded): the map of the papers'
    figures and tables (``report_map``)."""
    return map_block(results, readme, results_md_path)


def replace_block(text: str, block: str) -> str | None:
    """``text`` with the block between the markers replaced; None without both markers."""
    start, end = text.find(BEGIN), text.find(END)
    if start < 0 or end < start:
        return None
    return text[:start + len(BEGIN)] + "\n" + block + "\n" + text[end:]


# ------------------------------------------------------------------------------- main
def readme_notes(r: Result) -> str:
    """What the README's headline cell adds after a result's source: that it is stale, and
    how many of its trials came from uncommitted code ("" for neither)."""
    notes = [stale_note(r.notes.get("stale"), short=True),
             uncommitted_note(r.notes.get("trials"))]
    return "".join(f"; **{n}**" if not n.startswith("**") else f"; {n}" for n in notes if n)


def annotate(results: list[Result], results_dir: Path) -> None:
    """Set each result's ``notes``: its committed trials ("trials", "trials_line":
    ``report_trials``) and whether today's presets still give its settings ("stale",
    "stale_line": ``report_stale``, against the presets snapshot under ``results_dir``)."""
    try:
        snap = load_snapshot(results_dir)
    except ValueError as e:
        raise ReportError(str(e)) from e
    for r in results:
        info = summary_trials(results_dir, r)
        r.notes["trials"] = info
        r.notes["trials_line"] = trials_line(r, info)
        params = first_params(info) if r.kind in SVR_KINDS else None
        findings = _rendered(r, stale_findings, r, snap, params)
        if findings is not None:
            findings = findings + code_findings(r, results_dir)
        r.notes["stale"] = findings
        line = stale_note(findings)
        if findings is None and snap is not None and needs_backfill(r):
            line = ("Not checked against today's presets: it records only their names, and "
                    f"{SNAPSHOT.as_posix()} does not say what they meant at its commit (run "
                    "`python experiments/presets_snapshot.py`).")
        r.notes["stale_line"] = line


def generate(results_dir: Path, results_md_path: Path, readme: Path) -> dict:
    """{"files": {path: wanted text} of both outputs (README only when it has the markers),
    "note": about a README without markers (or None), "results": the result files read}."""
    results = load_results(results_dir)
    annotate(results, results_dir)
    index = results_md(results, results_dir, results_md_path)
    out = {Path(results_md_path): index}
    titles = {line[3:] for line in index.splitlines() if line.startswith("## ")}
    for paper, page in page_paths(results_md_path).items():
        out[page] = paper_page(paper, results, results_dir, page, results_md_path, titles)
    note = None
    if Path(readme).exists():
        new = replace_block(Path(readme).read_text(),
                            readme_block(results, readme, results_md_path))
        if new is None:
            note = (f"{readme} has no {BEGIN} ... {END} markers: left alone (put them where "
                    "the headline table belongs)")
        else:
            out[Path(readme)] = new
    else:
        note = f"{readme} does not exist: left alone"
    return {"files": out, "note": note, "results": results}


def parser() -> argparse.ArgumentParser:
    ap = ArgumentParser(prog="report.py", description=__doc__, epilog=EPILOG,
                        formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--check", action="store_true",
                    help="write nothing; exit 1 if RESULTS.md, a paper's page beside it or "
                         "the README block differs from what this script would generate")
    ap.add_argument("--results-dir", type=existing_dir, default=ROOT / "docs" / "results",
                    help="folder of the result files (default docs/results; given, it must "
                         "exist)")
    ap.add_argument("--results-md", type=Path, default=ROOT / "docs" / "RESULTS.md",
                    help="the generated index (default docs/RESULTS.md); the papers' pages "
                         "are written beside it")
    ap.add_argument("--readme", type=Path, default=ROOT / "README.md",
                    help="the README whose results block is rewritten (default README.md)")
    return ap


@guarded("report.py")
def main(argv=None) -> int:
    ap = parser()
    args = ap.parse_args(argv)
    if not args.check:
        for flag, path in (("--results-md", args.results_md), ("--readme", args.readme)):
            problem = file_problem(path) if flag == "--results-md" or path.exists() else None
            if problem:
                ap.error(f"argument {flag}: {problem}")
    try:
        gen = generate(args.results_dir, args.results_md, args.readme)
    except ReportError as e:
        print(f"report.py: error: {e}", file=sys.stderr)
        return 2
    for r in gen["results"]:
        gaps = provenance_gaps(r)
        if gaps:
            print(f"note: {_display(r.path)}: its provenance lacks {', '.join(gaps)} (rerun "
                  f"the experiment to record them)", file=sys.stderr)
    if gen["note"]:
        print(f"note: {gen['note']}", file=sys.stderr)
    stale = [p for p, text in gen["files"].items()
             if not p.exists() or p.read_text() != text]
    if args.check:
        for p in stale:
            print(f"{_display(p)} differs from what experiments/report.py generates from "
                  f"{_display(args.results_dir)}; run `{REGENERATE}`", file=sys.stderr)
        if not stale:
            print("up to date: " + ", ".join(_display(p) for p in gen["files"]))
        return 1 if stale else 0
    for p in stale:
        atomic.write_text(p, gen["files"][p])
    print("wrote " + (", ".join(_display(p) for p in stale) or "nothing (up to date)"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
