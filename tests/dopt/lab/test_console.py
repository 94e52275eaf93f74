"""The sweep console's time estimate, its revision on each finished line and the trial's
result on that line (dopt.lab.console); with workers, the bar counts the running trials' steps
and warnings print above it, not on it."""

import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from dopt.lab.console import duration, estimate_line, left_line, print_outputs, run_with_console
from dopt.lab.sweep import Trial

ROOT = Path(__file__).resolve().parents[3]


@pytest.mark.parametrize("seconds, text", [(0.4, "0 s"), (89, "89 s"), (90, "2 min"),
                                           (5399, "90 min"), (5400, "1.5 h")])
def test_duration_words(seconds, text):
    assert duration(seconds) == text


def test_the_estimate_counts_only_the_steps_not_held_over_the_workers():
    rng = np.random.default_rng(7)
    for _ in range(50):
        n = int(rng.integers(1, 6))
        trials = [Trial(f"t{i}", {}) for i in range(n)]
        whole = {t.key: int(rng.integers(1, 100)) for t in trials}
        start = {t.key: int(rng.integers(0, whole[t.key] + 1)) for t in trials}
        secs = {t.key: float(rng.uniform(1, 1000)) for t in trials}
        workers = int(rng.integers(1, 4))
        expect = sum(secs[k] * (whole[k] - start[k]) / whole[k] for k in whole)
        expect /= min(workers, n)
        line = estimate_line(trials, whole, start, lambda t, s=secs: s[t.key], "a pace",
                             workers)
        assert line == (f"estimate: about {duration(expect)} for {n} trials at a pace; "
                        f"revised as trials finish")


def test_the_time_left_is_the_pace_so_far():
    assert left_line(0, 10, 5.0, "step") == ""                   # nothing counted yet
    assert left_line(10, 0, 5.0, "step") == "none left"
    assert left_line(10, 30, 5.0, "step") == "about 15 s left at 2 step/s"


def test_finished_lines_say_the_result_and_the_revised_time_left(tmp_path, capsys):
    """Each finished line names the trial, its result (``describe``) and the time left; a
    record ``describe`` cannot read leaves the run alone and says so on its line."""
    trials = [Trial(f"k{i}", {"i": i}) for i in range(3)]

    def fn(params, report=None):
        for _ in range(4):
            report()
        return {"cost": None if params["i"] == 1 else 10.0 * params["i"]}

    res = run_with_console(fn, trials, tmp_path, steps=lambda t: 4, held=lambda t: 0,
                           unit="step", desc="x", seconds=lambda t: 1.0, basis="one second",
                           describe=lambda rec: f"cost {rec['result']['cost']:.1f}")
    assert not res.failed
    captured = capsys.readouterr()
    said = captured.out + captured.err
    assert "estimate: about 3 s for 3 trials at one second" in said
    lines = [line for line in said.replace("\r", "\n").splitlines()
             if line.startswith("finished")]
    assert lines[0].startswith("finished k0: cost 0.0 (1/3 trials run; about ")
    assert lines[1].startswith("finished k1: (no summary: TypeError")
    assert lines[2].startswith("finished k2: cost 20.0 (3/3 trials run; none left")


def test_print_outputs_names_the_pictures_that_exist_and_the_viewer(tmp_path, capsys):
    (tmp_path / "a.png").write_bytes(b"x")
    print_outputs(tmp_path, ["a.png", "missing.png"])
    out = capsys.readouterr().out.splitlines()
    assert out[0] == f"pictures: {tmp_path / 'a.png'}"
    assert out[1].startswith(f"replay its trials in the browser: dopt-view {tmp_path} ")
    assert 'pip install -e ".[viz]"' in out[1]


# ------------------------------------------------------------------------------ console
def test_the_console_counts_and_keeps_warnings_off_the_bar(tmp_path):
    """With --workers N the bar counts the running trials' steps and a worker's warning
    prints on a line of its own above the bar."""
    script = textwrap.dedent(f"""
        import logging, sys
        sys.path[:0] = [{str(ROOT)!r}]
        from dopt.lab.console import run_with_console
        from dopt.lab.sweep import Trial
        from tests.dopt.lab.sweep_trials import walk, warn
        logging.basicConfig(format="%(levelname)s %(name)s: %(message)s")
        trials = [Trial(f"w{{i}}", {{"n": 8, "x0": 0.2 + i / 10, "sleep": 0.05}})
                  for i in range(2)]
        run_with_console(walk, trials, {str(tmp_path)!r}, steps=lambda t: 8,
                         held=lambda t: 0, unit="step", desc="walk", workers=2)
        run_with_console(warn, [Trial("a", {{"x": 1}})], {str(tmp_path / "w")!r},
                         steps=lambda t: 1, held=lambda t: 0, unit="t", desc="warn",
                         workers=2)
    """)
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          timeout=300)
    assert proc.returncode == 0, proc.stderr
    err = proc.stderr
    assert "sweep: 2 trials: 0 reused, 0 resumed from a checkpoint, 2 run from the start" in err
    assert "sweep: 2 trials: 0 reused, 2 run to the end (0 of them resumed from a checkpoint)," \
           " 0 failed" in err
    assert "16/16" in err                                  # every step of both trials
    # each warning is a line of its own (after the bar's carriage returns, nothing before it)
    shown = [line.split("\r")[-1] for line in err.splitlines()]
    assert "WARNING tests.sweep_trials: warned by trial 1" in shown
    assert any(line.startswith("WARNING py.warnings:") and "python warning of trial 1" in line
               for line in shown)
