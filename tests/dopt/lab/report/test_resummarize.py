"""experiments/resummarize.py: every committed summary with committed trials is rebuilt from
those trials alone (no simulation) by the experiments' own summarize functions, and its numbers
are compared with the committed ones; a summary that does not match is named, never hidden."""

import json
import shutil
from pathlib import Path

import pytest

pytest.importorskip("torch")
pytest.importorskip("mujoco")

from dopt.lab.experiment import experiment_of  # noqa: E402
from dopt.lab.provenance import COMMIT_ENV  # noqa: E402
from dopt.lab.report import resummarize  # noqa: E402
from dopt.lab.report.base import load_results  # noqa: E402
from tests.external import LAYOUTS  # noqa: E402

ROOT = Path(__file__).resolve().parents[4]
RESULTS = ROOT / "docs" / "results"
#: committed summaries today's code cannot rebuild from their trials, and why: their trials
#: predate the fields svr_explain.py's summarize_rows reads (the importance "bins")
CANNOT_REBUILD = {"svr-explain-soft.json": "KeyError: 'bins'"}
#: committed summaries whose numbers their trials do not give (none today)
DO_NOT_MATCH: dict = {}


def test_every_committed_summary_is_what_its_committed_trials_give(tmp_path, capsys):
    """Rebuild every summary of docs/results into a temporary folder and compare the fields an
    experiment computes from its trials (numbers to 1e-9) with the committed file's: every
    one matches except those listed above; the rest of each file (settings, protocol) is the
    committed one's, with the original run's provenance kept under "resummarized_from"."""
    out = tmp_path / "resummarized"
    assert resummarize.main(["--results-dir", str(RESULTS), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    committed = {r.name: r for r in load_results(RESULTS)}
    found = {name: resummarize.rebuild(RESULTS, r) for name, r in committed.items()}
    with_trials = {name for name, f in found.items() if f is not None}
    # without the authors' scenes beside the project (a clone without ../shared) a summary
    # that reads them (the goal object's DoFs of each scene) cannot be rebuilt; with them, all
    cannot = dict(CANNOT_REBUILD)
    if not LAYOUTS.is_dir():
        cannot.update({name: f["error"] for name, f in found.items()
                       if f is not None and f["error"] and "layouts" in f["error"]})
    rebuilt = {p.name for p in out.glob("*.json")}
    assert rebuilt == with_trials - set(cannot)
    assert len(rebuilt) >= 30                      # Table 1, Fig. 4, Fig. 7, clocks, Panda
    for name, why in cannot.items():
        assert f"{name}: cannot be rebuilt from its trials ({why})" in printed
    # the last line counts them apart from the summaries that do not match
    assert (f"{len(DO_NOT_MATCH)} summaries do not match their trials"
            + "".join(f": {n}" for n in [", ".join(sorted(DO_NOT_MATCH))] if DO_NOT_MATCH)
            + f"; {len(cannot)} cannot be rebuilt from them: "
            + ", ".join(sorted(cannot))) in printed
    mismatched = {}
    for name in sorted(rebuilt):
        new, old = json.loads((out / name).read_text()), committed[name]
        fields = {k: old.data[k] for k in experiment_of(old).trial_fields if k in old.data}
        diff = resummarize.compare(fields, new)
        if diff["differs"] or diff["missing"]:
            mismatched[name] = diff
        for k, v in old.data.items():          # everything else is the committed file's
            if k not in experiment_of(old).trial_fields and k != "provenance":
                assert new[k] == v, (name, k)
        assert new["resummarized_from"] == old.origin
        assert new["provenance"]["command"].startswith("python experiments/resummarize.py")
    assert set(mismatched) == set(DO_NOT_MATCH), mismatched


def _copy_sweep(results: Path, name: str, sweep: str) -> Path:
    results.mkdir(parents=True, exist_ok=True)
    shutil.copy(RESULTS / name, results / name)
    shutil.copytree(RESULTS / "runs" / sweep / "trials", results / "runs" / sweep / "trials")
    return results / name


def test_a_summary_that_its_trials_do_not_give_is_named(tmp_path, capsys):
    path = _copy_sweep(tmp_path / "results", "fig7-cloth-diagonal-picker1.json",
                       "fig7-cloth-diagonal-picker1")
    assert resummarize.main(["--results-dir", str(tmp_path / "results"), "--check"]) == 0
    data = json.loads(path.read_text())
    data["methods"]["simple"]["final_cost_mean"] *= 1.01
    path.write_text(json.dumps(data))
    assert resummarize.main(["--results-dir", str(tmp_path / "results"), "--check"]) == 1
    assert ("fig7-cloth-diagonal-picker1.json: DOES NOT MATCH its 2 trials; differs: "
            "methods.simple.final_cost_mean") in capsys.readouterr().out


def test_in_place_rewrites_only_a_dirty_summary_of_clean_trials(tmp_path, capsys,
                                                              monkeypatch):
    """--in-place is refused from uncommitted code (like --record); from committed code it
    rewrites a summary written from uncommitted code whose trials are committed code and give
    its numbers, and leaves a clean one alone. The trial files are not touched."""
    results = tmp_path / "results"
    path = _copy_sweep(results, "fig7-rope-fold.json", "fig7-rope-fold")
    copy = json.loads(path.read_text())   # the test's copy as first recorded, from a tree with
    if "resummarized_from" in copy:       # uncommitted code, before its re-summary
        copy["provenance"] = copy.pop("resummarized_from")
    path.write_text(json.dumps(copy))
    trials = {p: p.read_bytes() for p in (results / "runs").rglob("*") if p.is_file()}
    monkeypatch.setenv(COMMIT_ENV, "f" * 40 + "-dirty")
    assert resummarize.main(["--results-dir", str(results), "--in-place"]) == 1
    assert "cannot record from uncommitted code" in capsys.readouterr().err
    monkeypatch.setenv(COMMIT_ENV, "f" * 40)
    old = json.loads(path.read_text())
    assert old["provenance"]["git_commit"].endswith("-dirty")
    assert resummarize.main(["--results-dir", str(results), "--in-place"]) == 0
    new = json.loads(path.read_text())
    assert new["provenance"]["git_commit"] == "f" * 40
    assert new["resummarized_from"] == old["provenance"]
    assert new["methods"] == old["methods"] and new["settings"] == old["settings"]
    assert {p: p.read_bytes() for p in (results / "runs").rglob("*") if p.is_file()} == trials
    before = path.read_text()                  # clean now: left alone
    assert resummarize.main(["--results-dir", str(results), "--in-place",
                             "--only", path.name]) == 0
    assert path.read_text() == before
    assert ("left alone: its summary is from committed code and holds every field its "
            "trials give") in capsys.readouterr().out


def test_in_place_brings_a_clean_summary_of_an_older_format_up_to_date(tmp_path, capsys,
                                                                     monkeypatch):
    """A summary from committed code that lacks a field its trials give (a Table 1 summary
    written before ``versus``) is rewritten with it; its other fields stay as they were."""
    results = tmp_path / "results"
    path = _copy_sweep(results, "table1-soft_rigid-ee.json", "table1-soft_rigid-ee")
    old = json.loads(path.read_text())
    old.pop("versus", None)
    path.write_text(json.dumps(old))
    monkeypatch.setenv(COMMIT_ENV, "f" * 40)
    assert resummarize.main(["--results-dir", str(results), "--in-place"]) == 0
    assert "versus, lag_cost_tau, choice)" in capsys.readouterr().out   # "(the rebuild adds ...)"
    new = json.loads(path.read_text())
    assert new["resummarized_from"] == old["provenance"]
    kept = {row: {f: v for f, v in m.items() if f in old["methods"][row]}
            for row, m in new["methods"].items()}         # the rebuild adds fields, keeps these
    assert kept == old["methods"] and new["versus"]["pairs"]
    assert resummarize.main(["--results-dir", str(results), "--check"]) == 0


def test_a_committed_nan_written_as_null_with_its_note_is_compared_as_nan():
    """A summary's mean over no kept pair is NaN, written null with a note beside it
    (dopt.lab.jsonio); the rebuild holds NaN and no note, and the two match."""
    from dopt.lab import jsonio
    from dopt.lab.report.base import Result

    methods = {"naive": {"mpc_cost_normalised_mean": float("nan"), "n_trials": 20}}
    written = json.loads(jsonio.dumps({"methods": methods}))
    assert "mpc_cost_normalised_mean_undefined" in written["methods"]["naive"]
    r = Result(path=Path("table1-soft.json"), data={"experiment": "table1", **written})
    committed = resummarize.committed_fields(r)
    assert resummarize.compare(committed, {"methods": methods}) == {
        "differs": [], "missing": [], "new": []}
    assert "mpc_cost_normalised_mean_undefined" in written["methods"]["naive"]  # not touched
