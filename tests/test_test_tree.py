"""tests/ mirrors the source (issue 93 item 7): every file of tests/ sits in a folder that names
a package folder of the source (``tests/dopt/lab/`` for ``dopt/lab/``,
``tests/planners/pick_place/experiments/`` for the pick slice's experiments, ...) or
``tests/experiments/`` (the thin scripts themselves), every such folder is a package (so two
folders may hold files of one name), and only the house's cross-cutting tests and the session's
settings sit at the top. A new test goes beside the tests of the module it tests; a new
exception needs a reason written here."""

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: the files allowed at tests/'s top: the session's settings, where the authors' data lies, and
#: the house's own tests (they read the whole tree, no one package)
TOP = {"__init__.py", "conftest.py", "external.py", "test_layers.py", "test_docs.py",
       "test_doc_numbers.py", "test_house_sizes.py", "test_machine_paths.py",
       "test_flag_vocabulary.py", "test_results_provenance.py", "test_replays.py",
       "test_test_tree.py"}
#: source folders that are no package but hold code a test may be about
SCRIPT_FOLDERS = {"experiments"}


def misplaced(root: Path) -> list[str]:
    """The files under ``root/tests`` (repository-relative) whose folder mirrors no package
    folder of ``root`` (nor a script folder), that sit at the top without being allowed to,
    or whose folder is no package (no ``__init__.py``)."""
    tests = root / "tests"
    found = []
    for path in sorted(p for p in tests.rglob("*") if p.is_file() and p.suffix == ".py"
                       and "__pycache__" not in p.parts):
        folder = path.parent.relative_to(tests)
        name = str(path.relative_to(root))
        if folder == Path("."):
            if path.name not in TOP:
                found.append(f"{name}: at the top (put it beside the tests of its package)")
        elif not ((root / folder / "__init__.py").is_file()
                  or str(folder) in SCRIPT_FOLDERS):
            found.append(f"{name}: {folder}/ is no package folder of the source")
        elif not (path.parent / "__init__.py").is_file():
            found.append(f"{name}: tests/{folder}/ has no __init__.py")
    return found


def test_every_test_file_sits_under_its_package():
    assert not misplaced(ROOT), misplaced(ROOT)


def test_the_tree_is_found():
    files = list((ROOT / "tests").rglob("test_*.py"))
    assert len(files) > 100
    assert {p.parent.relative_to(ROOT / "tests").parts[0] for p in files
            if p.parent != ROOT / "tests"} == {"dopt", "deformables", "planners", "experiments"}


def test_a_file_out_of_the_mirror_is_named(tmp_path):
    """The check against a small tree: a package, a script folder, a folder the source lacks,
    a test folder without __init__.py, and a stray top-level test."""
    for package in ("pkg", "pkg/sub"):
        (tmp_path / package).mkdir(parents=True)
        (tmp_path / package / "__init__.py").write_text("")
    (tmp_path / "experiments").mkdir()
    layout = {"tests/__init__.py": "", "tests/test_layers.py": "", "tests/test_stray.py": "",
              "tests/pkg/__init__.py": "", "tests/pkg/test_a.py": "",
              "tests/pkg/sub/__init__.py": "", "tests/pkg/sub/helpers.py": "",
              "tests/pkg/gone/__init__.py": "", "tests/pkg/gone/test_b.py": "",
              "tests/experiments/__init__.py": "", "tests/experiments/test_s.py": "",
              "tests/pkg/sub/loose/test_c.py": ""}
    (tmp_path / "pkg" / "sub" / "loose").mkdir()
    (tmp_path / "pkg" / "sub" / "loose" / "__init__.py").write_text("")
    for name, text in layout.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(text)
    found = misplaced(tmp_path)
    assert [f.split(":")[0] for f in found] == [
        "tests/pkg/gone/__init__.py", "tests/pkg/gone/test_b.py",
        "tests/pkg/sub/loose/test_c.py", "tests/test_stray.py"]
    assert "no __init__.py" in found[2] and "at the top" in found[3]
