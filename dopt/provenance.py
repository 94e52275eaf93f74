"""Where a result came from: the command line, the git commit, the package versions.

Every experiment stores ``provenance()`` in its summary, so a number in the docs can be traced
to the code and libraries that produced it; ``code_version()`` (dopt's version and the git
commit) is the short form a resumable sweep stores with each trial, so that a rerun with other
code does not reuse its results silently.
"""

from __future__ import annotations

import datetime
import functools
import importlib.metadata
import os
import platform
import shlex
import subprocess
import sys
from pathlib import Path

from dopt import __version__

#: the packages whose versions a result records
PACKAGES = ("dopt", "mujoco", "torch", "numpy", "scipy", "cvxpy", "pymeshlab", "trimesh")
_ROOT = Path(__file__).resolve().parents[1]


@functools.lru_cache(maxsize=1)
def git_commit() -> str | None:
    """The commit this code is: the environment variable ``DOPT_GIT_COMMIT`` where set (a
    source tree copied to a cluster or GPU machine: whoever copied it names the commit, since
    the copy's own .git, if any, may be another commit's), else the checkout's HEAD with
    "-dirty" when tracked files differ from it, else (an installed wheel, no git) None."""
    if os.environ.get("DOPT_GIT_COMMIT"):
        return os.environ["DOPT_GIT_COMMIT"]
    try:
        head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=_ROOT, capture_output=True,
                              text=True, timeout=10)
        if head.returncode != 0:
            return None
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"],
                               cwd=_ROOT, capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return None
    return head.stdout.strip() + ("-dirty" if dirty.stdout.strip() else "")


def versions() -> dict:
    """{package: version or None} of ``PACKAGES`` and Python."""
    out = {"python": platform.python_version()}
    for name in PACKAGES:
        if name == "dopt":                  # the source's, which no stale install metadata hides
            out[name] = __version__
            continue
        try:
            out[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            out[name] = None
    return out


def code_version() -> dict:
    """{"version": dopt's version, "commit": ``git_commit()`` or "unknown"}: what a trial file
    records. A resumed sweep recomputes a trial written by another dopt *version* (a version
    bump marks a result-changing release) and reuses, but counts, one written by another
    *commit* of the same version (``dopt.sweep.SweepResult.commits``). The version is
    ``dopt.__version__``, read from the source: an editable install's metadata keeps the
    version it was installed with until it is reinstalled."""
    return {"version": __version__, "commit": git_commit() or "unknown"}


def provenance(argv: list[str] | None = None) -> dict:
    """{"command", "git_commit", "versions", "date", "machine"} of this process; ``argv``
    defaults to ``sys.argv``."""
    argv = sys.argv if argv is None else argv
    return {"command": command_line(argv),
            "git_commit": git_commit(),
            "versions": versions(),
            "date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
            "machine": {"platform": platform.platform(), "cpus": _cpus()}}


def command_line(argv: list[str]) -> str:
    """The command a user types to rerun ``argv`` from the checkout's root: a script inside
    the checkout by its relative path, a package's ``__main__.py`` (``python -m``) by its
    module name, anything else as given."""
    if not argv:
        return "python"
    script = Path(argv[0])
    try:
        rel = script.resolve().relative_to(_ROOT) if script.is_absolute() else None
    except ValueError:
        rel = None
    if rel is not None:
        if rel.name == "__main__.py" and len(rel.parts) > 1:
            return shlex.join(["python", "-m", ".".join(rel.parts[:-1]), *argv[1:]])
        return shlex.join(["python", rel.as_posix(), *argv[1:]])
    return shlex.join(["python", *argv])


def _cpus() -> int:
    import os
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
