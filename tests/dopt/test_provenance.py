"""The command line a result records: what a user types from the checkout's root to rerun it."""

import sys
import types

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


def test_a_module_run_with_dash_m_is_recorded_as_python_dash_m(root, monkeypatch):
    """``python -m deformables.bench`` (a module inside a package, which only runs with -m)
    is recorded as such, not as the path of its file; a script of the same path run plainly
    (no ``__spec__``) stays a path."""
    (root / "deformables").mkdir()
    path = str(root / "deformables" / "bench.py")
    main = types.ModuleType("__main__")
    main.__spec__ = types.SimpleNamespace(name="deformables.bench", origin=path)
    monkeypatch.setitem(sys.modules, "__main__", main)
    assert provenance.command_line([path, "authors", "--repeats", "3"]) == \
        "python -m deformables.bench authors --repeats 3"
    main.__spec__ = None
    assert provenance.command_line([path, "authors"]) == "python deformables/bench.py authors"


def test_provenance_records_this_processes_command_line(root, monkeypatch):
    monkeypatch.setattr(sys, "argv", [str(root / "planners" / "bench" / "__main__.py"), "rope"])
    assert provenance.provenance()["command"] == "python -m planners.bench rope"


def test_a_copied_tree_records_the_commit_its_copier_names(root, monkeypatch):
    """A source tree copied elsewhere (a cluster, a GPU machine) may carry no .git, or another
    commit's: DOPT_GIT_COMMIT, where set, is the commit recorded (read on every call); unset,
    a tree without git records None ("no git" in a trial's stamp) and a checkout its HEAD."""
    monkeypatch.delenv("DOPT_GIT_COMMIT", raising=False)
    assert provenance.git_commit() is None
    assert provenance.code_version()["commit"] == "no git"
    assert provenance.code_state().record_problem().startswith(
        "cannot record outside a git checkout")
    checkout = provenance.Path(provenance.__file__).parents[1]
    monkeypatch.setenv("DOPT_GIT_COMMIT", "0123abc")
    assert provenance.git_commit() == "0123abc"
    assert provenance.code_state().record_problem() is None      # the copier vouches
    monkeypatch.setenv("DOPT_GIT_COMMIT", "0123abc-dirty")
    state = provenance.code_state()
    assert state.dirty and state.head == "0123abc" and "0123abc-dirty" in state.record_problem()
    monkeypatch.delenv("DOPT_GIT_COMMIT")
    if not (checkout / ".git").exists():
        pytest.skip("the tests run outside a git checkout")
    head = provenance.git_commit(checkout)
    assert head is not None and len(head.split("-")[0]) == 40


def test_a_tree_inside_another_checkout_is_not_that_checkout(tmp_path, monkeypatch):
    """An installed package (a virtualenv's site-packages inside a checkout) names no commit:
    git would find the enclosing checkout's."""
    monkeypatch.delenv("DOPT_GIT_COMMIT", raising=False)
    checkout = provenance.Path(provenance.__file__).parents[1]
    if not (checkout / ".git").exists():
        pytest.skip("the tests run outside a git checkout")
    assert provenance.code_state(checkout / "dopt").head is None


def test_name_files_names_a_dozen_and_counts_the_rest():
    assert provenance.name_files(["a", "b"]) == "a, b"
    many = [f"f{i}" for i in range(15)]
    assert provenance.name_files(many) == ", ".join(many[:12]) + " and 3 more"


def test_mujoco_version_is_read_from_mujoco_core_first(monkeypatch):
    """MuJoCo's bindings ship as mujoco-core (the dependency); an old environment has only the
    mujoco metapackage, which is read when there is no core."""
    import importlib.metadata as md

    installed = {"mujoco-core": "4.0.1", "mujoco": "4.0.0"}

    def version(dist):
        if dist in installed:
            return installed[dist]
        raise md.PackageNotFoundError(dist)

    monkeypatch.setattr(md, "version", version)
    assert provenance.versions()["mujoco"] == "4.0.1"
    del installed["mujoco-core"]
    assert provenance.versions()["mujoco"] == "4.0.0"
    installed.clear()
    assert provenance.versions()["mujoco"] is None
