"""Console scripts of the experiment scripts (pyproject.toml ``[project.scripts]``):
``dopt-fold`` (experiments/cloth_fold.py), ``dopt-rope`` (rope.py), ``dopt-mpc`` (mpc.py),
``dopt-keys`` (key_particles.py), ``dopt-report`` (report.py).

experiments/ is not a package: each console script runs its file with ``runpy`` as
``__main__`` with the experiments folder first on ``sys.path`` (as ``python
experiments/X.py`` does), so the two are the same run; its usage, help and error lines call
it by the console script's name (``dopt.lab.cli.shown_as``). The folder is the repository's,
beside this package (an editable install), or ``$DOPT_EXPERIMENTS``. Standard library and
``dopt.lab.cli`` only.
"""

from __future__ import annotations

import os
import runpy
import sys
from pathlib import Path

from dopt.lab.cli import shown_as

#: console script -> the experiment script it runs
SCRIPTS = {"dopt-fold": "cloth_fold.py", "dopt-rope": "rope.py", "dopt-mpc": "mpc.py",
           "dopt-keys": "key_particles.py", "dopt-report": "report.py"}
#: environment variable naming another experiments folder
ENV = "DOPT_EXPERIMENTS"


def experiments_dir() -> Path:
    """``$DOPT_EXPERIMENTS``, else the repository's experiments/ beside the dopt package."""
    return Path(os.environ.get(ENV) or Path(__file__).resolve().parents[2] / "experiments")


def run(name: str, argv: list[str] | None = None) -> int:
    """Run the experiment script of console script ``name`` with ``argv`` (default: this
    process's arguments) as ``python experiments/<script> ...`` would; its exit status
    (SystemExit passes through). A missing script is one line on stderr and status 1."""
    if name not in SCRIPTS:
        raise ValueError(f"unknown console script {name!r}; choose from {', '.join(SCRIPTS)}")
    script = experiments_dir() / SCRIPTS[name]
    if not script.is_file():
        print(f"{name}: error: no {script} (the experiment scripts live in the repository's "
              f"experiments/ folder: install with pip install -e . or set {ENV})",
              file=sys.stderr)
        return 1
    args = sys.argv[1:] if argv is None else list(argv)
    saved = sys.argv[:], sys.path[:]
    sys.argv = [str(script), *args]
    sys.path.insert(0, str(script.parent))
    try:
        with shown_as(SCRIPTS[name], name):      # its usage and errors say dopt-..., not X.py
            runpy.run_path(str(script), run_name="__main__")
    finally:
        sys.argv, sys.path[:] = saved[0], saved[1]
    return 0


def fold() -> int:
    return run("dopt-fold")


def rope() -> int:
    return run("dopt-rope")


def mpc() -> int:
    return run("dopt-mpc")


def keys() -> int:
    return run("dopt-keys")


def report() -> int:
    return run("dopt-report")
