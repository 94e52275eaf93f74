"""The one reuse rule, asked of a real (temporary) git repository: a trial recorded at commit X
is reused at a later commit that changed only docs/, recomputed at one that changed
planners/cem.py; uncommitted code is marked "-dirty", resumes only in its own tree and is never
reused once committed; recording from it is refused, naming the files."""

import json
import subprocess

import pytest

from dopt.lab import provenance
from dopt.lab.provenance import code_state, reuse_problem
from dopt.lab.sweep import Checkpoint, Trial, current_code, is_finished, run_sweep
from tests.dopt.lab.sweep_trials import count, square

FILES = {"planners/cem.py": "STEP = 1\n", "dopt/__init__.py": "", "pyproject.toml": "[x]\n",
         "docs/notes.md": "notes\n", "README.md": "readme\n"}


def git(repo, *args) -> str:
    proc = subprocess.run(["git", "-C", str(repo), "-c", "user.name=test",
                           "-c", "user.email=test@example.com", "-c", "commit.gpgsign=false",
                           *args], capture_output=True, text=True, check=True)
    return proc.stdout.strip()


def commit(repo, changes: dict, message: str) -> str:
    """Write ``changes`` ({path: text}), commit them all, return the new HEAD."""
    for rel, text in changes.items():
        (repo / rel).parent.mkdir(parents=True, exist_ok=True)
        (repo / rel).write_text(text)
    git(repo, "add", "-A")
    git(repo, "commit", "-q", "-m", message)
    return git(repo, "rev-parse", "HEAD")


@pytest.fixture
def repo(tmp_path, monkeypatch):
    """A tiny repository with the result paths' shape, at its first commit X."""
    monkeypatch.delenv("DOPT_GIT_COMMIT", raising=False)
    root = tmp_path / "repo"
    root.mkdir()
    git(root, "init", "-q")
    commit(root, FILES, "X")
    return root


def trials():
    return [Trial(f"x{x}", {"x": x}) for x in (1, 2)]


def stamp(out, key="x1"):
    return json.loads((out / "trials" / f"{key}.json").read_text())["code"]


def test_reused_after_a_docs_change_recomputed_after_a_planner_change(repo, tmp_path):
    out = tmp_path / "out"
    x = git(repo, "rev-parse", "HEAD")
    first = run_sweep(square, trials(), out, root=repo)
    assert sorted(first.ran) == ["x1", "x2"] and stamp(out)["commit"] == x
    docs = commit(repo, {"docs/notes.md": "more notes\n", "README.md": "new\n"}, "docs only")
    again = run_sweep(square, trials(), out, root=repo)
    assert sorted(again.skipped) == ["x1", "x2"] and again.ran == [] and again.commits == {x: 2}
    cem = commit(repo, {"planners/cem.py": "STEP = 2\n"}, "a planner change")
    third = run_sweep(square, trials(), out, root=repo)
    assert sorted(third.ran) == ["x1", "x2"] and third.skipped == []
    assert third.recomputed["x1"] == (f"files that can change its result changed since "
                                      f"{x[:12]}: planners/cem.py")
    assert stamp(out)["commit"] == cem and third.commits == {cem: 2}
    moved = json.loads((out / "trials" / "outdated" / "x1.json").read_text())
    assert moved["code"]["commit"] == x                   # kept as written, never rewritten
    assert reuse_problem({"commit": x}, code_state(repo), repo) is not None
    assert reuse_problem({"commit": docs}, code_state(repo), repo) is not None
    assert reuse_problem({"commit": cem[:10]}, code_state(repo), repo) is None  # abbreviated


def test_other_branches_and_unknown_commits_are_recomputed(repo, tmp_path):
    x = git(repo, "rev-parse", "HEAD")
    git(repo, "checkout", "-q", "-b", "side")
    side = commit(repo, {"docs/notes.md": "side\n"}, "side branch")
    git(repo, "checkout", "-q", "-")
    commit(repo, {"docs/notes.md": "main\n"}, "main branch")
    state = code_state(repo)
    assert reuse_problem({"commit": x}, state, repo) is None
    assert reuse_problem({"commit": side}, state, repo) == (
        f"its commit {side[:12]} is not an ancestor of HEAD {state.head[:12]}")
    assert reuse_problem({"commit": "feedface" * 5}, state, repo) == (
        "its commit feedfacefeed is unknown to git here")
    for old in ({}, {"commit": "unknown"}, {"commit": "no git"}, None):
        assert reuse_problem(old, state, repo).startswith("written by code of no known commit")


def test_uncommitted_code_is_marked_dirty_and_never_reused_once_committed(repo, tmp_path):
    out = tmp_path / "out"
    x = git(repo, "rev-parse", "HEAD")
    run_sweep(square, trials(), out, root=repo)
    (repo / "planners" / "cem.py").write_text("STEP = 3\n")
    dirty = run_sweep(square, trials(), out, root=repo)       # a clean record, a dirty tree
    assert sorted(dirty.ran) == ["x1", "x2"] and "uncommitted changes" in dirty.recomputed["x1"]
    code = stamp(out)
    assert code["commit"] == f"{x}-dirty" and len(code["tree"]) == 16
    resumed = run_sweep(square, trials(), out, root=repo)     # the same uncommitted tree
    assert sorted(resumed.skipped) == ["x1", "x2"]
    (repo / "planners" / "cem.py").write_text("STEP = 4\n")   # other uncommitted code
    assert is_finished(out, "x1", root=repo)               # the state this process last saw
    current_code(repo, refresh=True)
    assert not is_finished(out, "x1", root=repo)
    other = run_sweep(square, trials(), out, root=repo)
    assert other.recomputed["x1"] == f"written from uncommitted code ({x}-dirty)"
    (repo / "planners" / "cem.py").write_text("STEP = 3\n")
    commit(repo, {}, "the same code, committed")
    committed = run_sweep(square, trials(), out, root=repo)
    assert sorted(committed.ran) == ["x1", "x2"]              # a -dirty record at a commit


@pytest.mark.parametrize("path, counts", [
    ("planners/new_planner.py", True),        # a new module can change a result
    ("dopt/kernel.c", True),
    ("planners/data.csv", False),             # not a source file
    ("scratch.py", False),                    # outside the result paths
    ("docs/draft.md", False),
])
def test_which_untracked_files_make_a_tree_dirty(repo, path, counts):
    (repo / path).parent.mkdir(parents=True, exist_ok=True)
    (repo / path).write_text("x = 1\n")
    state = code_state(repo)
    assert state.dirty == counts and state.changed == ((path,) if counts else ())


def test_tracked_changes_staged_deleted_renamed_all_count(repo):
    (repo / "README.md").write_text("changed docs do not count\n")
    assert not code_state(repo).dirty
    git(repo, "mv", "planners/cem.py", "planners/cem2.py")
    (repo / "pyproject.toml").unlink()
    assert code_state(repo).changed == ("planners/cem.py", "planners/cem2.py", "pyproject.toml")


def test_recording_from_a_dirty_tree_is_refused_naming_the_files(repo, tmp_path):
    """The refusal itself: record=True, or trial files inside docs/results/, from a dirty tree
    raise before anything runs or moves; a clean tree records; --out elsewhere always runs."""
    results = repo / "docs" / "results" / "runs" / "sweep"
    assert sorted(run_sweep(square, trials(), results, root=repo).ran) == ["x1", "x2"]
    (repo / "planners" / "cem.py").write_text("STEP = 5\n")
    (repo / "planners" / "extra.py").write_text("")
    before = sorted(p.name for p in (results / "trials").iterdir())
    message = ("cannot write trial files ({}): cannot record from uncommitted code: 2 file(s) "
               "that can change a result differ from HEAD {}: planners/cem.py, "
               "planners/extra.py; commit them first (or write with --out only)")
    head = git(repo, "rev-parse", "HEAD")[:12]
    with pytest.raises(RuntimeError) as exc:
        run_sweep(square, trials(), results, root=repo)
    assert str(exc.value) == message.format(f"{results} is inside docs/results/", head)
    assert sorted(p.name for p in (results / "trials").iterdir()) == before   # nothing moved
    with pytest.raises(RuntimeError) as exc:
        run_sweep(square, trials(), tmp_path / "elsewhere", root=repo, record=True)
    assert str(exc.value) == message.format("the sweep is recorded", head)
    assert "\n" not in str(exc.value)
    assert sorted(run_sweep(square, trials(), tmp_path / "out", root=repo).ran) == ["x1", "x2"]


def test_recording_outside_git_is_refused(tmp_path, monkeypatch):
    monkeypatch.delenv("DOPT_GIT_COMMIT", raising=False)
    plain = tmp_path / "plain"
    plain.mkdir()
    with pytest.raises(RuntimeError, match="cannot record outside a git checkout"):
        run_sweep(square, trials(), tmp_path / "out", root=plain, record=True)
    res = run_sweep(square, trials(), tmp_path / "out", root=plain)
    assert res.commits == {"no git": 2}
    assert run_sweep(square, trials(), tmp_path / "out", root=plain).ran != []  # never reused


def test_checkpoints_follow_the_same_rule(repo, tmp_path):
    out = tmp_path / "out"
    first = run_sweep(count, [Trial("c", {"n": 5, "stop_at": 2})], out, root=repo)
    assert list(first.failed) == ["c"]
    commit(repo, {"docs/notes.md": "docs\n"}, "docs only")
    assert Checkpoint(out, "c", repo, code_state(repo)).peek() == {"i": 2, "runs": 1}
    res = run_sweep(count, [Trial("c", {"n": 5, "stop_at": 3})], out, root=repo)
    assert res.records == {} and "killed at 3" in res.failed["c"]   # resumed at 2, ran once
    commit(repo, {"planners/cem.py": "STEP = 6\n"}, "a planner change")
    res = run_sweep(count, [Trial("c", {"n": 5})], out, root=repo)
    result = res.records["c"]["result"]
    assert result["i"] == 5 and result["runs"] == 1                  # started afresh
    kept = json.loads((out / "trials" / "checkpoints" / "outdated" / "c.json").read_text())
    assert kept["progress"] == {"i": 3, "runs": 2}


def test_git_answers_are_cached_per_commit_pair(repo, monkeypatch):
    x = git(repo, "rev-parse", "HEAD")
    head = commit(repo, {"docs/notes.md": "docs\n"}, "docs only")
    provenance._diff_problem.cache_clear()
    state = code_state(repo)
    calls = []
    real = provenance._git
    monkeypatch.setattr(provenance, "_git", lambda *a, **k: calls.append(a) or real(*a, **k))
    for _ in range(3):
        assert reuse_problem({"commit": x}, state, repo) is None
    assert len(calls) == 3 and provenance._diff_problem.cache_info().hits == 2
    assert state.head == head
