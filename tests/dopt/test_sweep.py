"""Resumable sweeps: inline, process pool, Ray, and a killed sweep that resumes."""

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from dopt.sweep import Trial, load_finished, run_sweep
from tests.dopt.sweep_trials import square

HERE = Path(__file__).parent


def trials(xs, **extra):
    return [Trial(f"x{x}", dict(x=x, **extra)) for x in xs]


def test_inline_and_skip(tmp_path):
    seen = []
    res = run_sweep(square, trials([1, 2, -1]), tmp_path, progress=lambda k, r: seen.append(k))
    assert sorted(res.ran) == ["x1", "x2"] and list(res.failed) == ["x-1"]
    assert res.records["x2"]["result"]["y"] == 4 and sorted(seen) == ["x-1", "x1", "x2"]
    again = run_sweep(square, trials([1, 2, 3]), tmp_path)
    assert again.ran == ["x3"] and sorted(again.skipped) == ["x1", "x2"]
    assert sorted(load_finished(tmp_path)) == ["x1", "x2", "x3"]


def test_process_pool(tmp_path):
    res = run_sweep(square, trials(range(4)), tmp_path, workers=2)
    assert {k: r["result"]["y"] for k, r in res.records.items()} == {
        "x0": 0, "x1": 1, "x2": 4, "x3": 9}
    assert all(r["result"]["pid"] != os.getpid() for r in res.records.values())


def test_killed_sweep_resumes_without_redoing_finished_trials(tmp_path):
    calls = tmp_path / "calls"
    calls.mkdir()
    out = tmp_path / "out"
    script = textwrap.dedent(f"""
        from dopt.sweep import Trial, run_sweep
        from sweep_trials import square
        run_sweep(square, [Trial(f"x{{x}}", dict(x=x, calls={str(calls)!r}, sleep=0.4))
                           for x in range(6)], {str(out)!r})
    """)
    # sweep_trials is imported from its folder, given to the child on its PYTHONPATH
    env = {**os.environ,
           "PYTHONPATH": os.pathsep.join(filter(None, [str(HERE), os.environ.get("PYTHONPATH")]))}
    proc = subprocess.Popen([sys.executable, "-c", script], env=env)
    deadline = time.time() + 60
    while len(list((out / "trials").glob("x*.json"))) < 2 and time.time() < deadline:
        time.sleep(0.05)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    finished = {p.stem for p in (out / "trials").glob("x*.json")}
    assert 2 <= len(finished) < 6
    res = run_sweep(square, trials(range(6), calls=str(calls)), out)
    assert set(res.skipped) == finished and len(res.records) == 6
    for key in finished:   # each trial finished before the kill ran exactly once
        assert len([c for c in os.listdir(calls) if c.startswith(key[1:] + "-")]) == 1


def test_ray_local(tmp_path):
    ray = pytest.importorskip("ray")
    try:
        res = run_sweep(square, trials([2, 3]), tmp_path, ray_address="local")
    finally:
        ray.shutdown()
    assert {k: r["result"]["y"] for k, r in res.records.items()} == {"x2": 4, "x3": 9}


def test_bad_input(tmp_path):
    with pytest.raises(ValueError, match="unique"):
        run_sweep(square, trials([1, 1]), tmp_path)
    with pytest.raises(ValueError, match="workers"):
        run_sweep(square, trials([1]), tmp_path, workers=0)
    with pytest.raises(ValueError, match="file name"):
        Trial("a/b", {})
