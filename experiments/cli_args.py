"""Command-line helpers of the experiment scripts: the shared argparse types and one-line
errors of ``dopt.cli`` (re-exported here, so a script imports its CLI pieces from one place),
plus what only experiments do: check --record against --out and write OUT/summary.json with
the run's provenance. Standard library and ``dopt.cli`` / ``dopt.provenance`` only, so the
MuJoCo-free key-particle experiment can use them without importing torch or MuJoCo.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

from dopt.cli import (  # noqa: F401  (re-exported for the scripts)
    EPILOG,
    TRACEBACK_ENV,
    choices_list,
    choices_type,
    existing_dir,
    file_problem,
    folder_problem,
    guarded,
    int_at_least,
    no_repeats,
    nonneg_float,
    nonneg_int,
    number_list,
    one_line,
    output_dir,
    output_file,
    positive_float,
    positive_int,
)


def record_problem(record: Path | None, out: Path) -> str | None:
    """Why --record PATH cannot be written next to the --out folder (it is that folder)."""
    if record is not None and Path(record).absolute() == Path(out).absolute():
        return f"argument --record: {record} is the --out folder"
    return None


def write_summary(summary: dict, out: Path, record: Path | None, script: str, argv,
                  indent: int = 2) -> str:
    """Add this run's provenance (``script`` and its flags: ``argv``, or ``sys.argv[1:]`` when
    None) to ``summary``, write it to OUT/summary.json and, with --record, to that path too.
    Returns the JSON text."""
    from dopt.provenance import provenance  # pure Python: no MuJoCo, no torch

    summary["provenance"] = provenance([script, *(sys.argv[1:] if argv is None else argv)])
    text = json.dumps(summary, indent=indent)
    (Path(out) / "summary.json").write_text(text)
    if record:
        Path(record).parent.mkdir(parents=True, exist_ok=True)
        Path(record).write_text(text)
    return text
