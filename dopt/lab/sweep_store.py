"""The files of a sweep (``dopt.lab.sweep``) under its folder OUT, and their checks when read.

- ``OUT/trials/<key>.json``: a finished trial's record {"key", "params", "result", "code"}
  (``check_record``: a file that is not one, or whose result does not fit the sweep's
  ``Schema`` (a key missing, a number that must be finite and is not), or whose params are
  another trial's (``Schema.params_problem``), is named in a logged warning, moved to
  ``OUT/trials/corrupt/`` with its reason beside it (``<stem>.reason.txt``) and recomputed);
- ``OUT/trials/pack.jsonl``: finished trials packed, one record a line, append-only
  (``dopt.lab.trialpack``; ``dopt.lab.sweep_pack.pack_trials`` appends the loose files to it), over
  the read-only ``pack.jsonl.gz`` of earlier packs; a loose file overrides the packed record of
  its key, and a packed record that does not fit stays in the pack and is recomputed;
- ``OUT/trials/checkpoints/<key>.json``: an unfinished trial's saved progress
  (``Checkpoint``; its progress is checked against the ``Schema`` too);
- ``OUT/trials/.progress/<key>.json``: how far a running trial has got (``Report``: what a
  progress bar of a process pool or of Ray shows between whole trials), deleted when it ends;
- ``OUT/.lock``: the process that runs a sweep on OUT, and its pool's workers (``OutLock``,
  ``dopt.lab.sweep_lock``, importable from here): a second one refuses.

Every file is written atomically and as strict JSON (``dopt.lab.jsonio``: no bare NaN).
Standard library only (with ``dopt.atomic``, ``dopt.lab.provenance``, ``dopt.lab.jsonio``,
``dopt.lab.sweep_lock`` and ``dopt.lab.trialpack``).
Packing itself (``pack_trials``, ``PackResult``) lives in ``dopt.lab.sweep_pack``, which imports
this module (``dopt.lab.sweep`` re-exports both).
"""

from __future__ import annotations

import json
import logging
import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from dopt import atomic
from dopt.lab import jsonio
from dopt.lab.provenance import COMMIT_ENV, CodeState, code_state, repo_root, reuse_problem
from dopt.lab.sweep_lock import FRESH_LOCK_S, LOCK_NAME, OutLock, SweepLockedError  # noqa: F401
from dopt.lab.trialpack import StoredTrial, loose_files, read_pack

log = logging.getLogger("dopt.lab.sweep")

#: folders under OUT/trials where unusable trial files are moved (never deleted)
CORRUPT_DIR, OUTDATED_DIR = "corrupt", "outdated"
#: folder under OUT/trials of the unfinished trials' saved progress
CHECKPOINT_DIR = "checkpoints"
#: folder under OUT/trials of the running trials' step counts (``Report``)
PROGRESS_DIR = ".progress"
#: the fields every trial record has
RECORD_FIELDS = ("key", "params", "result", "code")

#: {root: CodeState} this process last saw (run_sweep refreshes it; is_finished and
#: Checkpoint read it, so that asking about many trials asks git once)
_STATES: dict[str, CodeState] = {}


def current_code(root: Path | str | None = None, refresh: bool = False) -> CodeState:
    """The ``CodeState`` of ``root`` (default: this checkout) this process last saw; asked of
    git again when ``refresh`` (``run_sweep`` does, once per call) or never asked before."""
    where = str(repo_root(root))
    if refresh or where not in _STATES or os.environ.get(COMMIT_ENV):
        _STATES[where] = code_state(where)
    return _STATES[where]


@dataclass(frozen=True)
class Trial:
    """key: unique file-name stem; params: the JSON-able arguments of the trial function."""

    key: str
    params: dict

    def __post_init__(self):
        if not self.key or any(ch in self.key for ch in "/\\\0") or self.key.startswith("."):
            raise ValueError(f"trial key {self.key!r} is not a valid file name")


@dataclass(frozen=True)
class Schema:
    """What an experiment's stored files must hold, beyond the fields of every record: a
    record or checkpoint that does not is named, moved aside and recomputed (never reused,
    never passed to the summary or to the trial). Each experiment script passes its own.

    Attributes:
        result: keys every trial result holds.
        progress: keys every checkpoint's progress holds.
        check_result, check_progress: further checks (picklable functions: a checkpoint
            travels to the pool's workers with its schema): the problem in a few words, or
            None.
        wanted: keys this run needs that a sound record of the experiment may lack (a run
            that did not ask for them wrote it, e.g. an MPC trial without --keep-controls):
            such a record is not corrupt but outdated, moved to OUT/trials/outdated/ and
            recomputed (``dopt.lab.sweep``), even where the sweep reuses across code changes.
        finite: result keys whose value must be a finite number (an int or a float, not a
            bool; a NaN or an infinity is stored null with its reason and read back as
            itself): a record with another value there is corrupt.
        identity: what of a trial's params names the trial (a picklable function params ->
            a JSON-able value, compared as JSON reads it back: e.g. the key the params give,
            or ``dict`` for all of them; None: params are not compared, for a sweep whose
            params hold knobs of how it runs): a stored record or checkpoint whose params
            give another identity than those of the trial it is stored for is another
            trial's (a record of another goal copied under this trial's name) and is not used
            (``params_problem``). Fields that do not change a result (threads) are left out
            of it, so that a rerun with other threads reuses the trial. Every experiment of
            the project names one.
        aliases: the older names a trial of these params may be stored under (a picklable
            function params -> tuple of keys, tried in order; None: none): the names trials
            had before the one identity (``dopt.lab.identity``). A trial whose own key holds
            no usable record is taken from the first alias whose record's params are its
            (``params_problem``), reused as stored: its "key" still names its file, and no
            file is renamed or rewritten (``stored_record``, ``find_alias``).
    """

    result: tuple[str, ...] = ()
    progress: tuple[str, ...] = ()
    check_result: Callable[[dict], str | None] | None = None
    check_progress: Callable[[dict], str | None] | None = None
    wanted: tuple[str, ...] = ()
    finite: tuple[str, ...] = ()
    identity: Callable[[dict], object] | None = None
    aliases: Callable[[dict], tuple[str, ...]] | None = None

    def __post_init__(self):
        for name in ("result", "progress", "wanted", "finite"):
            keys = getattr(self, name)
            if isinstance(keys, str) or not all(isinstance(k, str) for k in keys):
                raise TypeError(f"Schema.{name} must be a tuple of key names, got {keys!r}")
            object.__setattr__(self, name, tuple(keys))
        for name in ("check_result", "check_progress", "identity", "aliases"):
            if getattr(self, name) is not None and not callable(getattr(self, name)):
                raise TypeError(f"Schema.{name} must be callable or None")

    def result_problem(self, result) -> str | None:
        """Why ``result`` is not a trial result of this experiment, or None."""
        return (_fields_problem(result, self.result, None, "result")
                or _finite_problem(result, self.finite)
                or (None if self.check_result is None else self.check_result(result)))

    def params_problem(self, stored, params: dict) -> str | None:
        """Why a record or checkpoint holding the params ``stored`` cannot stand for the trial
        of ``params`` (their ``identity`` differ, or ``stored`` cannot be read as this
        experiment's params), or None (always, without an ``identity``)."""
        if self.identity is None:
            return None
        try:
            theirs = self._identity(stored)
        except (KeyError, IndexError, TypeError, ValueError, AttributeError) as e:
            return (f"its params cannot be read as this experiment's ({type(e).__name__}: "
                    f"{e})")
        mine = self._identity(params)
        if theirs == mine:
            return None
        return (f"its params are another trial's "
                f"({_difference(json.loads(theirs), json.loads(mine), stored, params)})")

    def _identity(self, params) -> str:
        """The identity of ``params`` as canonical JSON text (tuples as lists, keys sorted)."""
        return json.dumps(self.identity(params), sort_keys=True, allow_nan=True, default=repr)

    def aliases_of(self, params: dict) -> tuple[str, ...]:
        """The older keys a trial of ``params`` may be stored under (``aliases``; () without
        one); TypeError unless the function gives a tuple or list of str."""
        if self.aliases is None:
            return ()
        keys = self.aliases(params)
        if not isinstance(keys, (tuple, list)) or not all(isinstance(k, str) for k in keys):
            raise TypeError(f"Schema.aliases must give a tuple of keys, got {keys!r}")
        return tuple(keys)

    def wanted_problem(self, result: dict) -> str | None:
        """Why the sound trial ``result`` cannot stand for this run (it lacks a ``wanted``
        key), or None."""
        missing = [k for k in self.wanted if k not in result]
        return (f"it lacks {', '.join(repr(k) for k in missing)} (written by a run that did "
                f"not ask for them)") if missing else None

    def progress_problem(self, progress) -> str | None:
        """Why ``progress`` is not a checkpoint of this experiment, or None."""
        return _fields_problem(progress, self.progress, self.check_progress, "progress")


#: the schema of a sweep that names none: any object
ANY = Schema()


def _fields_problem(value, keys, check, what: str) -> str | None:
    if not isinstance(value, dict):
        return f"its {what} is not an object (a JSON {type(value).__name__})"
    missing = [k for k in keys if k not in value]
    if missing:
        return (f"its {what} lacks {', '.join(repr(k) for k in missing)} (another "
                f"experiment's or an older format)")
    return None if check is None else check(value)


def _finite_problem(result: dict, keys: tuple[str, ...]) -> str | None:
    """Why a value of ``result`` under ``keys`` is not a finite number, or None."""
    for k in keys:
        v = result.get(k)
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            return (f"its result's {k!r} is not a number ({json.dumps(v, default=repr)[:60]}"
                    f"), where this experiment writes a finite one")
        if not math.isfinite(v):
            return (f"its result's {k!r} is {v}, not a finite number (a trial whose result "
                    f"cannot be summarised)")
    return None


def _difference(theirs, mine, stored, params) -> str:
    """A few words on how the identity ``theirs`` of a stored record (its params ``stored``)
    differs from ``mine`` (of the trial it is stored for, of ``params``): the differing
    fields (nested ones dotted, the first three), of the identities where they are objects,
    else of the params."""
    def flat(d, prefix="") -> dict:
        out = {}
        for k, v in d.items():
            out.update(flat(v, f"{prefix}{k}.") if isinstance(v, dict) and v else
                       {f"{prefix}{k}": v})
        return out

    def short(v) -> str:
        text = json.dumps(v, sort_keys=True, default=repr)
        return text if len(text) <= 60 else text[:57] + "..."
    head = ""
    if not (isinstance(theirs, dict) and isinstance(mine, dict)):
        head = f"it names {short(theirs)}, this trial {short(mine)}"
        theirs, mine = stored, json.loads(json.dumps(params, default=repr))
        if not (isinstance(theirs, dict) and isinstance(mine, dict)):
            return head
    a, b = flat(theirs), flat(mine)
    keys = sorted(k for k in a.keys() | b.keys() if a.get(k, ...) != b.get(k, ...))
    parts = [f"{k!r}: stored {short(a[k]) if k in a else '(none)'}, this trial's "
             f"{short(b[k]) if k in b else '(none)'}" for k in keys[:3]]
    tail = "; ".join(parts) + (f"; {len(keys) - 3} more" if len(keys) > 3 else "")
    return "; ".join(x for x in (head, tail) if x)


def trial_path(out_dir: Path | str, key: str) -> Path:
    """OUT/trials/<key>.json."""
    return Path(out_dir) / "trials" / f"{key}.json"


def read_json(path: Path) -> tuple[object, str | None]:
    """(the JSON of the file at ``path``, None) or (None, what is wrong). Files are written
    strict (``dopt.lab.jsonio``); one with a bare NaN, written before, is read as it was meant."""
    try:
        return jsonio.loads(Path(path).read_text(), strict_numbers=False), None
    except (OSError, UnicodeDecodeError) as e:
        return None, f"unreadable ({type(e).__name__}: {e})"
    except ValueError as e:
        return None, f"not valid JSON, truncated? ({e})"


def check_record(path: Path | str, schema: Schema = ANY) -> tuple[dict | None, str | None]:
    """(record, None) if the file at ``path`` is a trial record of ``schema``'s experiment,
    else (None, what is wrong)."""
    path = Path(path)
    rec, problem = read_json(path)
    if problem is not None:
        return None, problem
    return check_value(rec, path.stem, schema)


def check_value(rec, key: str, schema: Schema = ANY) -> tuple[dict | None, str | None]:
    """(rec, None) if the parsed JSON ``rec`` is the trial record of ``key`` for ``schema``'s
    experiment, else (None, what is wrong): ``check_record`` once the file is read."""
    if not isinstance(rec, dict):
        return None, f"not a trial record (a JSON {type(rec).__name__}, not an object)"
    missing = [k for k in RECORD_FIELDS if k not in rec]
    if set(missing) - {"code"}:
        return None, f"not a trial record (no {', '.join(repr(k) for k in missing)})"
    if rec["key"] != key:
        return None, f"its key {rec['key']!r} is not its file name"
    if not isinstance(rec["params"], dict):
        return None, "its params are not an object"
    if missing:
        return None, ("not a trial record of this format (no 'code' stamp: written before "
                      "records named the code that wrote them)")
    code = rec["code"]
    if not (isinstance(code, dict) and "version" in code):
        return None, f"its code version {code!r} is not {{\"version\", \"commit\"}}"
    return (None, problem) if (problem := schema.result_problem(rec["result"])) else (rec, None)


def check_packed(trial: StoredTrial, schema: Schema = ANY) -> tuple[dict | None, str | None]:
    """``check_record`` of a packed record (``dopt.lab.trialpack``); the problem names its line."""
    try:
        rec = jsonio.loads(trial.text, strict_numbers=False)
    except ValueError as e:
        rec, problem = None, f"not valid JSON ({e})"
    else:
        rec, problem = check_value(rec, trial.stem, schema)
    return rec, (None if problem is None
                 else f"packed in {trial.pack.name} line {trial.line}: {problem}")


def stored_record(out_dir: Path | str, key: str, schema: Schema = ANY,
                  params: dict | None = None) -> tuple[dict | None, str | None]:
    """(record, None) of trial ``key`` under OUT/trials as ``check_trial_files`` would take it
    (its loose file, else, when that is missing or not a record, its packed record), else
    (None, what is wrong, or None when there is none). With ``params`` (the trial's), a trial
    without a usable record of its own key is looked up under its ``schema.aliases`` too
    (the record of the first alias whose params are these, by ``Schema.params_problem``,
    returned as stored: its "key" is the alias). Reads only.

    Raises:
        dopt.lab.trialpack.PackError: the folder's pack cannot be read.
    """
    rec, problem = _stored_record(out_dir, key, schema)
    if rec is not None or params is None:
        return rec, problem
    for alias in schema.aliases_of(params):
        old, _ = _stored_record(out_dir, alias, schema)
        if old is not None and schema.params_problem(old["params"], params) is None:
            return old, None
    return None, problem


def find_alias(records: dict, params: dict, schema: Schema) -> str | None:
    """The first of ``schema.aliases_of(params)`` that ``records`` ({key: record}, as
    ``check_trial_files`` reads them) holds with these params (``Schema.params_problem``), or
    None: where the trial of ``params`` is stored when its own key holds nothing."""
    for alias in schema.aliases_of(params):
        rec = records.get(alias)
        if rec is not None and schema.params_problem(rec["params"], params) is None:
            return alias
    return None


def _stored_record(out_dir: Path | str, key: str, schema: Schema
                   ) -> tuple[dict | None, str | None]:
    """``stored_record`` of ``key`` alone (no alias)."""
    path = trial_path(out_dir, key)
    packed = read_pack(path.parent).get(key)        # first: a bad pack is named either way
    rec, problem = (check_record(path, schema) if path.is_file() else (None, None))
    if rec is not None:
        return rec, None
    if packed is None:
        return None, problem
    return check_packed(packed, schema)


def move_aside(path: Path, folder: str, reason: str | None = None) -> Path | None:
    """Move ``path`` into ``folder`` next to it (a free name: <stem>.1.json, ...) and, with
    ``reason``, write why beside it (``<its stem>.reason.txt``: the old path and the reason,
    one line); None if it cannot be moved (it is then left where it is)."""
    dest_dir = path.parent / folder
    try:
        dest_dir.mkdir(exist_ok=True)
        dest = dest_dir / path.name
        n = 0
        while dest.exists() or (reason is not None and reason_path(dest).exists()):
            n += 1
            dest = dest_dir / f"{path.stem}.{n}{path.suffix}"
        os.replace(path, dest)
    except OSError as e:
        log.warning("could not move %s to %s/: %s", path, dest_dir, e)
        return None
    if reason is not None:
        try:
            atomic.write_text(reason_path(dest), f"{path}: {reason}\n", fsync=False)
        except OSError as e:               # the log names the reason too
            log.warning("could not write why %s was moved aside: %s", dest, e)
    return dest


def reason_path(moved: Path) -> Path:
    """The file beside a file ``move_aside`` moved that says why: <stem>.reason.txt."""
    return moved.with_name(f"{moved.stem}.reason.txt")


def check_trial_files(out_dir: Path | str, schema: Schema = ANY) -> tuple[dict, dict]:
    """({key: record} of the valid finished trials under OUT/trials, loose or packed, {file
    name: reason} of the others). A loose file that is not used is moved to
    OUT/trials/corrupt/ (the packed record of its key, if any, is then taken in its place); a
    packed record that is not used stays in the pack (its trial is recomputed and the new
    record, written loose, overrides it); each is named in a logged warning. Hidden files
    (the temporary files of writes that were killed) are left alone.

    Raises:
        dopt.lab.trialpack.PackError: the folder's pack cannot be read (named with its line).
    """
    folder = Path(out_dir) / "trials"
    if not folder.is_dir():
        return {}, {}
    packed = read_pack(folder)
    loose = loose_files(folder)
    records, corrupt = {}, {}
    for key in sorted(set(loose) | set(packed), key=lambda k: f"{k}.json"):
        if key in loose:
            path = loose[key]
            rec, problem = check_record(path, schema)
            if rec is not None:
                records[rec["key"]] = rec
                continue
            corrupt[path.name] = problem
            where = move_aside(path, CORRUPT_DIR, problem)
            log.warning("trial file %s is not used (%s): %s", path, problem,
                        f"moved to {where}" if where else "it could not be moved aside")
        if key in packed:
            rec, problem = check_packed(packed[key], schema)
            if rec is not None:
                records[key] = rec
                continue
            corrupt.setdefault(f"{key}.json", problem)
            log.warning("trial %s is not used (%s): it stays in %s and the trial is "
                        "recomputed (its new record, written loose, overrides it)", key,
                        problem, packed[key].pack)
    return records, corrupt


class Checkpoint:
    """The saved progress of one unfinished trial, ``OUT/trials/checkpoints/<key>.json``.

    ``save(progress)`` writes the JSON-able dict atomically with the trial's key and the code
    stamp (``CodeState.stamp``); ``load()`` returns the dict last saved, or None when there is
    none or it cannot be resumed (unreadable, another key, progress that does not fit the
    sweep's ``schema``: moved to checkpoints/corrupt/; code that may give another result,
    ``dopt.lab.provenance.reuse_problem``: to checkpoints/outdated/; logged, never deleted).
    ``root`` is the repository asked (default: this checkout). ``params``: the params of
    the trial it is of (None: not known): saved with the progress, and a checkpoint whose
    saved params are another trial's (``Schema.params_problem``) is not resumed (moved to
    checkpoints/corrupt/). Picklable: a process pool's workers get it with their trial (and
    the code state its sweep saw).
    """

    def __init__(self, out_dir: Path | str, key: str, root: Path | str | None = None,
                 state: CodeState | None = None, schema: Schema = ANY,
                 params: dict | None = None):
        Trial(key, {})                                   # the key's checks
        if not isinstance(schema, Schema):
            raise TypeError(f"schema must be a dopt.lab.sweep.Schema, got {type(schema).__name__}")
        if params is not None and not isinstance(params, dict):
            raise TypeError(f"params must be a dict or None, got {type(params).__name__}")
        self.key, self.schema, self.params = key, schema, params
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
        """Write ``progress`` (a JSON-able dict) for a rerun to resume."""
        rec = {"key": self.key, "code": self.state.stamp(), "progress": progress}
        jsonio.write_atomic(self.path, rec if self.params is None
                            else {**rec, "params": self.params})

    def load(self) -> dict | None:
        """The progress to resume, or None (a bad file is logged and moved aside)."""
        progress, problem, folder = self._read()
        if problem is None:
            return progress
        where = move_aside(self.path, folder, problem if folder == CORRUPT_DIR else None)
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
        rec, problem = read_json(self.path)
        if problem is None and not (isinstance(rec, dict) and {"key", "code", "progress"} <=
                                    rec.keys()):
            problem = "not a checkpoint (not an object with 'key', 'code' and 'progress')"
        if problem is not None:
            return None, (problem if problem.startswith("not a checkpoint")
                          else f"not a checkpoint: {problem}"), CORRUPT_DIR
        if rec["key"] != self.key:
            return None, f"the checkpoint of {rec['key']!r}", CORRUPT_DIR
        if (problem := self.schema.progress_problem(rec["progress"])) is not None:
            return None, problem, CORRUPT_DIR
        if self.params is not None and "params" in rec and (
                problem := self.schema.params_problem(rec["params"], self.params)):
            return None, problem, CORRUPT_DIR
        problem = reuse_problem(rec["code"], self.state, self.root)
        if problem is not None:
            return None, problem, OUTDATED_DIR
        return rec["progress"], None, None

    def clear(self) -> None:
        """Delete the file (the trial's record is written)."""
        try:
            self.path.unlink()
        except FileNotFoundError:
            pass


class Report:
    """What a trial function with a ``report`` parameter is given: ``report(n=1)`` says it
    has done ``n`` more steps (CEM iterations, MPC steps: whatever its caller's bar counts).

    In the sweep's own process the count goes straight to the sweep's ``tick`` callback; in
    a pool's or Ray's worker (the object is pickled there) it is written, at most every
    ``interval`` seconds and once more when the trial returns, to
    ``OUT/trials/.progress/<key>.json``, which the sweep reads while it waits.
    """

    def __init__(self, out_dir: Path | str, key: str,
                 callback: Callable[[int], None] | None = None, interval: float = 0.5):
        self.key = key
        self.path = Path(out_dir) / "trials" / PROGRESS_DIR / f"{key}.json"
        self.callback, self.interval = callback, float(interval)
        self.done, self._written, self._last = 0, 0, 0.0

    def __getstate__(self) -> dict:
        return {**self.__dict__, "callback": None}      # a worker writes the file instead

    def __call__(self, n: int = 1) -> None:
        n = int(n)
        if n < 0:
            raise ValueError(f"report(n): n must be >= 0, got {n}")
        self.done += n
        if self.callback is not None:
            self.callback(n)
        elif time.monotonic() - self._last >= self.interval:
            self.flush()

    def flush(self) -> None:
        """Write the count now (a worker's last word before its trial returns)."""
        if self.callback is not None or self.done == self._written:
            return
        try:
            jsonio.write_atomic(self.path, {"key": self.key, "done": self.done}, fsync=False)
        except OSError as e:                 # a bar is not worth a trial
            log.debug("progress of %s not written: %s", self.key, e)
        self._written, self._last = self.done, time.monotonic()

    def read(self) -> int:
        """The count a worker last wrote (0 if none)."""
        rec, problem = read_json(self.path)
        ok = problem is None and isinstance(rec, dict) and isinstance(rec.get("done"), int)
        return rec["done"] if ok else 0

    def clear(self) -> None:
        try:
            self.path.unlink()
        except FileNotFoundError:
            pass


__all__ = ["ANY", "CHECKPOINT_DIR", "CORRUPT_DIR", "LOCK_NAME", "OUTDATED_DIR", "PROGRESS_DIR",
           "RECORD_FIELDS", "Checkpoint", "OutLock", "Report", "Schema",
           "SweepLockedError", "Trial", "check_packed", "check_record", "check_trial_files",
           "check_value", "current_code", "find_alias", "move_aside", "read_json", "reason_path",
           "stored_record", "trial_path"]
