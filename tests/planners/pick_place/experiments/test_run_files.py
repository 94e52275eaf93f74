"""What the pick experiments (fig7: rope.py, cloth_fold.py) read and write under --out (the SVR
experiments': in tests/planners/svr_mpc/experiments/test_run_files.py; the console's lines: in
tests/dopt/lab/test_console.py): trial records and checkpoints of another format are named,
moved aside and recomputed (each experiment's schema); a second run on the same --out
refuses, naming the first; every JSON file a --quick run writes parses with a strict parser
(no bare NaN: null with its reason); what a run needs is checked before its first trial."""

import json
import logging
import subprocess
import sys

import pytest

from dopt.lab.provenance import COMMIT_ENV
from dopt.lab.sweep import Checkpoint
from planners.pick_place.experiments import fig7
from tests.dopt.lab.run_files import run_script, strict_files

QUICK_ROPE = ["--quick", "--no-render"]


@pytest.fixture(autouse=True)
def fixed_code(monkeypatch):
    """The code of this process (and its children) fixed: others may commit or edit the
    checkout while a test runs, and a resumed trial must see the code that wrote it."""
    monkeypatch.setenv(COMMIT_ENV, "c0ffee")


# ---------------------------------------------------------------- records of another format
@pytest.mark.parametrize("spoil, reason", [
    (lambda rec: rec.pop("code"), "no 'code' stamp"),
    (lambda rec: rec.__setitem__("result", {}), "its result lacks 'method', 'seed'"),
    (lambda rec: rec["result"].pop("unstable"), "its result lacks 'unstable'"),
])
def test_a_pick_record_of_another_format_is_named_moved_aside_and_recomputed(
        tmp_path, caplog, spoil, reason):
    """Such a record once reached the summary: KeyError 'unstable' (or 'method'), exit 1 on
    every rerun, naming no file."""
    out = tmp_path / "rope"
    argv = [*QUICK_ROPE, "--methods", "scripted", "--out", str(out)]
    assert fig7.rope(argv) == 0
    (path,) = (out / "trials").glob("*.json")
    rec = json.loads(path.read_text())
    spoil(rec)
    path.write_text(json.dumps(rec))
    with caplog.at_level(logging.WARNING, logger="dopt.lab.sweep"):
        assert fig7.rope(argv) == 0
    assert f"trial file {path} is not used (" in caplog.text and reason in caplog.text
    assert json.loads((out / "trials" / "corrupt" / path.name).read_text()) == rec
    assert json.loads(path.read_text())["result"]["method"] == "scripted"     # recomputed


def test_a_checkpoint_of_another_format_is_moved_aside_and_its_trial_starts_afresh(
        tmp_path, caplog):
    """A checkpoint that is valid JSON without "trial" once failed its trial on every rerun."""
    out = tmp_path / "rope"
    argv = [*QUICK_ROPE, "--methods", "random", "--out", str(out)]
    assert fig7.rope(argv) == 0
    (path,) = (out / "trials").glob("*.json")
    first = json.loads(path.read_text())["result"]
    path.unlink()
    Checkpoint(out, path.stem).save({"stages": [], "stage": None})        # no "trial"
    with caplog.at_level(logging.WARNING, logger="dopt.lab.sweep"):
        assert fig7.rope(argv) == 0
    assert "is not resumed (its progress lacks 'trial', 'planner'" in caplog.text
    assert (out / "trials" / "checkpoints" / "corrupt" / path.name).exists()
    again = json.loads(path.read_text())["result"]
    assert again["cost_history"] == first["cost_history"] and again["segments"] == 1


# ---------------------------------------------------------------------------------- lock
def test_a_second_run_on_the_same_out_refuses_naming_the_first(tmp_path, capsys):
    out = tmp_path / "rope"
    code = (f"from dopt.lab.sweep import OutLock; import time\n"
            f"with OutLock({str(out)!r}):\n    print('held', flush=True); time.sleep(60)")
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "held"
        assert fig7.rope([*QUICK_ROPE, "--methods", "scripted", "--out", str(out)]) == 1
        err = capsys.readouterr().err.strip().splitlines()
        assert err[-1].startswith(f"rope.py: error: SweepLockedError: {out.absolute()} is in "
                                  f"use by process {proc.pid} on ")
        assert not (out / "trials").exists()
    finally:
        proc.kill()
        proc.wait()


# ---------------------------------------------------------- what a run needs, checked first
def test_a_missing_plots_package_is_refused_before_the_first_trial(tmp_path, capsys,
                                                                   monkeypatch):
    """The plots and bars come after the trials: without matplotlib a run failed at its end."""
    import importlib.util
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "matplotlib" else real(name, *a))
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as exc:
        fig7.rope([*QUICK_ROPE, "--methods", "scripted", "--out", str(out)])
    assert exc.value.code == 2 and not out.exists()
    assert "the run needs matplotlib (the plots extra: pip install 'dopt[plots]')" in \
        capsys.readouterr().err


# ------------------------------------------------------------------------ strict JSON files
@pytest.mark.slow
def test_every_file_of_a_quick_run_parses_strictly(tmp_path):
    """Every JSON file of a --quick run parses strictly (the SVR scripts' in
    tests/planners/svr_mpc/experiments/test_run_files.py)."""
    run_script("cloth_fold.py", "--quick", "--methods", "simple,scripted", "--no-render",
               "--out", tmp_path / "cloth")
    assert strict_files(tmp_path) >= 3          # the summary, 2 trial records; a bare NaN raises
