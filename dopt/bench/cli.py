"""Command-line pieces shared by ``python -m dopt.bench`` and ``python -m planners.bench``."""

from __future__ import annotations

import argparse
import json


def add_common_args(p: argparse.ArgumentParser, task: str = "clutter") -> None:
    """--task, --threads, --repeats and --seed, the flags every bench takes."""
    p.add_argument("--task", default=task, help="task scene from dopt.tasks (default %(default)s)")
    p.add_argument("--threads", type=int, default=0, help="simulation threads (0: all cores)")
    p.add_argument("--repeats", type=int, default=5, help="timed repeats; the best is kept")
    p.add_argument("--seed", type=int, default=0, help="seed of the scene layout and controls")


def print_json(out: dict | list[dict]) -> None:
    """One JSON object per line: each measurement of a bench's result."""
    for obj in out if isinstance(out, list) else [out]:
        print(json.dumps(obj))
