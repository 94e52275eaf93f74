"""The command line a result records: what a user types from the checkout's root to rerun it,
naming no folder of the machine it ran on (paths relative to the checkout's root or its sibling
``../shared``, others as ``<outside>/NAME``); the settings' paths, recorded relative to the
root; and older records' commands shown so (``recorded_command``)."""

import json
import os
import posixpath
import shlex
import sys
import types
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dopt.lab import provenance


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


def test_relative_paths_are_kept_and_outside_ones_lose_their_folders(root, tmp_path_factory):
    assert provenance.command_line(["experiments/mpc.py", "--quick"]) == \
        "python experiments/mpc.py --quick"
    outside = str(tmp_path_factory.mktemp("elsewhere") / "run.py")
    assert provenance.command_line([outside, "-x"]) == "python '<outside>/run.py' -x"
    assert provenance.command_line([]) == "python"


def test_absolute_arguments_are_recorded_relative_to_the_root_or_its_shared_folder(root):
    shared = root.parent / "shared" / "external" / "layouts"
    argv = [str(root / "experiments" / "mpc.py"), "--layouts", str(shared),
            f"--out={root / 'docs' / 'results' / 'runs' / 'x'}", "--record", "/elsewhere/a.json",
            "--rho", "0.5", "--name", "docs/notes"]
    assert provenance.command_line(argv) == (
        "python experiments/mpc.py --layouts ../shared/external/layouts "
        "--out=docs/results/runs/x --record '<outside>/a.json' --rho 0.5 --name docs/notes")


#: path parts a generator draws (none of them "." or "..")
PART = st.text("abcxyz_-0123456789", min_size=1, max_size=6)


@settings(max_examples=80, deadline=None)
@given(st.sampled_from(["root", "shared", "sibling", "far"]), st.lists(PART, min_size=1,
                                                                         max_size=4))
def test_a_path_is_recorded_relative_exactly_where_it_lies_inside_root_or_shared(where, parts):
    """Against posixpath on made-up folders (nothing is read): inside the root its parts, in the
    shared folder beside it ``../shared`` and its parts, elsewhere ``<outside>/`` its name;
    ``rooted`` reads back every ``root_relative`` path to the same folder."""
    root = "/m/u/checkout"
    base = {"root": root, "shared": "/m/u/shared", "sibling": "/m/u/other",
            "far": "/var"}[where]
    path = posixpath.join(base, *parts)
    expected = {"root": "/".join(parts), "shared": "/".join(["..", "shared", *parts])}.get(
        where, f"<outside>/{parts[-1]}")
    assert provenance.portable_path(path, root) == expected
    rel = provenance.root_relative(path, root)
    assert not os.path.isabs(rel) and provenance.rooted(rel, root) == Path(path)
    assert provenance.rooted(path, root) == Path(path)           # an older, absolute record


def machine(*parts: str) -> str:
    """An absolute path of a machine, built so that this file names none
    (tests/test_machine_paths.py)."""
    return "/" + "/".join(parts)


def test_older_records_commands_are_shown_relative_as_command_line_writes_them(root):
    rec = provenance.recorded_command
    main = machine("work", "main", "planners", "bench", "__main__.py")
    assert rec(f"python {main} clock --sizes 5") == "python -m planners.bench clock --sizes 5"
    layouts = machine("work", "shared", "external", "ilqr_svr", "push_mcl_layouts")
    assert rec(f"python experiments/mpc.py --preset authors --layouts {layouts} "
               f"--out docs/results/runs/t") == \
        ("python experiments/mpc.py --preset authors --layouts "
         "../shared/external/ilqr_svr/push_mcl_layouts --out docs/results/runs/t")
    assert rec(f"python -m dopt.bench cloth-warp --record {machine('root', 'out', 'w.json')}") \
        == \
        "python -m dopt.bench cloth-warp --record '<outside>/w.json'"
    for kept in ("python experiments/mpc.py --task soft --out 'a b'", "python -c 'unbalanced",
                 "", "make demo"):
        assert rec(kept) == kept
    # today's records are what recorded_command shows them as
    today = provenance.command_line([str(root / "experiments" / "mpc.py"), "--layouts",
                                     str(root.parent / "shared" / "l"), "--out", "/x/y"])
    assert rec(today) == today


def test_every_committed_command_is_shown_without_a_machines_folder():
    """Over the commands of every committed result: none shown names a folder of a machine
    (tests/test_machine_paths.py's pattern), and every word of the recorded one that is no
    path is still there, in order."""
    from tests.test_machine_paths import MACHINE_PATH

    results = Path(__file__).resolve().parents[3] / "docs" / "results"
    commands = []
    for f in sorted(results.glob("*.json")):
        data = json.loads(f.read_text())
        for key in ("provenance", "resummarized_from"):
            if isinstance(data.get(key), dict) and data[key].get("command"):
                commands.append(data[key]["command"])
    assert len(commands) > 50
    for command in commands:
        shown = provenance.recorded_command(command)
        assert not MACHINE_PATH.search(shown), (command, shown)
        words = iter(w for w in shlex.split(shown) if "/" not in w)
        assert all(w in words for w in shlex.split(command) if "/" not in w), (command, shown)


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
    checkout = provenance.Path(provenance.__file__).parents[2]
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
    checkout = provenance.Path(provenance.__file__).parents[2]
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
