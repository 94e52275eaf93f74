"""The command line a result records: what a user types from the checkout's root to rerun it."""

import sys

import pytest

from dopt import provenance


@pytest.fixture
def root(monkeypatch, tmp_path):
    (tmp_path / "planners" / "bench").mkdir(parents=True)
    monkeypatch.setattr(provenance, "_ROOT", tmp_path)
    return tmp_path


def test_a_package_main_is_recorded_as_python_dash_m(root):
    argv = [str(root / "planners" / "bench" / "__main__.py"), "cloth", "--threads", "2"]
    assert provenance.command_line(argv) == "python -m planners.bench cloth --threads 2"


def test_a_script_in_the_checkout_is_recorded_by_its_relative_path(root):
    argv = [str(root / "experiments" / "mpc.py"), "--task", "soft", "--out", "a b"]
    assert provenance.command_line(argv) == "python experiments/mpc.py --task soft --out 'a b'"


def test_relative_and_outside_paths_are_kept_as_given(root, tmp_path_factory):
    assert provenance.command_line(["experiments/mpc.py", "--quick"]) == \
        "python experiments/mpc.py --quick"
    outside = str(tmp_path_factory.mktemp("elsewhere") / "run.py")
    assert provenance.command_line([outside, "-x"]) == f"python {outside} -x"
    assert provenance.command_line([]) == "python"


def test_provenance_records_this_processes_command_line(root, monkeypatch):
    monkeypatch.setattr(sys, "argv", [str(root / "planners" / "bench" / "__main__.py"), "rope"])
    assert provenance.provenance()["command"] == "python -m planners.bench rope"


def test_a_copied_tree_records_the_commit_its_copier_names(root, monkeypatch):
    """A source tree copied elsewhere (a cluster, a GPU machine) may carry no .git, or another
    commit's: DOPT_GIT_COMMIT, where set, is the commit recorded; unset, a tree without git
    records None and a checkout its HEAD."""
    git_commit = provenance.git_commit.__wrapped__
    monkeypatch.delenv("DOPT_GIT_COMMIT", raising=False)
    assert git_commit() is None
    checkout = provenance.Path(provenance.__file__).parents[1]
    if not (checkout / ".git").exists():
        pytest.skip("the tests run outside a git checkout")
    monkeypatch.setattr(provenance, "_ROOT", checkout)
    head = git_commit()
    assert head is not None and len(head.split("-")[0]) == 40
    monkeypatch.setenv("DOPT_GIT_COMMIT", "0123abc")
    assert git_commit() == "0123abc"
