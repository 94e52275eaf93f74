"""Where a result came from: the command line, the git commit, the package versions; and the
one rule, asked of git itself, that says whether a stored result may stand for this code.

Every experiment stores ``provenance()`` in its summary, so a number in the docs can be traced
to the code and libraries that produced it; ``CodeState.stamp()`` (dopt's version, the git
commit and, for uncommitted code, a fingerprint of it) is what a resumable sweep stores with
each trial (``dopt.lab.sweep``). A result names no folder of the machine it ran on: the command
(``command_line``) and the settings (``root_relative``, read back by ``rooted``) record paths
relative to the checkout's root, or its sibling ``../shared``; ``recorded_command`` shows an
older record's command so.

The rules, exactly:

- **Result paths** (``RESULT_PATHS``): dopt/, deformables/, planners/, experiments/,
  pyproject.toml, setup.py; only files there can change a result (docs/, tests/, README do
  not).
- **Dirty**: a tree is dirty when a tracked file under the result paths differs from HEAD
  (staged or not, deleted or renamed), or an untracked, not ignored source file
  (``UNTRACKED_SOURCES``: .py, .c, .h) lies under a package folder (``PACKAGE_DIRS``): a new
  module can change a result. Untracked files elsewhere, and changes outside the result paths,
  do not count. A dirty tree's commit is ``"<HEAD sha>-dirty"``; outside a git checkout it is
  None (``code_version``: "no git").
- **Recording** (``CodeState.record_problem``): a ``--record`` result (and trial files written
  into docs/results/, ``dopt.lab.sweep``) is refused, one line naming the changed files, from a
  dirty tree or outside a git checkout. Ordinary runs (``--out`` elsewhere, the tests) are
  not: they write their records marked ``-dirty``.
- **Reuse** (``reuse_problem``): a stored result of commit X stands for this code when X is
  HEAD, or X is a commit git knows, an ancestor of HEAD, and ``git diff X HEAD -- RESULT_PATHS``
  is empty; and the working tree is clean in the result paths. A ``-dirty`` record is never
  reused at any commit; the one exception is a resume in the same uncommitted tree it was
  written from (the same HEAD and the same fingerprint of the changed files' contents: the
  code is byte for byte the same), so that a developer's killed run, and the tests, resume
  before anything is committed. A record of no known commit ("unknown", "no git", none) is
  never reused. git's answers are cached per (X, HEAD) within a process.
- **A copied tree**: ``DOPT_GIT_COMMIT`` (``COMMIT_ENV``), where set, is the commit recorded,
  as given, and nothing is asked of the copy's .git about dirtiness: whoever copies a tree to a
  cluster or GPU machine vouches that it is that commit unchanged, or names it ``<sha>-dirty``.
"""

from __future__ import annotations

import datetime
import functools
import hashlib
import importlib.metadata
import os
import platform
import shlex
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

from dopt import __version__, blas

#: the packages whose versions a result records
PACKAGES = ("dopt", "mujoco", "torch", "numpy", "scipy", "cvxpy", "pymeshlab", "trimesh")
#: the distributions a package's version is read from, first found first: MuJoCo's bindings
#: ship as mujoco-core (the dependency; the mujoco metapackage pins an older core)
DISTRIBUTIONS = {"mujoco": ("mujoco-core", "mujoco")}
#: the paths whose files can change a result (relative to the repository's root)
RESULT_PATHS = ("dopt", "deformables", "planners", "experiments", "pyproject.toml", "setup.py")
#: the package folders in which an untracked source file counts as a change
PACKAGE_DIRS = ("dopt", "deformables", "planners", "experiments")
#: the suffixes of the untracked files that count (a new module, a new C kernel)
UNTRACKED_SOURCES = (".py", ".c", ".h")
#: the environment variable naming the commit of a copied tree
COMMIT_ENV = "DOPT_GIT_COMMIT"
#: the suffix of a commit whose tree had uncommitted changes
DIRTY = "-dirty"
#: the commit a trial record holds when the code is not a git checkout
NO_GIT = "no git"
#: how many changed files a one-line message names before "and N more"
NAMED_FILES = 12
#: the folder beside the checkout's root that holds what is not committed (the papers, the
#: authors' code and data): a path into it is recorded as ``../shared/...``
SHARED = "shared"
#: the committed folders of a checkout, by which ``recorded_command`` finds where an older
#: record's checkout lay
CHECKOUT_DIRS = (*PACKAGE_DIRS, "docs", "tests")
#: what a recorded path outside the checkout and its shared folder shows for its folders
OUTSIDE = "<outside>"
_ROOT = Path(__file__).resolve().parents[2]


@dataclass(frozen=True)
class CodeState:
    """The code this process runs, as git sees it (``code_state``).

    Attributes:
        head: HEAD's full sha (or the commit ``DOPT_GIT_COMMIT`` names, less "-dirty"); None
            outside a git checkout.
        dirty: whether files that can change a result differ from ``head``.
        changed: those files (sorted; untracked ones too), empty when named by the variable.
        tree: a fingerprint of the changed files' contents (None when clean or unknown).
        named: whether ``DOPT_GIT_COMMIT`` named the commit.
    """

    head: str | None
    dirty: bool = False
    changed: tuple[str, ...] = ()
    tree: str | None = None
    named: bool = False

    @property
    def commit(self) -> str | None:
        """"<head>", "<head>-dirty", or None outside git."""
        if self.head is None:
            return None
        return self.head + (DIRTY if self.dirty else "")

    def stamp(self) -> dict:
        """What a trial record stores under "code": {"version", "commit"} and, for a dirty
        tree, "tree" (the fingerprint that lets the same uncommitted tree resume it)."""
        out = {"version": __version__, "commit": self.commit or NO_GIT}
        if self.dirty and self.tree:
            out["tree"] = self.tree
        return out

    def record_problem(self) -> str | None:
        """Why a result of this code cannot be recorded (one line), or None."""
        if self.head is None:
            return ("cannot record outside a git checkout: the result would name no commit "
                    f"(a copied tree: set {COMMIT_ENV} to the commit it is)")
        if not self.dirty:
            return None
        if not self.changed:
            return f"cannot record from uncommitted code: {COMMIT_ENV} names {self.commit}"
        return (f"cannot record from uncommitted code: {len(self.changed)} file(s) that can "
                f"change a result differ from HEAD {self.head[:12]}: "
                f"{name_files(self.changed)}; commit them first (or write with --out only)")


def name_files(files) -> str:
    """``files`` on one line, the first ``NAMED_FILES`` by name and the rest counted."""
    files = list(files)
    shown = ", ".join(files[:NAMED_FILES])
    return shown + (f" and {len(files) - NAMED_FILES} more" if len(files) > NAMED_FILES else "")


def repo_root(root: Path | str | None = None) -> Path:
    """``root`` as a Path; None: this checkout (the folder holding the dopt package)."""
    return _ROOT if root is None else Path(root)


def _git(root: Path, *args: str, timeout: float = 60) -> subprocess.CompletedProcess | None:
    """``git -C root args``; None when git cannot be run at all."""
    try:
        return subprocess.run(["git", "-C", str(root), *args], capture_output=True,
                              timeout=timeout)
    except (OSError, subprocess.SubprocessError):
        return None


def code_state(root: Path | str | None = None) -> CodeState:
    """The code under ``root`` (default: this checkout), asked of git now (uncached):
    HEAD, the changed result files and their fingerprint; ``DOPT_GIT_COMMIT`` where set."""
    named = os.environ.get(COMMIT_ENV)
    if named:
        return CodeState(named.removesuffix(DIRTY), named.endswith(DIRTY), named=True)
    root = repo_root(root)
    proc = _git(root, "rev-parse", "--show-toplevel", "HEAD")
    lines = proc.stdout.decode().split() if proc is not None and proc.returncode == 0 else []
    # a tree inside another checkout (a virtualenv's site-packages) is not that checkout
    if len(lines) != 2 or not _same_dir(lines[0], root):
        return CodeState(None)
    sha = lines[1]
    changed = changed_files(root)
    if changed is None:             # git answered HEAD but not its status: assume the worst
        return CodeState(sha, True, ("(git status failed)",))
    if not changed:
        return CodeState(sha)
    return CodeState(sha, True, tuple(changed), _fingerprint(root, sha, changed))


def _same_dir(a: str | Path, b: str | Path) -> bool:
    try:
        return Path(a).resolve() == Path(b).resolve()
    except OSError:
        return False


def changed_files(root: Path | str | None = None) -> list[str] | None:
    """The files under ``RESULT_PATHS`` that make ``root``'s tree dirty (see the module's
    rules), sorted; None when git cannot tell."""
    root = repo_root(root)
    proc = _git(root, "status", "--porcelain=v1", "-z", "--untracked-files=all", "--",
                *RESULT_PATHS)
    if proc is None or proc.returncode != 0:
        return None
    entries = proc.stdout.decode(errors="surrogateescape").split("\0")
    out, i = set(), 0
    while i < len(entries):
        entry = entries[i]
        i += 1
        if len(entry) < 4:
            continue
        status, path = entry[:2], entry[3:]
        if status == "??":
            if path.endswith(UNTRACKED_SOURCES) and path.split("/")[0] in PACKAGE_DIRS:
                out.add(path)
            continue
        out.add(path)
        if "R" in status or "C" in status:     # a rename's or copy's source follows
            if i < len(entries) and entries[i]:
                out.add(entries[i])
            i += 1
    return sorted(out)


def _fingerprint(root: Path, head: str, changed) -> str:
    """sha256 (16 hex digits) of HEAD and each changed file's path and bytes: two trees
    share it only when their uncommitted code is the same."""
    h = hashlib.sha256(head.encode())
    for rel in sorted(changed):
        h.update(b"\0" + rel.encode(errors="surrogateescape") + b"\0")
        try:
            h.update(hashlib.sha256((root / rel).read_bytes()).digest())
        except OSError:
            h.update(b"<missing>")
    return h.hexdigest()[:16]


def reuse_problem(code: dict | None, state: CodeState,
                  root: Path | str | None = None) -> str | None:
    """Why a stored result whose record holds ``code`` ({"commit", "tree"?}) cannot stand for
    ``state``'s code (one line), or None when it can (the module's reuse rule)."""
    commit = code.get("commit") if isinstance(code, dict) else None
    if not commit or not isinstance(commit, str) or commit in ("unknown", NO_GIT):
        return f"written by code of no known commit ({commit or 'none recorded'})"
    if commit.endswith(DIRTY):
        if (state.dirty and state.tree is not None and commit == state.commit
                and code.get("tree") == state.tree):
            return None                 # the same uncommitted tree, byte for byte
        return f"written from uncommitted code ({commit})"
    if state.head is None:
        return f"this code is not a git checkout: no commit to compare {commit[:12]} with"
    if state.dirty:
        return ("this tree has uncommitted changes to files that can change a result "
                f"({name_files(state.changed)})")
    if commit == state.head:
        return None
    return _diff_problem(str(repo_root(root)), commit, state.head)


@functools.lru_cache(maxsize=256)
def _diff_problem(root: str, commit: str, head: str) -> str | None:
    """``reuse_problem`` for a clean tree at ``head`` and another commit: git's answer,
    cached per (root, commit, head)."""
    where = Path(root)
    found = _git(where, "rev-parse", "--verify", "--quiet", f"{commit}^{{commit}}")
    if found is None or found.returncode != 0:
        return f"its commit {commit[:12]} is unknown to git here"
    full = found.stdout.decode().strip()
    if full == head:
        return None
    ancestor = _git(where, "merge-base", "--is-ancestor", full, head)
    if ancestor is None or ancestor.returncode not in (0, 1):
        return f"git cannot tell whether {commit[:12]} is an ancestor of HEAD"
    if ancestor.returncode == 1:
        return f"its commit {commit[:12]} is not an ancestor of HEAD {head[:12]}"
    diff = _git(where, "diff", "--name-only", "-z", full, head, "--", *RESULT_PATHS)
    if diff is None or diff.returncode != 0:
        return f"git cannot compare {commit[:12]} with HEAD {head[:12]}"
    files = [f for f in diff.stdout.decode(errors="surrogateescape").split("\0") if f]
    if files:
        return (f"files that can change its result changed since {commit[:12]}: "
                f"{name_files(files)}")
    return None


def git_commit(root: Path | str | None = None) -> str | None:
    """The commit this code is: ``DOPT_GIT_COMMIT`` where set, else the checkout's HEAD with
    "-dirty" when files that can change a result differ from it (the module's rules), else
    (an installed wheel, no git) None. A checkout's answer is cached per root for the
    process (``_checkout_commit``); the variable is read on every call."""
    if os.environ.get(COMMIT_ENV):
        return os.environ[COMMIT_ENV]
    return _checkout_commit(str(repo_root(root)))


@functools.lru_cache(maxsize=8)
def _checkout_commit(root: str) -> str | None:
    return code_state(root).commit


def versions() -> dict:
    """{package: version or None} of ``PACKAGES`` and Python."""
    out = {"python": platform.python_version()}
    for name in PACKAGES:
        if name == "dopt":                  # the source's, which no stale install metadata hides
            out[name] = __version__
            continue
        out[name] = None
        for dist in DISTRIBUTIONS.get(name, (name,)):
            try:
                out[name] = importlib.metadata.version(dist)
                break
            except importlib.metadata.PackageNotFoundError:
                continue
    return out


def code_version(root: Path | str | None = None) -> dict:
    """{"version": dopt's version, "commit": ``git_commit()`` or "no git"}: the short form of
    the code a result came from. The version is ``dopt.__version__``, read from the source (an
    editable install's metadata keeps the version it was installed with); it is recorded, but
    no longer decides reuse: ``reuse_problem`` does, from git."""
    return {"version": __version__, "commit": git_commit(root) or NO_GIT}


def provenance(argv: list[str] | None = None, root: Path | str | None = None) -> dict:
    """{"command", "git_commit", "versions", "date", "machine"} of this process; ``argv``
    defaults to ``sys.argv``; "git_commit" is None outside a git checkout."""
    argv = sys.argv if argv is None else argv
    return {"command": command_line(argv),
            "git_commit": git_commit(root),
            "versions": versions(),
            "date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
            "machine": machine()}


def machine() -> dict:
    """{"platform", "cpu", "cpus", "blas"} of this process: the OS, the processor's model name
    (from /proc/cpuinfo, else ``platform.processor()``; "" when neither says), the cores it may
    use and the kernels numpy's OpenBLAS runs (``dopt.blas.kernels``: the bits of a BLAS
    result depend on them). A sweep's trial records carry it: a CPU-time clock (the virtual
    clock of the MPC experiments) runs at the speed of the machine a trial ran on. A new dict
    each call."""
    return dict(_machine())


@functools.cache
def _machine() -> dict:
    cpu = blas.cpuinfo("model name")
    return {"platform": platform.platform(), "cpu": cpu or platform.processor(), "cpus": _cpus(),
            "blas": blas.kernels()}           # fixed once OpenBLAS has loaded


def command_line(argv: list[str], root: Path | str | None = None) -> str:
    """The command a user types to rerun ``argv`` from the checkout's root, naming no folder of
    this machine: a module that ``python -m`` ran (this process's ``__main__``, when
    ``argv[0]`` is its file) or a package's ``__main__.py`` by its module name, another script
    inside the checkout by its relative path, anything else as given; every argument that is
    an absolute path (alone or as ``--flag=PATH``) as ``portable_path`` writes it. (A module
    inside a package, such as ``deformables/bench.py``, only runs with ``-m``: its relative
    imports fail as a script.)"""
    if not argv:
        return "python"
    args = [_portable_argument(a, root) for a in argv[1:]]
    module = _module_run_as_main(argv[0])
    if module is not None:
        return shlex.join(["python", "-m", module, *args])
    script = argv[0]
    if os.path.isabs(script):
        script = portable_path(script, root)
        rel = Path(script)
        if rel.name == "__main__.py" and len(rel.parts) > 1 and ".." not in rel.parts \
                and not script.startswith(OUTSIDE):
            return shlex.join(["python", "-m", ".".join(rel.parts[:-1]), *args])
    return shlex.join(["python", script, *args])


def recorded_command(command: str, root: Path | str | None = None) -> str:
    """A recorded command line as ``command_line`` writes it today, for a record written before
    it named no folder of its machine: its absolute paths made relative to the checkout of the
    machine that recorded it, taken to be the folder above the first part of such a path that
    names a folder of the checkout (``CHECKOUT_DIRS``), or the folder beside one named
    ``shared``. A command that does not parse, or names no absolute path, is returned as it
    is."""
    try:
        words = shlex.split(command)
    except ValueError:
        return command
    if len(words) < 2 or words[0] != "python" or not any(
            os.path.isabs(_path_of(w)) for w in words[1:]):
        return command
    recorder = None
    for word in words[1:]:
        parts = Path(_path_of(word)).parts if os.path.isabs(_path_of(word)) else ()
        at = next((i for i, part in enumerate(parts) if part in (*CHECKOUT_DIRS, SHARED)), None)
        if at:
            base = Path(*parts[:at])
            recorder = base / "checkout" if parts[at] == SHARED else base
            break
    return command_line(words[1:], repo_root(root) if recorder is None else recorder)


def root_relative(path: str | os.PathLike, root: Path | str | None = None) -> str:
    """``path`` (a relative one taken from the current folder) relative to the checkout's root,
    with / between its parts: what a setting records, so that a result names no folder of
    this machine (``rooted`` reads it back). A path on another drive stays absolute."""
    full = os.path.abspath(os.fspath(path))
    try:
        return Path(os.path.relpath(full, repo_root(root))).as_posix()
    except ValueError:                               # another drive (Windows)
        return full


def rooted(path: str | os.PathLike, root: Path | str | None = None) -> Path:
    """A recorded path (``root_relative``) on this machine: a relative one from the checkout's
    root, an absolute one (an older record's) as it is; normalised."""
    return Path(os.path.normpath(repo_root(root) / path))


def portable_path(path: str | os.PathLike, root: Path | str | None = None) -> str:
    """``path`` as a recorded command shows it: relative to the checkout's root
    (``root_relative``) where it lies inside it or inside the shared folder beside it
    (``../shared/...``), else ``<outside>/NAME``: a folder of this machine means nothing to a
    reader of the result."""
    rel = root_relative(path, root)
    if os.path.isabs(rel) or (rel.split("/")[0] == ".." and rel.split("/")[1:2] != [SHARED]):
        return f"{OUTSIDE}/{Path(os.fspath(path)).name}"
    return rel


def _path_of(word: str) -> str:
    """The path an argument names: itself, or the value of ``--flag=PATH``."""
    return word.split("=", 1)[1] if word.startswith("-") and "=" in word else word


def _portable_argument(word: str, root) -> str:
    path = _path_of(word)
    if not os.path.isabs(path):
        return word
    return word[:len(word) - len(path)] + portable_path(path, root)


def _module_run_as_main(script: str) -> str | None:
    """The name ``python -m`` ran this process's ``__main__`` under, if ``script`` is that
    module's file; else None (a script, ``-c``, or another program's ``argv``)."""
    spec = getattr(sys.modules.get("__main__"), "__spec__", None)
    name, origin = getattr(spec, "name", None), getattr(spec, "origin", None)
    if not name or not origin:
        return None
    try:
        same = Path(script).resolve() == Path(origin).resolve()
    except (OSError, ValueError):
        return None
    return name.removesuffix(".__main__") if same else None


def _cpus() -> int:
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
