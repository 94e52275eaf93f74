"""--record only from committed code: the scripts' record_problem (before anything runs) and
write_summary (before the copy is written) refuse, in one line naming the changed files, a
dirty tree or a tree without git; --out alone always writes; --reuse-any is recorded."""

import argparse
import json
import subprocess

import pytest

from dopt.lab import provenance
from dopt.lab.record import add_reuse_argument, record_problem, reuse_mode, write_summary
from dopt.lab.sweep import Trial, run_sweep, take_deliberate_reuse
from tests.dopt.lab.sweep_trials import square


def git(repo, *args) -> str:
    proc = subprocess.run(["git", "-C", str(repo), "-c", "user.name=test",
                           "-c", "user.email=test@example.com", "-c", "commit.gpgsign=false",
                           *args], capture_output=True, text=True, check=True)
    return proc.stdout.strip()


@pytest.fixture
def repo(tmp_path, monkeypatch):
    monkeypatch.delenv("DOPT_GIT_COMMIT", raising=False)
    root = tmp_path / "repo"
    (root / "experiments").mkdir(parents=True)
    (root / "experiments" / "run.py").write_text("print(1)\n")
    (root / "docs").mkdir()
    (root / "docs" / "notes.md").write_text("notes\n")
    git(root, "init", "-q")
    git(root, "add", "-A")
    git(root, "commit", "-q", "-m", "first")
    return root


def test_record_problem_refuses_uncommitted_code_before_anything_runs(repo, tmp_path):
    out, record = tmp_path / "out", tmp_path / "rec.json"
    assert record_problem(None, out, repo) is None
    assert record_problem(record, out, repo) is None
    (repo / "docs" / "notes.md").write_text("docs do not count\n")
    (repo / "scratch.py").write_text("")                   # untracked, outside: does not count
    assert record_problem(record, out, repo) is None
    (repo / "experiments" / "run.py").write_text("print(2)\n")
    problem = record_problem(record, out, repo)
    assert problem.startswith("argument --record: cannot record from uncommitted code: 1 file")
    assert problem.endswith("experiments/run.py; commit them first (or write with --out only)")
    assert record_problem(out, out, repo) == f"argument --record: {out} is the --out folder"
    plain = tmp_path / "plain"
    plain.mkdir()
    assert "outside a git checkout" in record_problem(record, out, plain)


def test_write_summary_refuses_the_record_but_keeps_the_out_summary(repo, tmp_path):
    provenance._checkout_commit.cache_clear()
    (repo / "experiments" / "new.py").write_text("")      # a new module counts
    out, record = tmp_path / "out", tmp_path / "docs" / "rec.json"
    out.mkdir()
    with pytest.raises(RuntimeError) as exc:
        write_summary({"experiment": "x"}, out, record, "experiments/run.py", [], root=repo)
    assert str(exc.value).startswith(f"{record} is not written: cannot record from "
                                     "uncommitted code: 1 file(s)")
    assert "experiments/new.py" in str(exc.value) and not record.exists()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["provenance"]["git_commit"].endswith("-dirty")
    write_summary({"experiment": "x"}, out, None, "experiments/run.py", [], root=repo)  # --out


def test_write_summary_records_from_a_clean_tree_and_notes_deliberate_reuse(repo, tmp_path):
    provenance._checkout_commit.cache_clear()
    take_deliberate_reuse()
    out, record = tmp_path / "out", tmp_path / "rec.json"
    old = {"key": "x1", "params": {"x": 1}, "result": {"y": 1},
           "code": {"version": "0.1.0", "commit": "feedface" * 5}}
    (out / "trials").mkdir(parents=True)
    (out / "trials" / "x1.json").write_text(json.dumps(old))
    res = run_sweep(square, [Trial("x1", {"x": 1})], out, root=repo, reuse="any")
    assert res.skipped == ["x1"]
    write_summary({"trial_commits": res.commits}, out, record, "experiments/run.py", [],
                  root=repo)
    summary = json.loads(record.read_text())
    assert summary["provenance"]["git_commit"] == git(repo, "rev-parse", "HEAD")
    assert summary["reused_across_code"] == {
        "x1": "its commit feedfacefeed is unknown to git here"}
    write_summary({}, out, record, "experiments/run.py", [], root=repo)
    assert "reused_across_code" not in json.loads(record.read_text())   # taken once


@pytest.mark.parametrize("started_by", ["provenance", "sweep"])
def test_write_summary_refuses_code_that_changed_during_the_run(repo, tmp_path, started_by):
    provenance._checkout_commit.cache_clear()
    first = git(repo, "rev-parse", "HEAD")
    if started_by == "provenance":
        assert provenance.git_commit(repo) == first                 # cached at the start
    else:
        run_sweep(square, [Trial("x1", {"x": 1})], tmp_path / "out", root=repo)
    (repo / "experiments" / "run.py").write_text("print(3)\n")
    git(repo, "commit", "-qam", "second")
    with pytest.raises(RuntimeError, match=f"the code changed during the run .it started at "
                                           f"{first}, HEAD is now"):
        write_summary({}, tmp_path, tmp_path / "rec.json", "experiments/run.py", [], root=repo)


def test_reuse_any_flag():
    ap = argparse.ArgumentParser()
    add_reuse_argument(ap)
    assert reuse_mode(ap.parse_args([])) == "same-code"
    assert reuse_mode(ap.parse_args(["--reuse-any"])) == "any"


def test_record_figure_lands_where_results_md_shows_it(tmp_path):
    """With --record in a "results" folder the figure goes to the sibling images/ folder under
    the record's name (what RESULTS.md links); elsewhere beside the record; nothing without a
    record or without the figure."""
    from dopt.lab.record import record_figure

    fig = tmp_path / "out" / "scaling.png"
    fig.parent.mkdir()
    fig.write_bytes(b"\x89PNG figure")
    docs = tmp_path / "docs"
    dest = record_figure(fig, docs / "results" / "fig7-scaling-side.json")
    assert dest == docs / "images" / "fig7-scaling-side.png"
    assert dest.read_bytes() == fig.read_bytes()
    other = record_figure(fig, tmp_path / "mine" / "run.json")
    assert other == tmp_path / "mine" / "run.png" and other.read_bytes() == fig.read_bytes()
    assert record_figure(fig, None) is None
    assert record_figure(tmp_path / "out" / "missing.png", docs / "results" / "x.json") is None
    assert not (docs / "images" / "x.png").exists()
