"""The house's import arrows point down: experiments -> planners -> deformables, dopt.

Every import statement of every module (top level and inside functions) is parsed with ast,
so a lazy import that runs up the house fails here as well. deformables may import the
pure-Python modules of dopt, dopt.validation, dopt.provenance and dopt.cli, and importing them
must not load MuJoCo."""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: package -> top-level names its modules must never import
FORBIDDEN = {
    "dopt": {"planners", "deformables", "experiments"},
    # deformables may import dopt.validation, dopt.provenance and dopt.cli (ALLOWED)
    "deformables": {"dopt", "planners", "experiments", "mujoco"},
    "planners": {"experiments"},
}


#: modules importable across the rule above (pure Python, no MuJoCo, no torch)
ALLOWED = {"dopt.validation", "dopt.provenance", "dopt.cli"}


def imported_roots(path: Path) -> set[str]:
    """Top-level packages imported by a module, except the ALLOWED modules."""
    tree = ast.parse(path.read_text(), filename=str(path))
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module)
    return {n.split(".")[0] for n in names - ALLOWED}


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


def test_importing_deformables_loads_neither_mujoco_nor_torch():
    code = ("import sys, deformables, deformables.cloth, deformables.rope, deformables.panels, "
            "deformables.bench; "
            "print(sorted(m for m in ('mujoco', 'torch') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=ROOT).stdout.strip()
    assert out == "[]"
