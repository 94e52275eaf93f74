"""How ``dopt.lab.sweep`` runs its trials, inline or on Ray, and how it stops when asked to; the
local process pool, ``run_pool``, lives in ``dopt.lab.sweep_pool`` (with the pool workers' side:
they end with their parent, and one's death fails its own trial only).

**Interrupts.** While trials run, SIGINT (Ctrl-C) and SIGTERM are caught (when the sweep runs
in the main thread). Queued trials are cancelled; a running trial is interrupted
(``TrialInterrupted`` raised inside it: at once inline, by a SIGTERM to each pool worker, by
``ray.cancel`` on Ray, whose local processes are started with SIGINT not ignored so that it
can); trials that still end within ``GRACE_S`` are written, then the workers
that have not stopped are killed. A trial saves its checkpoint itself after each step it
completes (atomically: a write cut short leaves the previous file), so an interrupted trial
keeps the progress of its last completed step and a rerun resumes it exactly. Pool workers
ignore SIGINT (a terminal's Ctrl-C reaches the whole process group: only the sweep decides
what its workers do). A second signal skips the grace period.

**Logging.** A pool worker's log records (warnings included, ``logging.captureWarnings``) are
sent to the sweep's process and handled by its loggers, so a progress bar's logging redirect
covers them; Ray's workers log on their own (``log_to_driver=False``).

**Progress.** A trial function with a ``report`` parameter gets a ``dopt.lab.sweep_store.Report``;
the steps it reports from a worker are read back from their files every ``POLL_S`` and given
to the sweep's ``tick``.
"""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path

from dopt.lab.provenance import machine
from dopt.lab.sweep_store import PROGRESS_DIR, Report

log = logging.getLogger("dopt.lab.sweep")

#: seconds the running trials of an interrupted sweep get to end before their workers are
#: killed, and between two looks at the workers' progress files
GRACE_S = 2.5
POLL_S = 0.25
#: the signals that stop a sweep
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class TrialInterrupted(BaseException):
    """Raised inside a trial (or instead of starting it) when its sweep is interrupted; a
    BaseException, like KeyboardInterrupt, so that ``except Exception`` does not swallow it.
    ``started``: whether the trial had begun."""

    def __init__(self, message: str = "interrupted", started: bool = True):
        super().__init__(message, started)
        self.started = started

    def __str__(self) -> str:
        return str(self.args[0])


class Stopper:
    """Catches SIGINT and SIGTERM while a sweep runs (a context manager; nothing is installed
    outside the main thread). ``signum``: the first signal caught (None: none); ``hurry``: a
    second one came; with ``raise_now`` set (an inline trial runs), the first raises
    ``TrialInterrupted`` where the program is."""

    def __init__(self):
        self.signum: int | None = None
        self.hurry = False
        self.raise_now = False
        self._old: dict = {}

    def __enter__(self) -> Stopper:
        if threading.current_thread() is threading.main_thread():
            for s in STOP_SIGNALS:
                self._old[s] = signal.signal(s, self._handle)
        return self

    def __exit__(self, *exc) -> None:
        for s, old in self._old.items():
            signal.signal(s, old)
        self._old.clear()

    def _handle(self, signum, frame) -> None:
        if self.signum is not None:
            self.hurry = True
            return
        self.signum = signum
        log.warning("%s: stopping the sweep (queued trials cancelled, running ones stop; "
                    "again to stop at once)", signal.Signals(signum).name)
        if self.raise_now:
            raise TrialInterrupted(f"stopped by {signal.Signals(signum).name}")


# ------------------------------------------------------------------------- worker side
#: a pool worker's state (``dopt.lab.sweep_pool``): its sweep is stopping; a trial runs
_STOPPING = False
_IN_TRIAL = False


def _worker_stop(signum, frame) -> None:
    """A pool worker's SIGTERM handler: no trial starts after it, and the running one is
    interrupted (``TrialInterrupted`` raised inside it)."""
    global _STOPPING
    _STOPPING = True
    if _IN_TRIAL:
        raise TrialInterrupted(f"stopped by {signal.Signals(signum).name}")


def call_trial(fn: Callable, params: dict, kwargs: dict) -> tuple[object, dict]:
    """Run one trial in a worker (none once its sweep is stopping): ``(its result, the
    worker's machine())``; its report's last count is written before it returns."""
    global _IN_TRIAL
    if _STOPPING:
        raise TrialInterrupted("not started: the sweep was interrupted", started=False)
    _IN_TRIAL = True
    try:
        return fn(params, **kwargs), machine()
    finally:
        _IN_TRIAL = False
        if isinstance(kwargs.get("report"), Report):
            kwargs["report"].flush()


# ------------------------------------------------------------------------ sweep side
class _Progress:
    """The steps the running trials reported from their workers (read from their files)."""

    def __init__(self, reports: dict[str, Report], tick: Callable[[str, int], None] | None):
        self.reports, self.tick = reports, tick
        self.seen: dict[str, int] = {}
        self.next = 0.0

    def poll(self, keys=None, force: bool = False) -> None:
        if self.tick is None or not self.reports or (not force and time.monotonic() < self.next):
            return
        self.next = time.monotonic() + POLL_S
        folder = next(iter(self.reports.values())).path.parent
        try:
            present = {e.name[:-5] for e in os.scandir(folder) if e.name.endswith(".json")}
        except OSError:
            return
        for key in present if keys is None else present & set(keys):
            if key in self.reports:
                done = self.reports[key].read()
                if done > self.seen.get(key, 0):
                    self.tick(key, done - self.seen.get(key, 0))
                    self.seen[key] = done

    def end(self, key: str) -> None:
        """A trial ended: its last count, then its file is removed."""
        if key in self.reports:
            self.poll([key], force=True)
            self.reports[key].clear()


def run_inline(fn, todo, kwargs_of, finish, stop: Stopper) -> None:
    """The trials one after another in this process."""
    with stop:
        _run_inline(fn, todo, kwargs_of, finish, stop)


def _run_inline(fn, todo, kwargs_of, finish, stop: Stopper) -> None:
    for i, t in enumerate(todo):
        if stop.signum is not None:
            for rest in todo[i:]:
                finish(rest, error=TrialInterrupted("not started", started=False))
            return
        try:
            stop.raise_now = True
            try:
                result = fn(t.params, **kwargs_of(t))
            finally:
                stop.raise_now = False
        except TrialInterrupted as e:
            finish(t, error=e)
        except Exception as e:  # recorded, the sweep goes on
            finish(t, error=e)
        else:
            finish(t, result, machine=machine())


def run_ray(fn, todo, address: str, kwargs_of, finish, stop: Stopper,
            progress: _Progress) -> None:
    """The trials on Ray (``address`` "local": a local instance)."""
    import ray
    if not ray.is_initialized():
        with _sigint_not_ignored():
            if address == "local":
                ray.init(include_dashboard=False, log_to_driver=False)
            else:
                ray.init(address=address, log_to_driver=False)
    module = sys.modules[fn.__module__]
    if getattr(module, "__file__", None) and "site-packages" not in module.__file__:
        # the trial module lives in a script folder, not an installed package: ship it by value
        ray.cloudpickle.register_pickle_by_value(module)
    remote = ray.remote(call_trial)
    # ray.init may set its own SIGTERM handler: the sweep's are (re)installed after it
    with stop:
        pending = {remote.remote(fn, t.params, kwargs_of(t)): t for t in todo}
        while pending and stop.signum is None:
            ready, _ = ray.wait(list(pending), num_returns=1, timeout=POLL_S)
            for ref in ready:
                trial = pending.pop(ref)
                _finish_ref(ray, ref, trial, finish, progress, False, kwargs_of(trial))
            progress.poll([t.key for t in pending.values()])
        if not pending:
            return
        for ref in pending:
            ray.cancel(ref)               # queued: dropped; running: KeyboardInterrupt in it
        deadline = time.monotonic() + GRACE_S
        while pending and time.monotonic() < deadline and not stop.hurry:
            ready, _ = ray.wait(list(pending), num_returns=1, timeout=0.05)
            for ref in ready:
                trial = pending.pop(ref)
                _finish_ref(ray, ref, trial, finish, progress, True, kwargs_of(trial))
        for ref, trial in pending.items():
            ray.cancel(ref, force=True)
            stopped = _stopped(kwargs_of(trial), "its Ray task was killed")
            progress.end(trial.key)                 # (this removes its progress file)
            finish(trial, error=stopped)


@contextlib.contextmanager
def _sigint_not_ignored():
    """SIGINT not ignored while Ray starts its processes. They inherit an ignored SIGINT (a
    script's background job, ``cmd &``, runs with SIGINT ignored), and in a Ray worker that
    ignores it ``ray.cancel`` cannot stop a running task: it raises KeyboardInterrupt there by
    simulating SIGINT, which Python does nothing for when the signal is ignored (measured: the
    trials of an interrupted sweep ran on to their end)."""
    ignored = (threading.current_thread() is threading.main_thread()
               and signal.getsignal(signal.SIGINT) == signal.SIG_IGN)
    if ignored:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        if ignored:
            signal.signal(signal.SIGINT, signal.SIG_IGN)


def _stopped(kwargs: dict, why: str) -> TrialInterrupted:
    """What a trial stopped by the sweep (a Ray task cancelled or killed, a pool worker that
    died while the sweep stopped; ``kwargs``: its trial function's) became: neither says
    whether the trial had begun, so a trial that left no progress (no checkpoint, no step
    reported; read before its progress file is removed) counts as not started (a rerun runs
    it from its start either way)."""
    checkpoint, report = kwargs.get("checkpoint"), kwargs.get("report")
    began = ((checkpoint is not None and checkpoint.path.is_file())
             or (isinstance(report, Report) and report.read() > 0))
    if began:
        return TrialInterrupted(f"stopped: {why}")
    return TrialInterrupted(f"not started (no step completed): {why}", started=False)


def _finish_ref(ray, ref, trial, finish, progress: _Progress, stopping: bool,
                kwargs: dict) -> None:
    try:
        result = ray.get(ref)
    except Exception as e:
        if stopping or isinstance(e, ray.exceptions.TaskCancelledError):
            error = _stopped(kwargs, type(e).__name__)
        else:
            error = e.cause if isinstance(getattr(e, "cause", None), Exception) else e
        progress.end(trial.key)
        finish(trial, error=error)
    else:
        progress.end(trial.key)
        finish(trial, result[0], machine=result[1])


def progress_reports(out_dir: Path | str, keys, tick) -> dict[str, Report]:
    """{key: Report} of the trials ``keys`` (inline: straight to ``tick``; elsewhere read
    back from their files), their old files removed."""
    reports = {}
    for key in keys:
        r = Report(out_dir, key, None if tick is None else
                   (lambda n, key=key: tick(key, n)))
        r.clear()
        reports[key] = r
    (Path(out_dir) / "trials" / PROGRESS_DIR).mkdir(parents=True, exist_ok=True)
    return reports
