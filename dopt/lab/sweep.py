"""Resumable trial sweeps on a local process pool or a Ray cluster.

A trial is a pure function of its parameters (a JSON-able dict) that builds everything it needs
and returns a JSON-able dict. Each finished trial is written at once to ``OUT/trials/<key>.json``
(atomically), so a killed sweep loses only the trials that were running, and a rerun skips every
trial whose file exists and may stand for this code. The same code runs inline (``workers=1``),
on a local process pool, or on Ray (``ray_address``: "local" starts a local instance, anything
else is passed to ``ray.init``), so a sweep of thousands of trials goes to many machines without
code changes.

**Packed trials.** A finished sweep's trials are packed into one file,
``OUT/trials/pack.jsonl`` (``pack_trials``; ``python -m dopt.lab.sweep pack [--repair] OUT
[OUT ...]``): one record a line, uncompressed and append-only (each pack appends the new
records, sorted by key, after the lines already there, and never rewrites one), so that
committing a re-packed sweep grows git's history by the delta of its new lines, not by the
whole file as a compressed pack did; each loose file is deleted once the pack reads back its
record. Everything below reads packed and loose trials alike (``dopt.lab.trialpack``, the one
reader), and for one key a later source overrides an earlier one: the read-only
``pack.jsonl.gz`` of earlier packs (never rewritten), then ``pack.jsonl`` (a later line over an
earlier one), then the loose file (a trial recomputed since). A resume reuses a packed trial as
it would its file, and new trials are written loose. A pack that cannot be read (not gzip, a
line that is not a record with a key, a gzip pack's key twice) raises ``PackError``, a
ValueError naming the pack and the line, rather than having its trials recomputed; a
``pack.jsonl`` whose last line has no newline (a write or a copy cut short) raises
``CutPackError``, which ``pack --repair`` repairs (the whole lines kept, the cut one moved to
``OUT/trials/corrupt/``).

Trial files are checked when read: a file that is not a trial record (truncated or invalid
JSON, not an object, without "key", "params", "result" or the "code" stamp, or whose key is
not its file name), whose result does not fit the experiment's ``Schema`` (the keys its
summary reads: a result ``{}``, another experiment's, an older format; a number that must be
finite and is not), or whose params are another trial's (``Schema.identity``: a record of
another goal copied under this trial's name) is named in a logged warning and moved to
``OUT/trials/corrupt/`` with its reason beside it (``<stem>.reason.txt``; never deleted; a
packed record stays in the pack), and its trial is recomputed. A trial function's own result
that does not fit is a failure, never a record. Every file is strict JSON (``dopt.lab.jsonio``: a
NaN is written ``null`` with the reason beside it, and read back as NaN).

**Which code a record stands for.** Each record stores ``CodeState.stamp()`` under "code"
(dopt's version, the git commit, "-dirty" with a fingerprint for uncommitted code; see
``dopt.lab.provenance`` for the exact rules). A stored trial is reused when its key matches (the
key names its settings) and ``dopt.lab.provenance.reuse_problem`` finds nothing that can change its
result between its commit and HEAD (``git diff X HEAD -- dopt deformables planners experiments
pyproject.toml setup.py`` empty, X an ancestor of HEAD, the working tree clean there). Anything
else is recomputed and its old file moved to ``OUT/trials/outdated/`` (never deleted; a
packed record stays in its pack, shadowed by the new file, also once ``pack_trials`` appends it
there): a record of an unknown commit, of no commit ("no git"), of another branch, or marked
"-dirty" (except in the very tree it was written from, so that a killed run resumes before its
code is committed). The dopt version is recorded but decides nothing. Each record also names
the machine its trial ran on ("machine": ``dopt.lab.provenance.machine()`` of the worker; absent
from records written before records carried it): a CPU-time clock runs at its speed.
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
``OUT/trials/checkpoints/outdated/`` and its trial starts afresh; one whose progress does not
fit the ``Schema`` (another format) to ``OUT/trials/checkpoints/corrupt/``.

**One run per folder.** ``run_sweep`` holds ``OUT/.lock`` (``OutLock``: pid, host, command,
and the pids of its pool's workers) while it runs; a second process on the same OUT refuses
(``SweepLockedError``, one line naming the first) unless that process is dead and none of its
workers still runs (a stale lock is taken over).

**Processes that die.** The pool's workers end within a second of the sweep's process (a
``kill -9`` or the OOM killer's: the kernel kills them on Linux, a watch thread elsewhere) and
start no trial after it; a worker that dies while the sweep runs fails only the trial it was
running, as ``WorkerDied`` naming its pid and signal or exit code, and the other trials go on
(``dopt.lab.sweep_pool``).

**Interrupts.** SIGINT (Ctrl-C) or SIGTERM cancels the queued trials, stops the running ones
(each keeps the checkpoint of its last completed step, if it saved one), writes those that
finished and raises ``SweepInterrupted`` (a KeyboardInterrupt) within a few seconds, inline,
on the pool and on Ray alike (``dopt.lab.sweep_exec``, ``dopt.lab.sweep_pool``); its
``exit_code`` is
130 or 143 and its message says how to resume. The rerun gives exactly the result of an
uninterrupted sweep.

**Progress.** ``on_start`` is given the ``SweepPlan`` (trials reused, resumed from a checkpoint,
run from the start); ``progress`` is called as each trial ends; a trial function with a
``report`` parameter reports its steps (``Report``), which reach ``tick(key, n)`` from the pool's
and Ray's workers as well.
"""

from __future__ import annotations

import inspect
import logging
import signal
import sys
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from dopt.lab import jsonio
from dopt.lab.cli import ArgumentParser
from dopt.lab.provenance import CodeState, repo_root, reuse_problem
from dopt.lab.sweep_exec import (
    Stopper,
    TrialInterrupted,
    _Progress,
    progress_reports,
    run_inline,
    run_ray,
)
from dopt.lab.sweep_pack import PackResult, pack_trials  # noqa: F401
from dopt.lab.sweep_pool import WorkerDied, run_pool  # noqa: F401
from dopt.lab.sweep_store import (  # noqa: F401  (the public names of dopt.lab.sweep)
    ANY,
    CHECKPOINT_DIR,
    CORRUPT_DIR,
    LOCK_NAME,
    OUTDATED_DIR,
    RECORD_FIELDS,
    Checkpoint,
    OutLock,
    Report,
    Schema,
    SweepLockedError,
    Trial,
    check_record,
    check_trial_files,
    current_code,
    find_alias,
    move_aside,
    stored_record,
    trial_path,
)
from dopt.lab.trialpack import GZIP_PACK_NAME, PACK_NAME, CutPackError, PackError  # noqa: F401

log = logging.getLogger(__name__)

#: run_sweep's reuse modes: git's rule, or every valid record (deliberately, listed)
REUSE_MODES = ("same-code", "any")
#: the folder, under a checkout's root, of the committed results
RESULTS_DIR = Path("docs") / "results"

#: {trial key: why it would have been recomputed} of the trials reused with reuse="any"
_DELIBERATE: dict[str, str] = {}


@dataclass(frozen=True)
class SweepResult:
    """The trials of one ``run_sweep`` call.

    Attributes:
        records: {key: {"key", "params", "result", "code"}} of every finished trial (old and
            new).
        ran: keys run to the end in this call; skipped: keys found finished and reused.
        failed: {key: "ErrorType: message"} of the trials that raised.
        commits: {commit: number of records} over ``records`` (their "code" "commit";
            "unknown" for records without one): more than one key means the results were
            written at several commits (reused because no result file changed in between, or
            deliberately: ``reused_across``).
        recomputed: {key: reason} of trials that had a file but were run again (fresh, written
            by code that may give another result, a corrupt file).
        corrupt: {file name: reason} of the stored trials not used in this call (a loose
            file is moved to OUT/trials/corrupt, a packed record stays in the pack).
        reused_across: {key: why it would have been recomputed} of the trials that
            ``reuse="any"`` reused across a code change.
        resumed: keys that started from a checkpoint.
        interrupted: {key: what happened} of the trials an interrupt stopped ("stopped ...")
            or kept from starting ("not started").
    """

    records: dict
    ran: list
    skipped: list
    failed: dict
    commits: dict = field(default_factory=dict)
    recomputed: dict = field(default_factory=dict)
    corrupt: dict = field(default_factory=dict)
    reused_across: dict = field(default_factory=dict)
    resumed: list = field(default_factory=list)
    interrupted: dict = field(default_factory=dict)

    def stored_key(self, key: str) -> str:
        """The name trial ``key``'s record is stored under (its file, its blow-up captures):
        ``key`` itself, or the older name it was found under (``Schema.aliases``)."""
        rec = self.records.get(key)
        return key if rec is None else rec["key"]

    def line(self) -> str:
        """One line: trials reused, resumed, run, failed (and interrupted)."""
        stopped = [k for k, v in self.interrupted.items() if not v.startswith("not started")]
        return (f"{len(self.skipped) + len(self.ran) + len(self.failed) + len(self.interrupted)}"
                f" trials: {len(self.skipped)} reused, {len(self.ran)} run to the end ("
                f"{len([k for k in self.resumed if k in self.ran])} of them resumed from a "
                f"checkpoint), {len(self.failed)} failed"
                + (f", {len(stopped)} stopped part-way, "
                   f"{len(self.interrupted) - len(stopped)} not started"
                   if self.interrupted else ""))


@dataclass(frozen=True)
class SweepPlan:
    """What a ``run_sweep`` call is about to do (``on_start`` gets it; it is logged).

    Attributes:
        reused: keys whose records stand (not run).
        resumed: keys to run from their checkpoints.
        fresh: keys to run from the start.
        recomputed: {key: why} of those to run although they had a file.
    """

    reused: list
    resumed: list
    fresh: list
    recomputed: dict

    def line(self) -> str:
        """"N trials: R reused, C resumed from a checkpoint, F run from the start"."""
        n = len(self.reused) + len(self.resumed) + len(self.fresh)
        return (f"{n} trials: {len(self.reused)} reused, {len(self.resumed)} resumed from a "
                f"checkpoint, {len(self.fresh)} run from the start"
                + (f" ({len(self.recomputed)} recomputed: their files were outdated or bad)"
                   if self.recomputed else ""))


class SweepInterrupted(KeyboardInterrupt):
    """``run_sweep`` was stopped by SIGINT or SIGTERM. ``signum``; ``exit_code`` (128 +
    signum: 130, 143); ``result``: the ``SweepResult`` so far (what finished is written); the
    message says what happened and that a rerun resumes."""

    def __init__(self, signum: int, result: SweepResult, out_dir: Path | str):
        self.signum, self.result, self.out_dir = signum, result, Path(out_dir)
        self.exit_code = 128 + int(signum)
        super().__init__(self._message())

    def _message(self) -> str:
        r = self.result
        stopped = [k for k, v in r.interrupted.items() if not v.startswith("not started")]
        saved = sum((self.out_dir / "trials" / CHECKPOINT_DIR / f"{k}.json").is_file()
                    for k in stopped)
        return (f"interrupted by {signal.Signals(self.signum).name}: {len(r.ran)} trials "
                f"finished in this run (written under {self.out_dir / 'trials'}), "
                f"{len(stopped)} stopped part-way ({saved} with a checkpoint of their last "
                f"completed step), {len(r.interrupted) - len(stopped)} not started; a rerun of "
                f"the same command reuses the finished trials and resumes the rest")

    def __str__(self) -> str:
        return self._message()


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


def takes_checkpoint(fn: Callable) -> bool:
    """Whether the trial function ``fn`` has a ``checkpoint`` parameter."""
    return _takes(fn, "checkpoint")


def takes_report(fn: Callable) -> bool:
    """Whether the trial function ``fn`` has a ``report`` parameter."""
    return _takes(fn, "report")


def _takes(fn: Callable, name: str) -> bool:
    try:
        return name in inspect.signature(fn).parameters
    except (TypeError, ValueError):             # no signature (a builtin): it has none
        return False


def is_finished(out_dir: Path | str, key: str, *, root: Path | str | None = None,
                reuse: str = "same-code", schema: Schema = ANY,
                params: dict | None = None) -> bool:
    """Whether ``run_sweep`` (not fresh, same ``reuse``, ``root`` and ``schema``) would skip
    trial ``key`` (of ``params``, when given: the stored params must be its, by
    ``Schema.params_problem``; with params, a record under one of its ``Schema.aliases``
    counts too): its file under OUT/trials, or else its packed record, is a valid record
    that may stand for this code (the code state this process last saw, ``current_code``).
    Reads only (PackError: the pack cannot be read)."""
    _check_reuse(reuse)
    rec, _ = stored_record(out_dir, key, schema, params)
    if rec is None or schema.wanted_problem(rec["result"]):
        return False
    if params is not None and schema.params_problem(rec["params"], params):
        return False
    return reuse == "any" or reuse_problem(rec.get("code"), current_code(root), root) is None


def load_finished(out_dir: Path | str, schema: Schema = ANY) -> dict:
    """{key: record} of every valid finished trial under OUT/trials, loose or packed (bad
    loose files are moved aside: ``check_trial_files``)."""
    return check_trial_files(out_dir, schema)[0]


def _check_reuse(reuse) -> None:
    if reuse not in REUSE_MODES:
        raise ValueError(f"reuse must be one of {', '.join(REUSE_MODES)}, got {reuse!r}")


def _sort_stored(trials, out_dir, state, *, fresh, reuse, root, schema
                 ) -> tuple[dict, dict, dict, dict]:
    """({key: reused record}, {key: why recomputed}, {file name: why corrupt}, {key: why it
    was reused across a code change}) of the stored trial files; a trial without a record of
    its own key takes the one stored under an alias (``Schema.aliases``, as stored); the
    loose files of the trials to recompute are moved to OUT/trials/outdated/ (a record under
    an alias stays where it is: the new record does not overwrite it)."""
    done, corrupt = check_trial_files(out_dir, schema)
    recomputed, across = {}, {}
    for t in trials:
        if t.key in done:
            _check_params(out_dir, t, done, corrupt, schema)
        if f"{t.key}.json" in corrupt and t.key not in done:
            recomputed[t.key] = f"corrupt trial file: {corrupt[f'{t.key}.json']}"
        if t.key not in done and (alias := find_alias(done, t.params, schema)) is not None:
            done[t.key] = done[alias]
            log.info("trial %s is stored under its older name %s", t.key, alias)
        rec = done.get(t.key)
        if rec is None:
            continue
        lacks = schema.wanted_problem(rec["result"])
        reason = ("fresh sweep" if fresh else lacks
                  or reuse_problem(rec.get("code"), state, root))
        if reason is None:
            continue
        if reuse == "any" and not fresh and lacks is None:
            across[t.key] = reason
            log.warning("trial %s is reused deliberately (reuse='any'): %s", t.key, reason)
            continue
        recomputed[t.key] = reason
        del done[t.key]
        path = trial_path(out_dir, rec["key"])
        old = (f"its record under its older name {rec['key']} stays as it is"
               if rec["key"] != t.key else
               f"old file moved to {move_aside(path, OUTDATED_DIR)}" if path.is_file() else
               "its packed record stays in its pack, overridden by the new file")
        log.log(logging.INFO if fresh else logging.WARNING, "trial %s is recomputed: %s (%s)",
                t.key, reason, old)
    return done, recomputed, corrupt, across


def _check_params(out_dir, trial: Trial, done: dict, corrupt: dict, schema: Schema) -> None:
    """Take the stored record of ``trial`` out of ``done`` into ``corrupt`` when its params
    are another trial's (``Schema.params_problem``): a loose file is moved to
    OUT/trials/corrupt/ with the reason, a packed record stays in the pack (its trial's new
    record, written loose, overrides it); logged either way."""
    problem = schema.params_problem(done[trial.key]["params"], trial.params)
    if problem is None:
        return
    del done[trial.key]
    corrupt[f"{trial.key}.json"] = problem
    path = trial_path(out_dir, trial.key)
    where = (f"moved to {move_aside(path, CORRUPT_DIR, problem)}" if path.is_file() else
             f"its packed record stays in trials/{PACK_NAME}, overridden by the new file")
    log.warning("trial file %s is not used (%s): %s", path, problem, where)


def _check_args(fn, trials, workers, reuse, schema, callbacks: dict) -> None:
    keys = [t.key for t in trials]
    if len(set(keys)) != len(keys):
        raise ValueError("trial keys must be unique")
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    _check_reuse(reuse)
    if not isinstance(schema, Schema):
        raise TypeError(f"schema must be a dopt.lab.sweep.Schema, got {type(schema).__name__}")
    for name, f in {"fn": fn, **callbacks}.items():
        if f is not None and not callable(f):
            raise TypeError(f"{name} must be callable or None, got {f!r}")


def run_sweep(fn: Callable[[dict], dict], trials: Sequence[Trial], out_dir: Path | str, *,
              workers: int = 1, ray_address: str | None = None,
              progress: Callable[[str, dict | None], None] | None = None,
              tick: Callable[[str, int], None] | None = None,
              on_start: Callable[[SweepPlan], None] | None = None, schema: Schema = ANY,
              fresh: bool = False, reuse: str = "same-code", record: bool = False,
              root: Path | str | None = None) -> SweepResult:
    """Run the trials not yet finished under ``out_dir``.

    Args:
        fn: module-level function params -> JSON-able dict (picklable by reference); with a
            ``checkpoint`` parameter it is called with ``checkpoint=Checkpoint``, with a
            ``report`` parameter with ``report=Report``.
        trials: the sweep; keys must be unique.
        out_dir: results folder; OUT/trials/<key>.json per finished trial.
        workers: processes of the local pool (1: run inline in this process).
        ray_address: run on Ray instead ("local" for a local instance).
        progress: called with (key, record or None on failure) as each trial ends (not for
            the trials an interrupt stopped).
        tick: called with (key, n) as a running trial reports n more steps.
        on_start: called with the ``SweepPlan`` before the first trial starts.
        schema: what the experiment's results and checkpoints hold (``Schema``).
        fresh: recompute every trial (the old files are moved to OUT/trials/outdated/, the
            checkpoints of unfinished trials to OUT/trials/checkpoints/outdated/).
        reuse: "same-code" (git's rule, the module's docstring) or "any" (every valid record,
            listed in ``SweepResult.reused_across``).
        record: the trials are recorded: refused from a dirty tree (as for docs/results/).
        root: the repository whose code runs (default: this checkout).

    Raises:
        RuntimeError: a recording (``record``, or ``out_dir`` inside docs/results/) from a
            dirty tree or outside git; nothing is run or moved.
        SweepLockedError: another live process runs a sweep on ``out_dir``.
        SweepInterrupted: SIGINT or SIGTERM (what finished is written).

    A trial whose file is corrupt, or cannot stand for this code, is recomputed
    (``SweepResult.recomputed``); a trial that raises, or returns something that is not
    JSON-able or does not fit ``schema``, is a failure (``SweepResult.failed``), never a
    result.
    """
    _check_args(fn, trials, workers, reuse, schema,
                {"progress": progress, "tick": tick, "on_start": on_start})
    state = current_code(root, refresh=True)
    refusal = record_refusal(out_dir, state, record, root)
    if refusal is not None:
        raise RuntimeError(refusal)
    with OutLock(out_dir):
        return _run_locked(fn, trials, out_dir, state, workers=workers,
                           ray_address=ray_address, progress=progress, tick=tick,
                           on_start=on_start, schema=schema, fresh=fresh, reuse=reuse,
                           root=root)


def _run_locked(fn, trials, out_dir, state, *, workers, ray_address, progress, tick, on_start,
                schema, fresh, reuse, root) -> SweepResult:
    """``run_sweep`` once its checks passed and it holds the folder's lock."""
    (Path(out_dir) / "trials").mkdir(parents=True, exist_ok=True)
    done, recomputed, corrupt, across = _sort_stored(trials, out_dir, state, fresh=fresh,
                                                     reuse=reuse, root=root, schema=schema)
    _DELIBERATE.update(across)
    todo = [t for t in trials if t.key not in done]
    skipped = [t.key for t in trials if t.key in done]
    checkpoints = {t.key: checkpoint_of(out_dir, t, schema, root, state) for t in todo}
    if fresh:
        for c in checkpoints.values():
            if c.path.exists():
                log.info("trial %s starts afresh (its checkpoint moved to %s)", c.key,
                         move_aside(c.path, OUTDATED_DIR))
    uses_checkpoint = takes_checkpoint(fn)
    resumed = [k for k, c in checkpoints.items() if uses_checkpoint and c.peek() is not None]
    plan = SweepPlan(skipped, resumed, [t.key for t in todo if t.key not in resumed],
                     recomputed)
    log.info("sweep %s: %s (%d reused across a code change)", out_dir, plan.line(),
             len(across))
    if on_start is not None:
        on_start(plan)
    records = {k: done[k] for k in skipped}
    failed, interrupted, stop = _execute(fn, todo, out_dir, state.stamp(), checkpoints,
                                         records, progress, tick, schema, workers=workers,
                                         ray_address=ray_address)
    commits = Counter(str((r.get("code") or {}).get("commit") or "unknown")
                      for r in records.values())
    result = SweepResult(records, [t.key for t in todo if t.key in records], skipped, failed,
                         dict(commits), recomputed, corrupt, across, resumed, interrupted)
    if stop.signum is not None:
        raise SweepInterrupted(stop.signum, result, out_dir)
    return result


def checkpoint_of(out_dir: Path | str, trial: Trial, schema: Schema = ANY,
                  root: Path | str | None = None, state: CodeState | None = None
                  ) -> Checkpoint:
    """The ``Checkpoint`` of ``trial``: of its own key, or, while that has no file, of the
    first alias (``Schema.aliases``) that has one (a trial saved before its name changed
    resumes, and its checkpoint is deleted once its record is written under its key)."""
    own = Checkpoint(out_dir, trial.key, root, state, schema, trial.params)
    if own.path.is_file():
        return own
    for alias in schema.aliases_of(trial.params):
        old = Checkpoint(out_dir, alias, root, state, schema, trial.params)
        if old.path.is_file():
            return old
    return own


def _execute(fn, todo, out_dir, code, checkpoints, records, progress, tick, schema, *,
             workers, ray_address) -> tuple[dict, dict, Stopper]:
    """Run ``todo`` (inline, on a pool or on Ray), write each record stamped ``code`` into
    ``records`` and its file; returns ({key: error} of the failures, {key: what happened} of
    the trials an interrupt stopped, the ``Stopper`` that watched for it)."""
    failed: dict = {}
    interrupted: dict = {}
    reports = (progress_reports(out_dir, [t.key for t in todo], tick) if takes_report(fn)
               else {})

    def kwargs_of(t: Trial) -> dict:
        out = {"checkpoint": checkpoints[t.key]} if takes_checkpoint(fn) else {}
        return {**out, "report": reports[t.key]} if reports else out

    def finish(trial: Trial, result=None, error: BaseException | None = None,
               machine: dict | None = None):
        if isinstance(error, TrialInterrupted):
            interrupted[trial.key] = str(error)
            log.info("trial %s: %s", trial.key, error)
            return
        rec = None
        if error is None and (problem := schema.result_problem(result)) is not None:
            error = ValueError(f"its result does not fit the experiment's schema: {problem}")
        if error is None:
            rec = {"key": trial.key, "params": trial.params, "result": result, "code": code,
                   "machine": machine}
            try:
                jsonio.write_atomic(trial_path(out_dir, trial.key), rec)
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

    stop = Stopper()
    watch = _Progress(reports, tick)
    if ray_address is not None:
        run_ray(fn, todo, ray_address, kwargs_of, finish, stop, watch)
    elif workers == 1:
        run_inline(fn, todo, kwargs_of, finish, stop)
    else:
        run_pool(fn, todo, kwargs_of, finish, stop, workers, watch,
                 on_workers=OutLock(out_dir).note_workers)
    for r in reports.values():
        r.clear()
    return failed, interrupted, stop


# ----------------------------------------------------------------------- command line
def main(argv=None) -> int:
    """``python -m dopt.lab.sweep pack [--repair] OUT [OUT ...]``: pack each finished sweep's loose
    trial files (``pack_trials``), one line per folder; exit 1 when a file was left loose."""
    from dopt.lab.cli import EPILOG, existing_dir, guarded

    @guarded("python -m dopt.lab.sweep")
    def run(argv) -> int:
        p = ArgumentParser(
            prog="python -m dopt.lab.sweep", epilog=EPILOG,
            description="Tools of the resumable sweeps' folders.")
        sub = p.add_subparsers(dest="command", required=True)
        pk = sub.add_parser(
            "pack", epilog=EPILOG,
            help="pack a finished sweep's trial files into OUT/trials/" + PACK_NAME,
            description="Append each OUT/trials/*.json to OUT/trials/" + PACK_NAME + " (one "
                        "record a line, never rewriting a line; a sweep and the report read it "
                        "as they read the files, as they read an earlier " + GZIP_PACK_NAME +
                        ", which is left as it is) and delete each file once its line reads "
                        "back the same.")
        pk.add_argument("out", nargs="+", type=existing_dir,
                        help="a sweep's folder (holding trials/)")
        pk.add_argument("--repair", action="store_true",
                        help="first repair a " + PACK_NAME + " whose last line was cut (the "
                             "whole lines kept, the cut one moved to OUT/trials/corrupt/)")
        args = p.parse_args(argv)
        logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
        left = 0
        for out in args.out:
            r = pack_trials(out, repair=args.repair)
            print(r.line(), flush=True)
            left += len(r.left)
        return 1 if left else 0

    return run(argv)


if __name__ == "__main__":
    sys.exit(main())
