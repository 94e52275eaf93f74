"""Command-line pieces shared by ``python -m dopt.bench`` and ``python -m planners.bench``:
the flags every bench takes, --record and its result file, one JSON line per measurement.
The argparse types themselves are ``dopt.lab.cli``'s."""

from __future__ import annotations

import argparse
import json

from dopt import atomic
from dopt.lab.cli import nonneg_int, output_file, positive_int


def add_common_args(p: argparse.ArgumentParser, task: str = "clutter") -> None:
    """--task, --threads, --repeats and --seed, the flags every bench takes."""
    p.add_argument("--task", default=task, help="task scene from dopt.tasks (default %(default)s)")
    p.add_argument("--threads", type=nonneg_int, default=0,
                   help="simulation threads (0: all cores)")
    p.add_argument("--repeats", type=positive_int, default=5,
                   help="timed repeats; the best is kept")
    p.add_argument("--seed", type=nonneg_int, default=0,
                   help="seed of the scene layout and controls")


def add_record_arg(p: argparse.ArgumentParser, experiment: str, when: str = "") -> None:
    """--record PATH: the bench's rows with their provenance as a result file (experiment
    ``experiment``), written ``when`` (e.g. "as each size finishes"; default: at the end)."""
    when = f" {when}" if when else ""
    p.add_argument("--record", type=output_file, default=None, metavar="PATH",
                   help=f"also write the rows with their provenance to PATH{when} (a result "
                        f"file, experiment \"{experiment}\")")


def write_record(path, experiment: str, rows: list[dict], **fields) -> None:
    """Write ``rows`` (and ``fields``, e.g. the task) with this run's provenance to ``path``
    as a result file ``{"experiment", **fields, "rows", "provenance"}``."""
    from dopt.lab.provenance import provenance

    atomic.write_text(path, json.dumps({"experiment": experiment, **fields, "rows": rows,
                                        "provenance": provenance()}, indent=1))


def print_json(out: dict | list[dict]) -> None:
    """One JSON object per line: each measurement of a bench's result."""
    for obj in out if isinstance(out, list) else [out]:
        print(json.dumps(obj))
