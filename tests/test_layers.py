"""The house's import arrows point down: experiments -> planners -> deformables, dopt.

Every import statement of every module (top level and inside functions) is parsed with ast,
so a lazy import that runs up the house fails here as well."""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: package -> top-level names its modules must never import
FORBIDDEN = {
    "dopt": {"planners", "deformables", "experiments"},
    "deformables": {"dopt", "planners", "experiments", "mujoco"},
    "planners": {"experiments"},
}


def imported_roots(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(), filename=str(path))
    roots = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            roots |= {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            roots.add(node.module.split(".")[0])
    return roots


@pytest.mark.parametrize("package", sorted(FORBIDDEN))
def test_no_import_runs_up_the_house(package):
    modules = sorted((ROOT / package).rglob("*.py"))
    assert modules, f"no modules found under {package}/"
    bad = {str(p.relative_to(ROOT)): sorted(imported_roots(p) & FORBIDDEN[package])
           for p in modules}
    assert {k: v for k, v in bad.items() if v} == {}


def test_the_checker_sees_lazy_imports(tmp_path):
    f = tmp_path / "m.py"
    f.write_text("def g():\n    from planners.cem import CEM\n    import deformables.goals\n")
    assert imported_roots(f) == {"planners", "deformables"}
