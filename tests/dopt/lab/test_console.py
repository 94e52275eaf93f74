"""The sweep console's time estimate, its revision on each finished line and the trial's
result on that line (dopt.lab.console)."""

import numpy as np
import pytest

from dopt.lab.console import duration, estimate_line, left_line, print_outputs, run_with_console
from dopt.lab.sweep import Trial


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
