"""The local process pool of ``dopt.lab.sweep`` (``workers=N``, ``--workers N``): spawn processes
that each hold one pipe to the sweep and run one trial at a time, so that the sweep always
knows which worker runs which trial.

**A worker's death** (the OOM killer, ``kill -9`` of its pid, a crash in C code) fails the
trial it was running, named with the worker's pid and its signal or exit code
(``WorkerDied``; the trial's checkpoint, if it saved one, is kept for a rerun to resume); the
other workers' trials go on, and a fresh worker takes the dead one's place while trials are
queued. (The standard library's ProcessPoolExecutor, used before, killed the other workers
and failed every unfinished trial, queued ones included, as ``BrokenProcessPool``, naming
neither the worker nor the cause.)

**Workers end with their parent.** A worker exits as soon as the sweep's process is gone
(``watch_parent``): on Linux the kernel kills it (``prctl(PR_SET_PDEATHSIG, SIGKILL)``, set
before its first trial); everywhere a thread of the worker compares its parent pid with the
sweep's every ``WATCH_S`` and ends the process when they differ; and a worker starts no trial
once its parent is gone (its pipe ends too: the sweep is the only writer). A trial's
checkpoint is written atomically, so a worker killed anywhere leaves its last completed step.
(Before, the workers of a killed sweep ran on, started queued trials, then waited forever,
ignoring Ctrl-C and SIGTERM, beside the rerun that took the folder over.) The live workers'
pids are handed to ``on_workers`` (``dopt.lab.sweep`` notes them in the folder's lock,
``OutLock.note_workers``, so that a rerun does not take the folder over while they run).
PR_SET_PDEATHSIG fires when the thread that started the worker ends: ``run_pool`` starts
every worker from the thread it runs in, and ends them all before it returns.

**Interrupts** are as before (``dopt.lab.sweep_exec``): queued trials are not started, running
ones get SIGTERM (``TrialInterrupted`` inside them), those that end within ``GRACE_S`` are
written, the workers still running are then killed.

**Logging.** A worker's log records (warnings included, ``logging.captureWarnings``) travel
over its pipe, in order with its results, to this process's loggers.
"""

from __future__ import annotations

import ctypes
import logging
import logging.handlers
import os
import pickle
import queue
import signal
import sys
import threading
import time
from collections import deque
from collections.abc import Callable
from multiprocessing import connection, get_context, parent_process
from multiprocessing.reduction import ForkingPickler

from dopt.lab.sweep_exec import (
    GRACE_S,
    POLL_S,
    Stopper,
    TrialInterrupted,
    _Progress,
    _stopped,
    _worker_stop,
    call_trial,
)

log = logging.getLogger("dopt.lab.sweep")

#: seconds between two looks of a worker's watch thread at its parent
WATCH_S = 0.2
#: Linux's prctl option: the signal a process gets when its parent ends
PR_SET_PDEATHSIG = 1
#: the exit code of a worker that ended because its parent was gone
ORPHAN_EXIT = 70


class WorkerDied(RuntimeError):
    """The worker process running a trial died (killed by a signal or exited) before the
    trial ended; the message names its pid and cause."""


# ------------------------------------------------------------------------- worker side
def watch_parent(parent_pid: int, prctl: bool = True) -> None:
    """End this process as soon as process ``parent_pid``, its parent, is gone: on Linux
    (with ``prctl``) the kernel sends it SIGKILL; everywhere a daemon thread compares
    ``os.getppid()`` with ``parent_pid`` every ``WATCH_S`` (an orphan gets another parent)
    and calls ``os._exit(ORPHAN_EXIT)``. Exits at once if the parent is gone already."""
    if prctl and sys.platform.startswith("linux"):
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            if libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) != 0:
                log.debug("prctl(PR_SET_PDEATHSIG) failed: errno %d", ctypes.get_errno())
        except (OSError, AttributeError) as e:         # no libc prctl: the thread alone
            log.debug("prctl not available: %s", e)
    if not parent_alive(parent_pid):                   # it died before the watch began
        os._exit(ORPHAN_EXIT)
    threading.Thread(target=_watch, args=(parent_pid,), name="dopt-parent-watch",
                     daemon=True).start()


def parent_alive(parent_pid: int) -> bool:
    """Whether this process's parent is still process ``parent_pid`` (Windows, where an
    orphan keeps its parent pid: whether multiprocessing's parent process lives)."""
    if os.name == "nt":
        parent = parent_process()
        return parent is None or parent.is_alive()
    return os.getppid() == parent_pid


def _watch(parent_pid: int) -> None:
    while parent_alive(parent_pid):
        time.sleep(WATCH_S)
    os._exit(ORPHAN_EXIT)


class _Sender(threading.Thread):
    """Writes a worker's messages (log records, trial ends) to its pipe, in order, from one
    thread: a SIGTERM's ``TrialInterrupted`` raised in the worker's main thread can never cut
    a message in half."""

    def __init__(self, conn):
        super().__init__(name="dopt-worker-send", daemon=True)
        self.conn, self.messages = conn, queue.SimpleQueue()

    def run(self) -> None:
        while (msg := self.messages.get()) is not None:
            tag = msg[0][:1].encode()              # b"l": a log record, b"d": a trial's end
            try:
                data = tag + ForkingPickler.dumps(msg[1:])
            except Exception as e:                 # a result that cannot be pickled
                if msg[0] != "done":
                    continue
                data = tag + ForkingPickler.dumps((False, TypeError(
                    f"its result cannot be sent from the worker ({type(e).__name__}: {e})"),
                    None))
            try:
                self.conn.send_bytes(data)
            except OSError:                        # the sweep is gone
                return

    def put(self, msg) -> None:
        self.messages.put(msg)

    def close(self) -> None:
        self.messages.put(None)
        self.join(timeout=5)


class _PipeLogs(logging.handlers.QueueHandler):
    """A worker's log records, prepared to be pickled, to its ``_Sender``."""

    def __init__(self, sender: _Sender):
        super().__init__(None)
        self.sender = sender

    def enqueue(self, record) -> None:
        self.sender.put(("log", record))


def _worker_main(conn, parent_pid: int, level: int) -> None:
    """A pool worker: watches its parent, ignores SIGINT (a terminal's Ctrl-C reaches the
    whole process group: the sweep decides), stops its trial on SIGTERM, logs to the sweep;
    then runs the trials it is sent, one at a time, until it is sent None, its pipe closes
    or its parent is gone."""
    watch_parent(parent_pid)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _worker_stop)
    sender = _Sender(conn)
    sender.start()
    root = logging.getLogger()
    root.handlers[:] = [_PipeLogs(sender)]
    root.setLevel(level)
    logging.captureWarnings(True)
    while True:
        try:
            data = conn.recv_bytes()
        except (EOFError, OSError):
            break
        if not parent_alive(parent_pid):
            os._exit(ORPHAN_EXIT)
        try:
            task = pickle.loads(data)
        except BaseException as e:             # e.g. the trial's module cannot be imported
            sender.put(("done", False, _portable(e), None))
            continue
        if task is None:
            break
        try:
            result, where = call_trial(*task)
            sender.put(("done", True, result, where))
        except BaseException as e:             # the trial's error, or its interrupt
            sender.put(("done", False, _portable(e), None))
    sender.close()


def _portable(e: BaseException) -> BaseException:
    """``e`` if it survives pickling both ways, else a RuntimeError with its type and text."""
    try:
        pickle.loads(pickle.dumps(e))
        return e
    except Exception:
        return RuntimeError(f"{type(e).__name__}: {e}")


# ------------------------------------------------------------------------ sweep side
class _Worker:
    """One worker process: its process, this end of its pipe, the trial it runs (or None)."""

    def __init__(self, ctx, level: int):
        mine, theirs = ctx.Pipe()
        self.proc = ctx.Process(target=_worker_main, args=(theirs, os.getpid(), level),
                                name="dopt-sweep-worker")
        self.proc.start()
        theirs.close()
        self.conn, self.trial, self.eof = mine, None, False

    @property
    def pid(self) -> int:
        return self.proc.pid

    def send(self, msg) -> None:
        """Send ``msg`` (pickled first: a pickling error leaves the pipe as it was)."""
        self.conn.send_bytes(ForkingPickler.dumps(msg))

    def cause(self) -> str:
        """How the (dead) process ended: "killed by SIGKILL", "exited with exit code 3"."""
        self.proc.join(timeout=1)
        code = self.proc.exitcode
        if code is None:
            return "its pipe closed (the process is still being reaped)"
        if code < 0:
            try:
                name = signal.Signals(-code).name
            except ValueError:
                name = f"signal {-code}"
            return f"killed by {name}" + (" (the out-of-memory killer's signal, or kill -9)"
                                          if -code == signal.SIGKILL else "")
        return f"exited with exit code {code}"


class _Pool:
    """The workers of one ``run_pool``: starts them (and a fresh one for each that dies while
    trials are queued), hands them trials, reads what they send and ends them."""

    def __init__(self, size: int, fn: Callable, kwargs_of, finish, progress: _Progress,
                 on_workers: Callable[[list[int]], None] | None):
        self.ctx, self.size, self.fn = get_context("spawn"), size, fn
        self.kwargs_of, self.finish, self.progress = kwargs_of, finish, progress
        self.on_workers = on_workers
        self.level = logging.getLogger().getEffectiveLevel()
        self.workers: list[_Worker] = []
        self.started = 0
        self.stopping = False

    def busy(self) -> list[_Worker]:
        return [w for w in self.workers if w.trial is not None]

    def _noted(self) -> None:
        if self.on_workers is not None:
            self.on_workers(sorted(w.pid for w in self.workers))

    def hand_out(self, todo: deque) -> None:
        """Start workers up to the pool's size (never more than the trials queued and
        running need) and give each idle one the next queued trial."""
        spawned = False
        while todo and len(self.workers) < min(self.size, len(self.busy()) + len(todo)):
            self.workers.append(_Worker(self.ctx, self.level))
            self.started, spawned = self.started + 1, True
        if spawned:
            self._noted()
        for w in self.workers:
            while todo and w.trial is None and not w.eof:
                trial = todo.popleft()
                try:
                    w.send((self.fn, trial.params, self.kwargs_of(trial)))
                except OSError:              # the worker is dead: the trial goes to another
                    todo.appendleft(trial)
                    w.eof = True
                except Exception as e:       # its arguments cannot be pickled
                    self.finish(trial, error=e)
                else:
                    w.trial = trial

    def serve(self, timeout: float) -> None:
        """Wait up to ``timeout`` s for the workers; handle what they sent and their deaths."""
        waits = {w.proc.sentinel: w for w in self.workers}
        waits.update({w.conn: w for w in self.workers if not w.eof})
        ready = connection.wait(list(waits), timeout)
        for w in {id(waits[r]): waits[r] for r in ready}.values():
            self._read(w)
            if w.proc.sentinel in ready:
                self._died(w)

    def _read(self, w: _Worker) -> None:
        """Handle every message waiting in ``w``'s pipe (its first byte says what it is: a
        trial's end that cannot be unpickled here still ends the trial)."""
        while not w.eof:
            try:
                if not w.conn.poll():
                    return
                data = w.conn.recv_bytes()
            except (EOFError, OSError):
                w.eof = True
                return
            try:
                body = pickle.loads(data[1:])
            except Exception as e:
                body = (False, RuntimeError(f"what worker {w.pid} sent back cannot be read "
                                            f"here ({type(e).__name__}: {e})"), None)
                if data[:1] == b"l":
                    log.error("a log record of sweep worker %d: %s", w.pid, body[1])
                    continue
            if data[:1] == b"l":
                logger = logging.getLogger(body[0].name)
                if logger.isEnabledFor(body[0].levelno):
                    logger.handle(body[0])
            elif w.trial is not None:
                trial, w.trial = w.trial, None
                self.progress.end(trial.key)
                if body[0]:
                    self.finish(trial, body[1], machine=body[2])
                else:
                    self.finish(trial, error=body[1])

    def _died(self, w: _Worker) -> None:
        """``w``'s process ended: its trial (if any) fails naming it, or, while the sweep
        stops, counts as stopped."""
        self.workers.remove(w)
        cause = w.cause()
        w.conn.close()
        self._noted()
        if w.trial is None:
            if not self.stopping:
                log.warning("sweep worker %d ended between trials: %s", w.pid, cause)
            return
        trial, w.trial = w.trial, None
        kwargs = self.kwargs_of(trial)
        if self.stopping:                       # (progress read before its file is removed)
            stopped = _stopped(kwargs, f"its worker {cause}")
            self.progress.end(trial.key)
            self.finish(trial, error=stopped)
            return
        checkpoint = kwargs.get("checkpoint")
        kept = checkpoint is not None and checkpoint.path.is_file()
        self.progress.end(trial.key)
        self.finish(trial, error=WorkerDied(
            f"its worker process (pid {w.pid}) died while running it: {cause}; "
            + ("its checkpoint is kept: a rerun resumes it" if kept else
               "a rerun runs it again") + "; the other trials go on"))

    def stop(self, stop: Stopper) -> None:
        """Interrupt the running trials (SIGTERM to their workers), handle those that end
        within ``GRACE_S`` (or until a second signal); the rest count as stopped."""
        self.stopping = True
        for w in self.busy():
            try:
                os.kill(w.pid, signal.SIGTERM)
            except (ProcessLookupError, PermissionError):
                pass
        deadline = time.monotonic() + GRACE_S
        while self.busy() and time.monotonic() < deadline and not stop.hurry:
            self.serve(0.05)
        for w in self.busy():
            trial, w.trial = w.trial, None
            self.progress.end(trial.key)
            self.finish(trial, error=TrialInterrupted(
                f"stopped: its worker did not end within {GRACE_S:g} s and was killed"))

    def close(self, clean: bool) -> None:
        """End every worker: asked to (``clean``: the sweep is done) and given a few seconds,
        else killed at once."""
        for w in self.workers:
            try:
                if clean and not w.eof:
                    w.send(None)
                else:
                    w.proc.kill()
            except (OSError, ValueError):
                pass
        deadline = time.monotonic() + 5.0
        for w in self.workers:
            w.proc.join(timeout=max(0.0, deadline - time.monotonic()))
            if w.proc.exitcode is None:
                w.proc.kill()
                w.proc.join(timeout=5)
            w.conn.close()
        self.workers.clear()
        self._noted()


def run_pool(fn, todo, kwargs_of, finish, stop: Stopper, workers: int,
             progress: _Progress, on_workers: Callable[[list[int]], None] | None = None
             ) -> None:
    """The trials ``todo`` on a pool of ``workers`` spawn processes (the module docstring);
    ``finish(trial, result, machine=...)`` or ``finish(trial, error=...)`` as each ends;
    ``on_workers``: given the live workers' pids whenever they change."""
    pool = _Pool(workers, fn, kwargs_of, finish, progress, on_workers)
    queued = deque(todo)
    clean = False
    try:
        with stop:
            while (queued or pool.busy()) and stop.signum is None:
                pool.hand_out(queued)
                pool.serve(POLL_S)
                progress.poll([w.trial.key for w in pool.busy()])
            clean = not (queued or pool.busy())
            if not clean:
                while queued:
                    trial = queued.popleft()
                    progress.end(trial.key)
                    finish(trial, error=TrialInterrupted("not started", started=False))
                pool.stop(stop)
    finally:
        pool.close(clean)
