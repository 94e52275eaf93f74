"""The SVR experiments' code findings (their ``stale`` hook, ``code_findings`` over
``SVR_COMPUTE_PATHS``): a Table 1-protocol result is stale when a file that computes its trials
changed between its trials' commit and HEAD, and not when only a summary, report or lab file
changed; checked on a git repository built here."""

import subprocess
from pathlib import Path

from dopt.lab.experiment import experiment_of
from dopt.lab.report.base import Result


def git(root, *args):
    return subprocess.run(["git", "-C", str(root), *args], check=True, capture_output=True,
                          text=True).stdout.strip()


def commit(root, files: dict, message: str) -> str:
    for name, text in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    git(root, "add", "-A")
    git(root, "-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qm", message)
    return git(root, "rev-parse", "HEAD")


def code_findings(r: Result, results: Path) -> list[str]:
    """What the registered experiment of ``r`` finds stale about it (its hook: for an MPC
    result its settings against today's preset, none here, then its trials' code)."""
    return experiment_of(r).stale(r, results, None)


def result(commit_sha: str, kind="table1") -> Result:
    return Result(Path("table1-x.json"), {"experiment": kind,
                                          "trial_commits": {commit_sha: 20}})


def test_a_change_to_the_runtime_makes_the_trials_stale_a_summary_change_does_not(tmp_path):
    root = tmp_path / "repo"
    root.mkdir()
    git(root, "init", "-q")
    first = commit(root, {"dopt/mpc.py": "a\n", "planners/svr_mpc/summary.py": "s\n",
                          "dopt/lab/sweep.py": "w\n", "docs/results/x.json": "{}\n"}, "one")
    results = root / "docs" / "results"
    commit(root, {"planners/svr_mpc/summary.py": "s2\n", "dopt/lab/sweep.py": "w2\n"}, "lab")
    assert code_findings(result(first), results) == []
    commit(root, {"dopt/mpc.py": "b\n"}, "runtime")
    (finding,) = code_findings(result(first), results)
    assert finding.startswith(f"the code that computes its trials changed since {first[:8]}")
    assert "dopt/mpc.py" in finding and "summary.py" not in finding
    # not an MPC result: no code finding (None: its presets not checked, it records none)
    assert code_findings(result(first, kind="fig7"), results) in (None, [])


def test_an_unknown_commit_or_no_git_says_nothing(tmp_path):
    assert code_findings(result("f" * 40), tmp_path) == []


def test_a_verification_at_todays_code_clears_the_finding_until_the_code_changes(tmp_path):
    """verified/<result> (experiments/verify_trials.py) at a commit with today's code: current
    when every rerun matched, a finding naming the reruns when one differed; ignored once the
    code that computes trials changes again."""
    import json

    root = tmp_path / "repo"
    root.mkdir()
    git(root, "init", "-q")
    first = commit(root, {"dopt/mpc.py": "a\n", "docs/results/x.json": "{}\n"}, "one")
    head = commit(root, {"dopt/mpc.py": "b\n"}, "runtime")
    results = root / "docs" / "results"
    verified = results / "verified"
    verified.mkdir()

    def write(all_equal):
        (verified / "table1-x.json").write_text(json.dumps(
            {"provenance": {"git_commit": head}, "all_equal": all_equal,
             "trials": [{"key": "k", "equal": all_equal}]}))

    write(True)
    assert code_findings(result(first), results) == []
    write(False)
    findings = code_findings(result(first), results)
    assert findings[0].startswith(f"the code at {head[:8]} reruns 1 of 1 sampled trials")
    write(True)
    commit(root, {"planners/svr.py": "c\n"}, "runtime again")
    (finding,) = code_findings(result(first), results)
    assert "planners/svr.py" in finding and "dopt/mpc.py" in finding
