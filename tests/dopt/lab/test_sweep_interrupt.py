"""Stopping a sweep: SIGINT or SIGTERM on a sweep of a process pool (and of Ray) cancels the
queued trials, stops the running ones with their checkpoints, writes what finished, says how
to resume and exits 130 / 143 within 5 s; the rerun equals the uninterrupted sweep bit for bit.
Also the per-step progress of a pool's running trials and their log records reaching this
process, and the lock of a sweep's folder."""

import json
import logging
import os
import re
import signal
import subprocess
import sys
import textwrap
import time
import types
from pathlib import Path

import pytest

from dopt.lab.provenance import COMMIT_ENV
from dopt.lab.sweep import (
    LOCK_NAME,
    OutLock,
    SweepLockedError,
    SweepPlan,
    Trial,
    run_sweep,
)
from dopt.lab.sweep_store import CHECKPOINT_DIR, Checkpoint, Report
from tests.dopt.lab.sweep_trials import walk, warn

HERE = Path(__file__).parent
#: the most seconds from the signal to the sweep's exit
STOP_S = 5.0


def walks(n_trials=8, n=40, sleep=0.05):
    return [Trial(f"w{i}", {"n": n, "x0": 0.1 + i / 97, "sleep": sleep})
            for i in range(n_trials)]


def child(out: Path, workers: int, ray: bool):
    """A CLI-like process that runs the walks on ``workers`` (or Ray) under dopt.lab.cli.guarded,
    started with SIGINT ignored under Ray, as a script's background job (``cmd &``) is: the
    processes Ray starts inherit that, and its workers must still be interruptible."""
    script = textwrap.dedent(f"""
        import sys
        from dopt.lab.cli import guarded
        from dopt.lab.sweep import Trial, run_sweep
        from sweep_trials import walk

        @guarded("sweep")
        def main():
            trials = [Trial(f"w{{i}}", {{"n": 40, "x0": 0.1 + i / 97, "sleep": 0.05}})
                      for i in range(8)]
            run_sweep(walk, trials, {str(out)!r}, workers={workers},
                      ray_address={"'local'" if ray else None})
            return 0
        sys.exit(main())
    """)
    env = {**os.environ,
           "PYTHONPATH": os.pathsep.join(filter(None, [str(HERE), os.environ.get("PYTHONPATH")]))}
    # a session of its own, as a terminal's job: Ctrl-C reaches every process of its group
    ignore = (lambda: signal.signal(signal.SIGINT, signal.SIG_IGN)) if ray else None
    return subprocess.Popen([sys.executable, "-c", script], env=env, stderr=subprocess.PIPE,
                            text=True, start_new_session=True, preexec_fn=ignore)


def wait_for(condition, seconds: float) -> None:
    deadline = time.time() + seconds
    while not condition():
        assert time.time() < deadline, "the sweep did not get there in time"
        time.sleep(0.05)


def checkpoint_steps(out: Path) -> list[int]:
    """The step each checkpoint under OUT holds, read as a resume would (``peek``: a file
    being replaced, or one a resume would refuse, is skipped)."""
    steps = []
    for path in (out / "trials" / CHECKPOINT_DIR).glob("w*.json"):
        progress = Checkpoint(out, path.stem).peek()
        if progress is not None:
            steps.append(progress["i"])
    return steps


def results(out: Path) -> dict:
    """{key: the result's JSON text} of every trial file under OUT."""
    return {p.stem: json.dumps(json.loads(p.read_text())["result"], sort_keys=True)
            for p in (out / "trials").glob("*.json")}


@pytest.fixture(autouse=True)
def fixed_code(monkeypatch):
    """The code of this process and of its children, fixed (a clean commit named by
    DOPT_GIT_COMMIT): others may commit or edit the checkout while a test runs."""
    monkeypatch.setenv(COMMIT_ENV, "c0ffee")


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory):
    out = tmp_path_factory.mktemp("uninterrupted")
    res = run_sweep(walk, walks(sleep=0.0), out)
    assert sorted(res.ran) == [f"w{i}" for i in range(8)]
    return results(out)


def interrupt_and_resume(tmp_path, uninterrupted, sig, workers=2, ray=False, group=False):
    """Interrupt a child's sweep with ``sig`` (``group``: sent to its whole process group,
    as a terminal's Ctrl-C is), check how it stopped, rerun it here and compare."""
    out = tmp_path / "out"
    proc = child(out, workers, ray)
    try:
        # a trial finished and another early in its walk (at most a quarter of its 40 steps
        # of 0.05 s): it is still running when the signal lands 0.3 s later
        wait_for(lambda: len(list((out / "trials").glob("w*.json"))) >= 1
                 and any(step <= 10 for step in checkpoint_steps(out)), 240)
        time.sleep(0.3)
        at_signal = {"finished": sorted(results(out)), "checkpoints": checkpoint_steps(out)}
        sent, sent_wall = time.monotonic(), time.time()
        if group:
            os.killpg(proc.pid, sig)
        else:
            proc.send_signal(sig)
        _, err = proc.communicate(timeout=30)
        took = time.monotonic() - sent
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 128 + sig, err
    assert took < STOP_S, f"the sweep took {took:.1f} s to stop"
    line = err.strip().splitlines()[-1]
    assert line.startswith(f"sweep: interrupted by {signal.Signals(sig).name}: ")
    assert "to resume: python" in line and "resumes the rest" in line
    counts = re.search(r"(\d+) stopped part-way \((\d+) with a checkpoint of their last "
                       r"completed step\), (\d+) not started", line)
    part_way, saved, not_started = (int(c) for c in counts.groups())
    finished = set(results(out))
    stopped = {p.stem for p in (out / "trials" / CHECKPOINT_DIR).glob("w*.json")}
    # what happened, kept beside the run (pytest keeps the last runs' folders): the trials
    # done and the checkpoints' steps when the signal went, and when each trial file came
    seen = {**at_signal, "written_s_after_signal": {
        p.stem: round(p.stat().st_mtime - sent_wall, 3) for p in (out / "trials").glob("w*.json")},
        "stderr": err[-4000:]}
    (tmp_path / "diagnosis.json").write_text(json.dumps(seen, indent=1))
    assert finished and stopped and len(finished) < 8 and not finished & stopped, seen
    assert saved == len(stopped) and part_way + not_started == 8 - len(finished)
    if ray:     # Ray does not say which tasks began: those without progress are not started
        assert part_way == saved, line
    assert not (out / LOCK_NAME).exists()                 # released on the way out
    res = run_sweep(walk, walks(sleep=0.0), out, workers=workers)
    assert set(res.skipped) == finished and set(res.resumed) == stopped, res.recomputed
    assert results(out) == uninterrupted                  # the same bits as never stopped
    print(f"stopped in {took:.2f} s")
    return took


@pytest.mark.parametrize("sig, group", [(signal.SIGINT, True), (signal.SIGINT, False),
                                        (signal.SIGTERM, False)])
def test_a_pool_sweep_stops_within_seconds_and_resumes_exactly(tmp_path, uninterrupted, sig,
                                                               group):
    interrupt_and_resume(tmp_path, uninterrupted, sig, group=group)


def test_an_inline_sweep_stops_and_resumes_exactly(tmp_path, uninterrupted):
    interrupt_and_resume(tmp_path, uninterrupted, signal.SIGINT, workers=1)


def test_a_ray_sweep_stops_within_seconds_and_resumes_exactly(tmp_path, uninterrupted):
    pytest.importorskip("ray")
    interrupt_and_resume(tmp_path, uninterrupted, signal.SIGINT, ray=True, group=True)


def test_a_stopped_ray_trial_counts_as_begun_by_its_progress_read_before_it_is_removed(
        tmp_path):
    """A Ray task's cancellation does not say whether it had begun: a trial that reported a
    step or saved a checkpoint stopped part-way, one that did neither did not start. The
    count is read before the sweep removes the trial's progress file."""
    from dopt.lab.sweep_exec import _finish_ref, _Progress

    class Cancelled(Exception):
        pass

    def cancelled(ref):
        raise Cancelled

    ray = types.SimpleNamespace(get=cancelled,
                                exceptions=types.SimpleNamespace(TaskCancelledError=Cancelled))
    ends = {}
    for key, steps in (("ran", 3), ("queued", 0)):
        report = Report(tmp_path, key, interval=0.0)
        (tmp_path / "trials" / ".progress").mkdir(parents=True, exist_ok=True)
        report(steps)                             # a worker's report: written to its file
        progress = _Progress({key: report}, tick=lambda k, n: None)
        _finish_ref(ray, None, Trial(key, {}), lambda t, error: ends.update({t.key: error}),
                    progress, True, {"report": report})
        assert not report.path.exists()           # removed once the trial ended
    assert ends["ran"].started and not ends["queued"].started


# --------------------------------------------------------------- progress and logs of workers
def test_a_pool_reports_the_steps_of_its_running_trials(tmp_path):
    ticks, ends, plans = [], [], []
    res = run_sweep(walk, walks(n_trials=2, n=12, sleep=0.1), tmp_path, workers=2,
                    tick=lambda key, n: ticks.append((key, n, len(ends))),
                    progress=lambda key, rec: ends.append(key), on_start=plans.append)
    assert sorted(res.ran) == ["w0", "w1"] and not res.failed
    steps = {k: sum(n for key, n, _ in ticks if key == k) for k in ("w0", "w1")}
    assert steps == {"w0": 12, "w1": 12}               # every step, once
    assert any(before == 0 for _, _, before in ticks)   # while the trials still ran
    assert plans == [SweepPlan([], [], ["w0", "w1"], {})]
    assert plans[0].line() == "2 trials: 0 reused, 0 resumed from a checkpoint, 2 run from " \
                              "the start"
    assert not list((tmp_path / "trials" / ".progress").glob("*.json"))


def test_inline_steps_reach_tick_at_once(tmp_path):
    ticks = []
    run_sweep(walk, walks(n_trials=1, n=5), tmp_path, tick=lambda k, n: ticks.append(n))
    assert ticks == [1] * 5


def test_the_warnings_of_pool_workers_reach_this_process_loggers(tmp_path, caplog):
    with caplog.at_level(logging.WARNING):
        run_sweep(warn, [Trial("a", {"x": 1}), Trial("b", {"x": 2})], tmp_path, workers=2)
    text = caplog.text
    assert "warned by trial 1" in text and "warned by trial 2" in text
    assert "python warning of trial 1" in text                # warnings.warn, via logging


# ------------------------------------------------------------------------------ the lock
def holder(out: Path):
    """A process that holds OUT's lock until killed."""
    code = (f"from dopt.lab.sweep import OutLock; import time\n"
            f"with OutLock({str(out)!r}):\n    print('held', flush=True); time.sleep(60)")
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "held"
    return proc


def test_a_second_run_on_the_same_out_refuses_naming_the_first(tmp_path):
    proc = holder(tmp_path)
    try:
        with pytest.raises(SweepLockedError) as exc:
            run_sweep(walk, walks(n_trials=1, n=1), tmp_path)
        message = str(exc.value)
        assert f"is in use by process {proc.pid} on " in message and "\n" not in message
        assert "wait for it to finish or use another --out" in message
        assert not (tmp_path / "trials").exists()              # nothing ran, nothing moved
    finally:
        proc.kill()
        proc.wait()
    # its process is dead: the lock is stale and taken over
    res = run_sweep(walk, walks(n_trials=1, n=1), tmp_path)
    assert res.ran == ["w0"] and not (tmp_path / LOCK_NAME).exists()


def test_the_lock_is_reentrant_within_a_process_and_names_its_holder(tmp_path):
    with OutLock(tmp_path):
        held = json.loads((tmp_path / LOCK_NAME).read_text())
        assert held["pid"] == os.getpid() and held["host"] and held["command"]
        run_sweep(walk, walks(n_trials=1, n=1), tmp_path)       # the experiment's own sweep
        assert (tmp_path / LOCK_NAME).exists()
    assert not (tmp_path / LOCK_NAME).exists()


def test_a_lock_of_another_host_is_never_taken_over(tmp_path):
    (tmp_path / LOCK_NAME).write_text(json.dumps({"pid": 1, "host": "elsewhere",
                                                  "started": "x", "command": "y"}))
    with pytest.raises(SweepLockedError, match="if it is no longer running on elsewhere, "
                                               "delete"):
        OutLock(tmp_path).acquire()


def test_a_lock_whose_pid_now_runs_another_program_is_stale(tmp_path):
    """A dead sweep's pid taken by an unrelated process (pid reuse) does not hold the folder."""
    other = subprocess.Popen(["sleep", "30"])
    try:
        (tmp_path / LOCK_NAME).write_text(json.dumps(
            {"pid": other.pid, "host": os.uname().nodename, "started": "x",
             "command": "experiments/rope.py --out somewhere"}))
        with OutLock(tmp_path):
            assert json.loads((tmp_path / LOCK_NAME).read_text())["pid"] == os.getpid()
    finally:
        other.kill()
        other.wait()
