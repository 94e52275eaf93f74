"""experiments/verify_trials.py: a committed trial of the clutter pilot (the authors' clock)
reruns to its recorded outcome and the verification file says so; a changed record is named
as differing; trials on a host-dependent clock are refused. Skips without the authors'
scenes."""

import json
import shutil
from pathlib import Path

import pytest

from dopt.lab.provenance import COMMIT_ENV
from planners.svr_mpc.experiments import verify_trials
from tests.external import LAYOUTS

ROOT = Path(__file__).resolve().parents[4]
NAME = "table1-clutter-authors-executor-pilot.json"
TRIAL = ("clutter-rand-rho1-theta5-slow1-Y0-seed3-costauthors-clutter-ws-clockauthors-"
         "execauthors-authors.json")


def site(tmp_path, edit=None):
    """A results folder holding the pilot's record and one of its trials (``edit``: a change
    to that trial's stored result)."""
    results = tmp_path / "results"
    trials = results / "runs" / "table1-clutter-authors-executor" / "trials"
    trials.mkdir(parents=True)
    shutil.copy(ROOT / "docs" / "results" / NAME, results / NAME)
    record = json.loads((ROOT / "docs" / "results" / "runs" /
                         "table1-clutter-authors-executor" / "trials" / TRIAL).read_text())
    if edit:
        record["result"].update(edit)
    (trials / TRIAL).write_text(json.dumps(record))
    return results


@pytest.mark.skipif(not LAYOUTS.is_dir(), reason=f"the authors' scenes are not at {LAYOUTS}")
@pytest.mark.parametrize("edit, status", [(None, 0), ({"mpc_cost": 1.0}, 1)])
def test_a_rerun_is_compared_with_its_record(tmp_path, monkeypatch, edit, status):
    monkeypatch.setenv(COMMIT_ENV, "f" * 40)
    monkeypatch.chdir(ROOT)                     # the trial's layouts path is relative to it
    results = site(tmp_path, edit)
    assert verify_trials.main([str(results / NAME), "--sample", "3"]) == status
    v = json.loads((results / "verified" / NAME).read_text())
    assert v["sample"] == 1 and v["all_equal"] is (status == 0)
    assert v["trials"][0]["key"] + ".json" == TRIAL
    assert v["provenance"]["git_commit"] == "f" * 40


def test_a_host_dependent_clock_is_refused(tmp_path, monkeypatch, capsys):
    results = site(tmp_path)
    path = next((results / "runs").rglob("*.json"))
    record = json.loads(path.read_text())
    record["params"]["clock"] = "virtual"
    path.write_text(json.dumps(record))
    with pytest.raises(SystemExit) as e:
        verify_trials.main([str(results / NAME)])
    assert e.value.code == 2 and "depend on the host" in capsys.readouterr().err
