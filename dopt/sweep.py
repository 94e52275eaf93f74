"""Resumable trial sweeps on a local process pool or a Ray cluster.

A trial is a pure function of its parameters (a JSON-able dict) that builds everything it needs
and returns a JSON-able dict. Each finished trial is written at once to ``OUT/trials/<key>.json``
(atomically), so a killed sweep loses only the trials that were running, and a rerun skips every
trial whose file exists and may stand for this code. The same code runs inline (``workers=1``),
on a local process pool, or on Ray (``ray_address``: "local" starts a local instance, anything
else is passed to ``ray.init``), so a sweep of thousands of trials goes to many machines without
code changes.

Trial files are checked when read: a file that is not a trial record (truncated or invalid
JSON, not an object, without "key", "params" or "result", or whose key is not its file name) is
named in a logged warning and moved to ``OUT/trials/corrupt/`` (never deleted), and its trial is
recomputed.

**Which code a record stands for.** Each record stores ``CodeState.stamp()`` under "code"
(dopt's version, the git commit, "-dirty" with a fingerprint for uncommitted code; see
``dopt.provenance`` for the exact rules). A stored trial is reused when its key matches (the
key names its settings) and ``dopt.provenance.reuse_problem`` finds nothing that can change its
result between its commit and HEAD (``git diff X HEAD -- dopt deformables planners experiments
pyproject.toml setup.py`` empty, X an ancestor of HEAD, the working tree clean there). Anything
else is recomputed and its old file moved to ``OUT/trials/outdated/`` (never deleted): a record
of an unknown commit, of no commit (records older than the "code" stamp, "no git"), of another
branch, or marked "-dirty" (except in the very tree it was written from, so that a killed run
resumes before its code is committed). The dopt version is recorded but decides nothing.
``reuse="any"`` reuses every valid record deliberately: ``SweepResult.reused_across`` (and
``take_deliberate_reuse()``, which the experiments' ``write_summary`` puts in the summary) list
the trials reused across a code change and why they would have been recomputed. No field of a
stored record is ever rewritten.

**Recording.** Trial files written into the checkout's docs/results/ (the committed results), or
by a caller that passes ``record=True``, are refused before anything runs (``RuntimeError``, one
line naming the changed files) when the tree is dirty or not a git checkout. Elsewhere (``--out``
folders, the tests' temporary folders) a dirty tree runs and marks its records "-dirty".

A long trial can save its progress as it goes: a trial function with a ``checkpoint``
parameter is given a ``Checkpoint`` (``OUT/trials/checkpoints/<key>.json``) to ``save`` to and
``load`` from, so that a rerun of a killed sweep, on this machine or on another one that has
the file, resumes the trial where it stopped instead of starting it again. The file is
deleted once the trial's record is written. A checkpoint follows the same rule as a trial, but
always the strict one (a resumed trial's record names this commit, so resuming across a code
change would hide it): one that cannot stand for this code is moved to
``OUT/trials/checkpoints/outdated/`` and its trial starts afresh.
"""

from __future__ import annotations

import inspect
import json
import logging
import os
import sys
import tempfile
from collections import Counter
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from multiprocessing import get_context
from pathlib import Path

from dopt.provenance import COMMIT_ENV, CodeState, code_state, repo_root, reuse_problem

log = logging.getLogger(__name__)

#: folders under OUT/trials where unusable trial files are moved (never deleted)
CORRUPT_DIR, OUTDATED_DIR = "corrupt", "outdated"
#: folder under OUT/trials of the unfinished trials' saved progress
CHECKPOINT_DIR = "checkpoints"
#: the fields every trial record has
RECORD_FIELDS = ("key", "params", "result")
#: run_sweep's reuse modes: git's rule, or every valid record (deliberately, listed)
REUSE_MODES = ("same-code", "any")
#: the folder, under a checkout's root, of the committed results
RESULTS_DIR = Path("docs") / "results"

#: {root: CodeState} this process last saw (run_sweep refreshes it; is_finished and
#: Checkpoint read it, so that asking about many trials asks git once)
_STATES: dict[str, CodeState] = {}
#: {trial key: why it would have been recomputed} of the trials reused with reuse="any"
_DELIBERATE: dict[str, str] = {}


@dataclass(frozen=True)
class Trial:
    """key: unique file-name stem; params: the JSON-able arguments of the trial function."""

    key: str
    params: dict

    def __post_init__(self):
        if not self.key or any(ch in self.key for ch in "/\\\0") or self.key.startswith("."):
            raise ValueError(f"trial key {self.key!r} is not a valid file name")


@dataclass(frozen=True)
class SweepResult:
    """The trials of one ``run_sweep`` call.

    Attributes:
        records: {key: {"key", "params", "result", "code"}} of every finished trial (old and
            new).
        ran: keys run in this call; skipped: keys found finished and reused.
        failed: {key: "ErrorType: message"} of the trials that raised.
        commits: {commit: number of records} over ``records`` (their "code" "commit";
            "unknown" for records without one): more than one key means the results were
            written at several commits (reused because no result file changed in between, or
            deliberately: ``reused_across``).
        recomputed: {key: reason} of trials that had a file but were run again (fresh, written
            by code that may give another result, a corrupt file).
        corrupt: {file name: reason} of the files moved to OUT/trials/corrupt in this call.
        reused_across: {key: why it would have been recomputed} of the trials that
            ``reuse="any"`` reused across a code change.
    """

    records: dict
    ran: list
    skipped: list
    failed: dict
    commits: dict = field(default_factory=dict)
    recomputed: dict = field(default_factory=dict)
    corrupt: dict = field(default_factory=dict)
    reused_across: dict = field(default_factory=dict)


def trial_path(out_dir: Path | str, key: str) -> Path:
    return Path(out_dir) / "trials" / f"{key}.json"


def current_code(root: Path | str | None = None, refresh: bool = False) -> CodeState:
    """The ``CodeState`` of ``root`` (default: this checkout) this process last saw; asked of
    git again when ``refresh`` (``run_sweep`` does, once per call) or never asked before."""
    where = str(repo_root(root))
    if refresh or where not in _STATES or os.environ.get(COMMIT_ENV):
        _STATES[where] = code_state(where)
    return _STATES[where]


def take_deliberate_reuse() -> dict:
    """{trial key: why it would have been recomputed} of every trial this process reused with
    ``reuse="any"`` since the last call, and forget them (``write_summary`` records them)."""
    out = dict(_DELIBERATE)
    _DELIBERATE.clear()
    return out


def record_refusal(out_dir: Path | str, state: CodeState, record: bool,
                   root: Path | str | None = None) -> str | None:
    """Why trial files cannot be written to ``out_dir`` from ``state``'s code (one line), or
    None: only a recording (``record``, or ``out_dir`` inside the checkout's docs/results/)
    from a dirty tree or outside git is refused."""
    results = (repo_root(root) / RESULTS_DIR).resolve()
    inside = Path(out_dir).resolve().is_relative_to(results)
    if not (record or inside):
        return None
    problem = state.record_problem()
    if problem is None:
        return None
    where = f"{out_dir} is inside {RESULTS_DIR}/" if inside else "the sweep is recorded"
    return f"cannot write trial files ({where}): {problem}"


class Checkpoint:
    """The saved progress of one unfinished trial, ``OUT/trials/checkpoints/<key>.json``.

    ``save(progress)`` writes the JSON-able dict atomically with the trial's key and the code
    stamp (``CodeState.stamp``); ``load()`` returns the dict last saved, or None when there is
    none or it cannot be resumed (unreadable, another key, code that may give another result:
    ``dopt.provenance.reuse_problem``; logged and moved aside, never deleted). ``root`` is the
    repository asked (default: this checkout). Picklable: a process pool's workers get it with
    their trial (and the code state its sweep saw).
    """

    def __init__(self, out_dir: Path | str, key: str, root: Path | str | None = None,
                 state: CodeState | None = None):
        Trial(key, {})                                   # the key's checks
        self.key = key
        self.path = Path(out_dir) / "trials" / CHECKPOINT_DIR / f"{key}.json"
        self.root = None if root is None else str(root)
        self._state = state

    def __repr__(self) -> str:
        return f"Checkpoint({str(self.path)!r})"

    @property
    def state(self) -> CodeState:
        if self._state is None:
            self._state = current_code(self.root)
        return self._state

    def save(self, progress: dict) -> None:
        _write_json_atomic(self.path, {"key": self.key, "code": self.state.stamp(),
                                       "progress": progress})

    def load(self) -> dict | None:
        progress, problem, folder = self._read()
        if problem is None:
            return progress
        where = _move_aside(self.path, folder)
        log.warning("checkpoint %s is not resumed (%s): %s", self.path, problem,
                    f"moved to {where}" if where else "it could not be moved aside")
        return None

    def peek(self) -> dict | None:
        """The progress ``load`` would resume, or None; reads only (moves and logs nothing)."""
        return self._read()[0]

    def _read(self) -> tuple[dict | None, str | None, str | None]:
        """(progress, None, None) of a resumable file, else (None, what is wrong, the folder
        it belongs in); (None, None, None) when there is none."""
        if not self.path.is_file():
            return None, None, None
        try:
            rec = json.loads(self.path.read_text())
            key, code, progress = rec["key"], rec["code"], rec["progress"]
        except (OSError, ValueError, TypeError, KeyError) as e:
            return None, f"not a checkpoint ({type(e).__name__}: {e})", CORRUPT_DIR
        if key != self.key:
            return None, f"the checkpoint of {key!r}", CORRUPT_DIR
        if not isinstance(progress, dict):
            return None, "its progress is not an object", CORRUPT_DIR
        problem = reuse_problem(code, self.state, self.root)
        if problem is not None:
            return None, problem, OUTDATED_DIR
        return progress, None, None

    def clear(self) -> None:
        """Delete the file (the trial's record is written)."""
        try:
            self.path.unlink()
        except FileNotFoundError:
            pass


def takes_checkpoint(fn: Callable) -> bool:
    """Whether the trial function ``fn`` has a ``checkpoint`` parameter."""
    try:
        return "checkpoint" in inspect.signature(fn).parameters
    except (TypeError, ValueError):             # no signature (a builtin): it has none
        return False


def check_record(path: Path | str) -> tuple[dict | None, str | None]:
    """(record, None) if the file at ``path`` is a trial record, else (None, what is wrong)."""
    path = Path(path)
    try:
        rec = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError) as e:
        return None, f"unreadable ({type(e).__name__}: {e})"
    except ValueError as e:
        return None, f"not valid JSON, truncated? ({e})"
    if not isinstance(rec, dict):
        return None, f"not a trial record (a JSON {type(rec).__name__}, not an object)"
    missing = [k for k in RECORD_FIELDS if k not in rec]
    if missing:
        return None, f"not a trial record (no {', '.join(repr(k) for k in missing)})"
    if rec["key"] != path.stem:
        return None, f"its key {rec['key']!r} is not its file name"
    if not isinstance(rec["params"], dict):
        return None, "its params are not an object"
    code = rec.get("code")
    if code is not None and not (isinstance(code, dict) and "version" in code):
        return None, f"its code version {code!r} is not {{\"version\", \"commit\"}}"
    return rec, None


def check_trial_files(out_dir: Path | str) -> tuple[dict, dict]:
    """({key: record} of the valid trial files under OUT/trials, {file name: reason} of the
    others, each moved to OUT/trials/corrupt/ with a logged warning). Hidden files (the
    temporary files of writes that were killed) are left alone."""
    folder = Path(out_dir) / "trials"
    if not folder.is_dir():
        return {}, {}
    records, corrupt = {}, {}
    for path in sorted(folder.glob("*.json")):
        if path.name.startswith(".") or not path.is_file():
            continue
        rec, problem = check_record(path)
        if rec is not None:
            records[rec["key"]] = rec
            continue
        corrupt[path.name] = problem
        where = _move_aside(path, CORRUPT_DIR)
        log.warning("trial file %s is not used (%s): %s", path, problem,
                    f"moved to {where}" if where else "it could not be moved aside")
    return records, corrupt


def is_finished(out_dir: Path | str, key: str, *, root: Path | str | None = None,
                reuse: str = "same-code") -> bool:
    """Whether ``run_sweep`` (not fresh, same ``reuse`` and ``root``) would skip trial
    ``key``: its file under OUT/trials is a valid record that may stand for this code (the
    code state this process last saw, ``current_code``). Reads only."""
    _check_reuse(reuse)
    rec, _ = check_record(trial_path(out_dir, key))
    if rec is None:
        return False
    return reuse == "any" or reuse_problem(rec.get("code"), current_code(root), root) is None


def load_finished(out_dir: Path | str) -> dict:
    """{key: record} of every valid trial file under OUT/trials (others are moved aside:
    ``check_trial_files``)."""
    return check_trial_files(out_dir)[0]


def _check_reuse(reuse) -> None:
    if reuse not in REUSE_MODES:
        raise ValueError(f"reuse must be one of {', '.join(REUSE_MODES)}, got {reuse!r}")


def _sort_stored(trials, out_dir, state, *, fresh, reuse, root) -> tuple[dict, dict, dict, dict]:
    """({key: reused record}, {key: why recomputed}, {file name: why corrupt}, {key: why it
    was reused across a code change}) of the stored trial files; the files of the trials to
    recompute are moved to OUT/trials/outdated/."""
    done, corrupt = check_trial_files(out_dir)
    recomputed, across = {}, {}
    for t in trials:
        if f"{t.key}.json" in corrupt:
            recomputed[t.key] = f"corrupt trial file: {corrupt[f'{t.key}.json']}"
        rec = done.get(t.key)
        if rec is None:
            continue
        reason = "fresh sweep" if fresh else reuse_problem(rec.get("code"), state, root)
        if reason is None:
            continue
        if reuse == "any" and not fresh:
            across[t.key] = reason
            log.warning("trial %s is reused deliberately (reuse='any'): %s", t.key, reason)
            continue
        recomputed[t.key] = reason
        del done[t.key]
        where = _move_aside(trial_path(out_dir, t.key), OUTDATED_DIR)
        log.log(logging.INFO if fresh else logging.WARNING, "trial %s is recomputed: %s (old "
                "file moved to %s)", t.key, reason, where)
    return done, recomputed, corrupt, across


def run_sweep(fn: Callable[[dict], dict], trials: Sequence[Trial], out_dir: Path | str, *,
              workers: int = 1, ray_address: str | None = None,
              progress: Callable[[str, dict | None], None] | None = None,
              fresh: bool = False, reuse: str = "same-code", record: bool = False,
              root: Path | str | None = None) -> SweepResult:
    """Run the trials not yet finished under ``out_dir``.

    Args:
        fn: module-level function params -> JSON-able dict (picklable by reference); with a
            ``checkpoint`` parameter it is called as ``fn(params, checkpoint=Checkpoint)``.
        trials: the sweep; keys must be unique.
        out_dir: results folder; OUT/trials/<key>.json per finished trial.
        workers: processes of the local pool (1: run inline in this process).
        ray_address: run on Ray instead ("local" for a local instance).
        progress: called with (key, record or None on failure) as each trial ends.
        fresh: recompute every trial (the old files are moved to OUT/trials/outdated/, the
            checkpoints of unfinished trials to OUT/trials/checkpoints/outdated/).
        reuse: "same-code" (git's rule, the module's docstring) or "any" (every valid record,
            listed in ``SweepResult.reused_across``).
        record: the trials are recorded: refused from a dirty tree (as for docs/results/).
        root: the repository whose code runs (default: this checkout).

    Raises:
        RuntimeError: a recording (``record``, or ``out_dir`` inside docs/results/) from a
            dirty tree or outside git; nothing is run or moved.

    A trial whose file is corrupt, or cannot stand for this code, is recomputed
    (``SweepResult.recomputed``); a trial that raises, or returns something that is not
    JSON-able, is a failure (``SweepResult.failed``), never a result.
    """
    keys = [t.key for t in trials]
    if len(set(keys)) != len(keys):
        raise ValueError("trial keys must be unique")
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    _check_reuse(reuse)
    state = current_code(root, refresh=True)
    refusal = record_refusal(out_dir, state, record, root)
    if refusal is not None:
        raise RuntimeError(refusal)
    (Path(out_dir) / "trials").mkdir(parents=True, exist_ok=True)
    done, recomputed, corrupt, across = _sort_stored(trials, out_dir, state, fresh=fresh,
                                                     reuse=reuse, root=root)
    _DELIBERATE.update(across)
    todo = [t for t in trials if t.key not in done]
    skipped = [t.key for t in trials if t.key in done]
    checkpoints = {t.key: Checkpoint(out_dir, t.key, root, state) for t in todo}
    if fresh:
        for c in checkpoints.values():
            if c.path.exists():
                log.info("trial %s starts afresh (its checkpoint moved to %s)", c.key,
                         _move_aside(c.path, OUTDATED_DIR))
    log.info("sweep: %d trials, %d already finished, %d to run (%d recomputed, %d reused "
             "across a code change)", len(trials), len(skipped), len(todo), len(recomputed),
             len(across))
    records = {k: done[k] for k in skipped}
    failed = _execute(fn, todo, out_dir, state.stamp(), checkpoints, records, progress,
                      workers=workers, ray_address=ray_address)
    commits = Counter(str((r.get("code") or {}).get("commit") or "unknown")
                      for r in records.values())
    return SweepResult(records, [t.key for t in todo if t.key not in failed], skipped, failed,
                       dict(commits), recomputed, corrupt, across)


def _execute(fn, todo, out_dir, code, checkpoints, records, progress, *, workers,
             ray_address) -> dict:
    """Run ``todo`` (inline, on a pool or on Ray), write each record stamped ``code`` into
    ``records`` and its file; returns {key: error} of the failures."""
    failed: dict = {}
    kwargs = ((lambda t: {"checkpoint": checkpoints[t.key]}) if takes_checkpoint(fn)
              else (lambda t: {}))

    def finish(trial: Trial, result=None, error: BaseException | None = None):
        rec = None
        if error is None:
            rec = {"key": trial.key, "params": trial.params, "result": result, "code": code}
            try:
                _write_json_atomic(trial_path(out_dir, trial.key), rec)
            except (TypeError, ValueError) as e:        # not JSON-able: a failure, not a result
                error, rec = TypeError(f"its result is not JSON-able ({e})"), None
            else:
                checkpoints[trial.key].clear()
        if error is not None:
            failed[trial.key] = f"{type(error).__name__}: {error}"
            log.error("trial %s failed: %s", trial.key, failed[trial.key])
        else:
            records[trial.key] = rec
        if progress is not None:
            progress(trial.key, rec)

    if ray_address is not None:
        _run_ray(fn, todo, ray_address, finish, kwargs)
    elif workers == 1:
        for t in todo:
            try:
                result = fn(t.params, **kwargs(t))
            except Exception as e:  # recorded, the sweep goes on
                finish(t, error=e)
            else:
                finish(t, result)
    else:
        with ProcessPoolExecutor(workers, mp_context=get_context("spawn")) as pool:
            futures = {pool.submit(fn, t.params, **kwargs(t)): t for t in todo}
            for fut in as_completed(futures):
                err = fut.exception()
                finish(futures[fut], None if err else fut.result(), err)
    return failed


def _move_aside(path: Path, folder: str) -> Path | None:
    """Move ``path`` into ``folder`` next to it (a free name: <stem>.1.json, ...); None if it
    cannot be moved (it is then left where it is)."""
    dest_dir = path.parent / folder
    try:
        dest_dir.mkdir(exist_ok=True)
        dest = dest_dir / path.name
        n = 0
        while dest.exists():
            n += 1
            dest = dest_dir / f"{path.stem}.{n}{path.suffix}"
        os.replace(path, dest)
    except OSError as e:
        log.warning("could not move %s to %s/: %s", path, dest_dir, e)
        return None
    return dest


def _run_ray(fn, todo, address, finish, kwargs) -> None:
    import ray
    if not ray.is_initialized():
        if address == "local":
            ray.init(include_dashboard=False, log_to_driver=False)
        else:
            ray.init(address=address, log_to_driver=False)
    module = sys.modules[fn.__module__]
    if getattr(module, "__file__", None) and "site-packages" not in module.__file__:
        # the trial module lives in a script folder, not an installed package: ship it by value
        ray.cloudpickle.register_pickle_by_value(module)
    remote = ray.remote(fn)
    pending = {remote.remote(t.params, **kwargs(t)): t for t in todo}
    while pending:
        ready, _ = ray.wait(list(pending), num_returns=1)
        trial = pending.pop(ready[0])
        try:
            finish(trial, ray.get(ready[0]))
        except Exception as e:
            finish(trial, error=e)


def _write_json_atomic(path: Path, obj) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=".json")
    try:
        with os.fdopen(fd, "w") as f:
            json.dump(obj, f)
        os.replace(tmp, path)
    except BaseException:
        os.unlink(tmp)
        raise
