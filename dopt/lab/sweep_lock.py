"""``OUT/.lock``, the lock of a sweep's folder (``OutLock``): one process at a time runs
sweeps on OUT, and a rerun does not take the folder over while the workers of a dead sweep
still write there. Standard library only (with ``dopt.lab.jsonio``); importable from
``dopt.lab.sweep_store`` and ``dopt.lab.sweep``."""

from __future__ import annotations

import logging
import os
import socket
import sys
import time
from pathlib import Path

from dopt.lab import jsonio

log = logging.getLogger("dopt.lab.sweep")

#: the lock file of a sweep's folder, and how long (s) an unreadable one counts as being
#: written (older: garbage, taken over)
LOCK_NAME = ".lock"
FRESH_LOCK_S = 5.0
#: how long (s) taking over the lock of a dead sweep waits for its workers to end before it
#: refuses (they end within a second of their parent, ``dopt.lab.sweep_pool``)
WORKERS_WAIT_S = 5.0


def read_json(path: Path) -> tuple[object, str | None]:
    """(the JSON of the file at ``path``, None) or (None, what is wrong)."""
    try:
        return jsonio.loads(Path(path).read_text(), strict_numbers=False), None
    except (OSError, UnicodeDecodeError, ValueError) as e:
        return None, f"{type(e).__name__}: {e}"


class SweepLockedError(RuntimeError):
    """Another live process runs a sweep on the same folder."""


#: {lock file: how many times this process holds it}
_HELD: dict[str, int] = {}


class OutLock:
    """``OUT/.lock``: one process at a time runs sweeps on OUT. Holds {"pid", "host",
    "started", "command"} and, while a process pool runs the sweep's trials, "workers": their
    pids (``note_workers``). A lock of a dead process on this host is stale and taken over
    (logged), once none of its workers still runs (waited for up to ``WORKERS_WAIT_S``).
    Reentrant within a process (an experiment holds it, and so does each of its sweeps). Use
    as a context manager.

    Raises (on enter):
        SweepLockedError: a live process (or one on another host, which cannot be asked)
            holds it, or a dead one whose workers still run; the one-line message names it.
    """

    def __init__(self, out_dir: Path | str):
        self.path = Path(out_dir).absolute() / LOCK_NAME

    def __enter__(self) -> OutLock:
        self.acquire()
        return self

    def __exit__(self, *exc) -> None:
        self.release()

    def acquire(self) -> None:
        where = str(self.path)
        if _HELD.get(where):
            _HELD[where] += 1
            return
        self.path.parent.mkdir(parents=True, exist_ok=True)
        me = {"pid": os.getpid(), "host": socket.gethostname(),
              "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
              "command": " ".join(sys.argv)}
        for _ in range(3):
            try:
                fd = os.open(self.path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            except FileExistsError:
                holder = self._holder()
                if holder is None and _age(self.path) < FRESH_LOCK_S:
                    raise SweepLockedError(f"{self.path.parent} is being locked by another "
                                           f"process right now ({self.path})") from None
                if holder is not None and not _stale(holder):
                    raise SweepLockedError(_locked_message(self.path.parent, holder)) \
                        from None
                if holder is not None:
                    _wait_for_workers(self.path.parent, holder)
                log.warning("%s: taking over the stale lock of %s", self.path.parent,
                            _describe(holder) if holder else "an unreadable lock file")
                try:
                    self.path.unlink()
                except FileNotFoundError:
                    pass
                continue
            with os.fdopen(fd, "w") as f:
                f.write(jsonio.dumps(me))
            _HELD[where] = 1
            return
        raise SweepLockedError(f"{self.path.parent}: could not take its lock {self.path}")

    def release(self) -> None:
        where = str(self.path)
        if not _HELD.get(where):
            return
        _HELD[where] -= 1
        if _HELD[where]:
            return
        del _HELD[where]
        holder = self._holder()
        if holder is not None and holder.get("pid") == os.getpid():
            try:
                self.path.unlink()
            except FileNotFoundError:
                pass

    def note_workers(self, pids) -> None:
        """Record ``pids``, the live worker processes of this process's sweep, in the lock
        file (rewritten atomically), so that a rerun after this process died does not take
        the folder over while they run. Only while this process holds the lock."""
        if not _HELD.get(str(self.path)):
            return
        holder = self._holder()
        if holder is None or holder.get("pid") != os.getpid():
            return
        holder["workers"] = sorted(int(p) for p in pids)
        try:
            jsonio.write_atomic(self.path, holder, fsync=False)
        except OSError as e:
            log.warning("could not note the sweep's workers in its lock: %s", e)

    def _holder(self) -> dict | None:
        rec, problem = read_json(self.path)
        return rec if problem is None and isinstance(rec, dict) else None


def _stale(holder: dict) -> bool:
    """Whether the lock ``holder`` wrote is of a dead process (or of this one) on this host;
    a process on another host cannot be asked, so its lock is never stale here."""
    if holder.get("host") != socket.gethostname():
        return False
    pid = holder.get("pid")
    if not isinstance(pid, int) or pid <= 0 or pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    except PermissionError:                  # alive, another user's
        return False
    try:                                     # alive: the same program, or a reused pid?
        running = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
    except (OSError, UnicodeDecodeError):    # no /proc here: trust the pid
        return False
    return str(holder.get("command", "")) not in running


def _live_workers(holder: dict) -> list[int]:
    """The pids the lock ``holder`` names as its workers that still run as workers of a
    process pool (multiprocessing's command line: a reused pid, or a zombie, does not)."""
    live = []
    for pid in holder.get("workers") or []:
        if not isinstance(pid, int) or pid <= 0 or pid == os.getpid():
            continue
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            continue
        except PermissionError:
            pass
        try:
            running = Path(f"/proc/{pid}/cmdline").read_bytes()
        except OSError:                          # no /proc here: trust the pid
            running = b"multiprocessing" if not Path("/proc/self").exists() else b""
        if b"multiprocessing" in running:
            live.append(pid)
    return live


def _wait_for_workers(out: Path, holder: dict) -> None:
    """Wait up to ``WORKERS_WAIT_S`` for the workers of the dead lock ``holder`` to end.

    Raises:
        SweepLockedError: some still run (named, with the command that ends them).
    """
    deadline = time.monotonic() + WORKERS_WAIT_S
    while (live := _live_workers(holder)) and time.monotonic() < deadline:
        time.sleep(0.1)
    if live:
        pids = " ".join(str(p) for p in live)
        raise SweepLockedError(
            f"{out} was run by {_describe(holder)}, which has ended, but its worker "
            f"processes {pids} still run (still writing under {out}); wait for them to end "
            f"or stop them (kill {pids}), then rerun")


def _age(path: Path) -> float:
    try:
        return time.time() - path.stat().st_mtime
    except OSError:
        return float("inf")


def _describe(holder: dict) -> str:
    return (f"process {holder.get('pid')} on {holder.get('host')} since "
            f"{holder.get('started')} ({holder.get('command')})")


def _locked_message(out: Path, holder: dict) -> str:
    other = holder.get("host") != socket.gethostname()
    return (f"{out} is in use by {_describe(holder)}; wait for it to finish or use another "
            f"--out" + (f" (if it is no longer running on {holder.get('host')}, delete "
                        f"{out / LOCK_NAME})" if other else ""))
