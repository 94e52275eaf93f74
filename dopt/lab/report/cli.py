"""The report's command line: ``python experiments/report.py [--check]`` and ``dopt-report``.

Reads every result file under ``--results-dir`` and writes docs/RESULTS.md, the paper pages
beside it and README.md's map (``dopt.lab.report.engine.generate``); ``--check`` writes
nothing and exits 1 when any of them is not what it would write. A result file that cannot be
read exits 2 naming it; one whose provenance lacks the command, the git commit or the versions
of dopt, mujoco and torch is named in a note on stderr.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from dopt import atomic
from dopt.lab.cli import EPILOG, ArgumentParser, existing_dir, file_problem, guarded
from dopt.lab.report.base import REGENERATE, ROOT, ReportError, _display, provenance_gaps
from dopt.lab.report.engine import generate

#: what ``--help`` says before the flags
DESCRIPTION = """Generate the result pages and README.md's map of the papers' figures from the
result files.

Every number in the docs comes from a result file docs/results/*.json that an experiment wrote
itself (--record PATH). This command writes docs/RESULTS.md (the index: every result file's
headline, section, committed trials and whether it is stale), a page per paper beside it
(docs/KEY-PARTICLES.md, docs/STATE-VECTOR-REDUCTION.md: the paper's claims with our verdicts)
and the block between <!-- results:begin --> and <!-- results:end --> in README.md (the map).
The result kinds are the registered experiments' (dopt.lab.experiment: the entry-point group
dopt.experiments, DOPT_EXPERIMENTS); files of other kinds are listed by name.

    python experiments/report.py            # regenerate the pages and the README's map
    python experiments/report.py --check    # exit 1 if any is not what it would write
"""


def parser() -> argparse.ArgumentParser:
    ap = ArgumentParser(prog="report.py", description=DESCRIPTION, epilog=EPILOG,
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
