"""A process pool's workers and the deaths of processes (``dopt.lab.sweep_pool``): the workers of
a sweep whose main process is killed (``kill -9``, the OOM killer) exit within seconds and
start no trial; a worker killed while the sweep runs fails its own trial only, named with its
pid and signal or exit code, while the others finish; the folder's lock names the live
workers, and a rerun does not take the folder over while a dead sweep's workers still run."""

import json
import os
import signal
import socket
import subprocess
import sys
import textwrap
import threading
import time
from multiprocessing import get_context
from pathlib import Path

import pytest

from dopt.lab import sweep_lock
from dopt.lab.provenance import COMMIT_ENV
from dopt.lab.sweep import LOCK_NAME, OutLock, SweepLockedError, Trial, run_sweep
from dopt.lab.sweep_store import Checkpoint
from tests.dopt.lab.sweep_trials import linger, lock_workers

HERE = Path(__file__).parent
#: the checkout these tests belong to: its dopt, not an installed one, runs in the children
ROOT = HERE.parents[2]
#: the most seconds from the main process's death to the end of its last worker
ORPHAN_S = 3.0


@pytest.fixture(autouse=True)
def fixed_code(monkeypatch):
    """The code of this process and of its children, fixed (see test_sweep_interrupt)."""
    monkeypatch.setenv(COMMIT_ENV, "c0ffee")


def alive(pid: int) -> bool:
    """Whether process ``pid`` runs (a zombie, dead but not yet reaped, does not)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return not Path("/proc/self").exists()
    return state not in ("Z", "X")


def started(calls: Path) -> dict[str, int]:
    """{trial key: pid of the worker that started it} from ``linger``'s start marks."""
    return {p.name.rsplit("-", 1)[0]: int(p.name.rsplit("-", 1)[1]) for p in calls.iterdir()}


def seconds_until(condition, limit: float) -> float:
    """Seconds until ``condition()`` holds (checked every 0.02 s), or inf after ``limit``."""
    t0 = time.monotonic()
    while not condition():
        if time.monotonic() - t0 > limit:
            return float("inf")
        time.sleep(0.02)
    return time.monotonic() - t0


def lingering(calls: Path, keys, **params) -> list[Trial]:
    return [Trial(k, {"key": k, "calls": str(calls), **params}) for k in keys]


def child_env() -> dict:
    """The environment of a child process: this checkout and the trial functions first."""
    path = [str(ROOT), str(HERE), os.environ.get("PYTHONPATH")]
    return {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, path))}


def sweep_child(out: Path, calls: Path) -> subprocess.Popen:
    """A process that runs 4 trials of 10 s on 2 workers."""
    script = textwrap.dedent(f"""
        from dopt.lab.sweep import Trial, run_sweep
        from sweep_trials import linger
        trials = [Trial(f"t{{i}}", {{"key": f"t{{i}}", "calls": {str(calls)!r}, "n": 200,
                                      "sleep": 0.05}}) for i in range(4)]
        run_sweep(linger, trials, {str(out)!r}, workers=2)
    """)
    return subprocess.Popen([sys.executable, "-c", script], env=child_env(), start_new_session=True,
                            stderr=subprocess.DEVNULL)


def test_the_workers_of_a_killed_sweep_exit_within_seconds_and_start_nothing(tmp_path):
    out, calls = tmp_path / "out", tmp_path / "calls"
    calls.mkdir()
    proc = sweep_child(out, calls)
    pids: set[int] = set()
    try:
        assert seconds_until(lambda: len(started(calls)) >= 2, 120) < 120, "no trial started"
        pids = set(started(calls).values())
        assert len(pids) == 2
        held = json.loads((out / LOCK_NAME).read_text())
        time.sleep(0.3)                                    # the trials are under way
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
        took = seconds_until(lambda: not any(alive(p) for p in pids), 10)
        print(f"the orphaned workers exited {took:.2f} s after the sweep was killed")
        assert took < ORPHAN_S, f"workers {sorted(p for p in pids if alive(p))} still run"
        marks = started(calls)
        saved = {p: p.stat().st_mtime_ns for p in (out / "trials" / "checkpoints").glob("*")}
        time.sleep(1.0)
        assert started(calls) == marks                     # no trial started since
        assert {p: p.stat().st_mtime_ns
                for p in (out / "trials" / "checkpoints").glob("*")} == saved
        assert sorted(held.get("workers", [])) == sorted(pids)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        for pid in pids:                                   # what the old code left running
            if alive(pid):
                os.kill(pid, signal.SIGKILL)


def test_a_worker_whose_parent_is_killed_exits_without_prctl(tmp_path):
    """The portable guard (a thread that watches the parent's pid), alone: a process started
    by a process that is then killed with SIGKILL."""
    grandchild = textwrap.dedent("""
        import os, time
        from dopt.lab.sweep_pool import watch_parent
        watch_parent(os.getppid(), prctl=False)
        print(os.getpid(), flush=True)
        time.sleep(60)
    """)
    middle = textwrap.dedent(f"""
        import subprocess, sys, time
        p = subprocess.Popen([sys.executable, "-c", {grandchild!r}], stdout=subprocess.PIPE,
                             text=True)
        print(p.stdout.readline().strip(), flush=True)
        time.sleep(60)
    """)
    proc = subprocess.Popen([sys.executable, "-c", middle], stdout=subprocess.PIPE, text=True,
                            env=child_env())
    pid = None
    try:
        pid = int(proc.stdout.readline())
        proc.kill()
        proc.wait()
        took = seconds_until(lambda: not alive(pid), 10)
        print(f"the orphan exited {took:.2f} s after its parent was killed")
        assert took < ORPHAN_S
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        if pid is not None and alive(pid):
            os.kill(pid, signal.SIGKILL)


# --------------------------------------------------------------------- one worker killed
def kill_when_under_way(calls: Path, out: Path, key: str) -> threading.Thread:
    """A thread that kills the worker running trial ``key`` with SIGKILL once the trial saved
    its second step (as the OOM killer would)."""
    def run():
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:
            pid = started(calls).get(key)
            progress = Checkpoint(out, key).peek()
            if pid is not None and progress is not None and progress["i"] >= 2:
                os.kill(pid, signal.SIGKILL)
                return
            time.sleep(0.02)
    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    return thread


@pytest.mark.parametrize("how", ["signal", "exit", "outside"])
def test_a_dead_workers_trial_fails_named_and_the_others_finish(tmp_path, how):
    out, calls = tmp_path / "out", tmp_path / "calls"
    calls.mkdir()
    victim = {"n": 5, "sleep": 0.05, "die_at": 2, "signal": int(signal.SIGKILL)}
    if how == "exit":
        victim = {"n": 5, "sleep": 0.05, "die_at": 2, "exit": 3}
    elif how == "outside":
        victim = {"n": 100, "sleep": 0.05}
    trials = lingering(calls, ["victim"], **victim) + lingering(
        calls, [f"t{i}" for i in range(5)], n=3, sleep=0.05)
    killer = kill_when_under_way(calls, out, "victim") if how == "outside" else None
    t0 = time.monotonic()
    res = run_sweep(linger, trials, out, workers=2)
    took = time.monotonic() - t0
    if killer is not None:
        killer.join()
    pid = started(calls)["victim"]
    assert list(res.failed) == ["victim"], res.failed
    why = res.failed["victim"]
    print(f"{how}: {why} (the sweep took {took:.1f} s)")
    assert why.startswith("WorkerDied: ") and f"pid {pid}" in why
    assert ("exit code 3" if how == "exit" else "SIGKILL") in why
    assert sorted(res.ran) == [f"t{i}" for i in range(5)] and res.interrupted == {}
    assert "a rerun resumes it" in why
    progress = Checkpoint(out, "victim").peek()
    assert progress is not None and progress["i"] >= 2
    if how != "outside":                                   # dies at step 2 only: resumed
        again = run_sweep(linger, trials, out, workers=2)
        assert again.resumed == ["victim"] and again.ran == ["victim"] and not again.failed
        assert again.records["victim"]["result"]["i"] == 5


# ------------------------------------------------------------------------------ the lock
def test_the_lock_of_a_pool_sweep_names_its_live_workers(tmp_path):
    trials = [Trial(k, {"lock": str(tmp_path / LOCK_NAME)}) for k in ("a", "b", "c")]
    res = run_sweep(lock_workers, trials, tmp_path, workers=2)
    assert not res.failed, res.failed
    for rec in res.records.values():
        result = rec["result"]
        assert result["holder"] == os.getpid() and result["pid"] in result["workers"]
    assert not (tmp_path / LOCK_NAME).exists()


def test_a_dead_sweeps_lock_is_not_taken_over_while_its_workers_run(tmp_path, monkeypatch):
    monkeypatch.setattr(sweep_lock, "WORKERS_WAIT_S", 0.5, raising=False)
    worker = get_context("spawn").Process(target=time.sleep, args=(60,))
    worker.start()
    gone = subprocess.Popen(["true"])
    gone.wait()
    try:
        (tmp_path / LOCK_NAME).write_text(json.dumps(
            {"pid": gone.pid, "host": socket.gethostname(), "started": "x",
             "command": "python experiments/rope.py", "workers": [worker.pid]}))
        with pytest.raises(SweepLockedError) as exc:
            OutLock(tmp_path).acquire()
        message = str(exc.value)
        print(message)
        assert f"{worker.pid}" in message and "\n" not in message and "kill" in message
    finally:
        worker.kill()
        worker.join()
    with OutLock(tmp_path):                            # its workers ended: taken over
        assert json.loads((tmp_path / LOCK_NAME).read_text())["pid"] == os.getpid()
