"""The house's import arrows point down: experiments -> planners -> deformables, dopt.

Every import statement of every module (top level and inside functions) is parsed with ast,
so a lazy import that runs up the house fails here as well. deformables may import the
pure-Python modules of dopt, dopt.validation, dopt.provenance, dopt.cli and dopt.atomic, and
importing them must not load MuJoCo.

Inside dopt the same holds between its rooms (``room``): the core (every module outside
dopt/tasks and dopt/bench) imports nothing of ``dopt.tasks``; the two task wings,
``dopt.tasks.pick`` and ``dopt.tasks.push``, never import each other nor the front
``dopt.tasks`` (which imports them); the neutral modules of ``dopt.tasks`` (the Panda both wings
use, ``dopt.tasks.panda``) import neither wing. The front registers both wings, and
``dopt.bench``, the benchmarks of the tasks' scenes, may import them as a planner may."""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: package -> top-level names its modules must never import
FORBIDDEN = {
    "dopt": {"planners", "deformables", "experiments"},
    # deformables may import dopt.validation, dopt.provenance, dopt.cli, dopt.atomic (ALLOWED)
    "deformables": {"dopt", "planners", "experiments", "mujoco"},
    "planners": {"experiments"},
}


#: modules importable across the rule above (pure Python, no MuJoCo, no torch; dopt.atomic:
#: the one atomic writer of every result file, the benchmarks' included)
ALLOWED = {"dopt.validation", "dopt.provenance", "dopt.cli", "dopt.atomic"}


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


# ------------------------------------------------------------------------ inside dopt
#: room -> the rooms of dopt it must never import (``room`` names them)
DOPT_FORBIDDEN = {
    "core": {"front", "pick", "push", "neutral"},
    "pick": {"front", "push"},
    "push": {"front", "pick"},
    "neutral": {"front", "pick", "push"},
    "front": set(),
    "bench": set(),
}


def room(module: str) -> str | None:
    """The room of dopt a dotted module name lies in (None outside dopt): "front"
    (``dopt.tasks`` itself), "pick" / "push" (a wing), "neutral" (another module of
    ``dopt.tasks``), "bench" (``dopt.bench``) or "core" (the rest)."""
    parts = module.split(".")
    if parts[0] != "dopt":
        return None
    if parts[1:2] == ["bench"]:
        return "bench"
    if parts[1:2] != ["tasks"]:
        return "core"
    if len(parts) == 2:
        return "front"
    return parts[2] if parts[2] in ("pick", "push") else "neutral"


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imported_modules(path: Path, text: str | None = None) -> set[str]:
    """The dotted modules the module at ``path`` (its source ``text``, default the file's)
    imports: relative imports resolved, ``from a import b`` counted as ``a`` and ``a.b`` (b a
    submodule or a name of a)."""
    tree = ast.parse(path.read_text() if text is None else text, filename=str(path))
    package = module_name(path).split(".")
    if path.name != "__init__.py":
        package = package[:-1]
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package[:len(package) - node.level + 1]
                base = ".".join(anchor + ([base] if base else []))
            names.add(base)
            names |= {f"{base}.{alias.name}" for alias in node.names}
    return names


def leaks(path: Path, text: str | None = None) -> list[str]:
    """The modules the dopt module at ``path`` imports from a room it must not."""
    here = room(module_name(path))
    return sorted(m for m in imported_modules(path, text)
                  if room(m) in DOPT_FORBIDDEN[here] and room(m) != here)


def test_inside_dopt_the_core_imports_no_task_and_the_wings_not_each_other():
    bad = {str(p.relative_to(ROOT)): hits for p in sorted((ROOT / "dopt").rglob("*.py"))
           if (hits := leaks(p))}
    assert bad == {}


def test_the_rooms_of_dopt_and_the_leaks_the_checker_sees():
    assert [room(m) for m in ("dopt.render", "dopt.view.cli", "dopt.tasks", "dopt.tasks.panda",
                              "dopt.tasks.pick.replay", "dopt.tasks.push", "dopt.bench.rollout",
                              "numpy")] == ["core", "core", "front", "neutral", "pick", "push",
                                            "bench", None]
    # parsed as if they were these files (nothing is written)
    wing = ROOT / "dopt" / "tasks" / "pick" / "fake.py"
    code = "from ..push import clutter\nfrom . import picker\ndef f():\n    import dopt.render\n"
    assert leaks(wing, code) == ["dopt.tasks.push", "dopt.tasks.push.clutter"]
    core = ROOT / "dopt" / "fake.py"
    assert leaks(core, "def g():\n    from dopt.tasks.pick.scene import DeformableScene\n") \
        == ["dopt.tasks.pick.scene", "dopt.tasks.pick.scene.DeformableScene"]
    assert leaks(core, "from dopt.tasks import get_task\n") == ["dopt.tasks",
                                                                "dopt.tasks.get_task"]
    neutral = ROOT / "dopt" / "tasks" / "fake.py"
    assert leaks(neutral, "from dopt.tasks.push.clutter import STANDOFF\n") != []
    front = ROOT / "dopt" / "tasks" / "__init__.py"
    assert leaks(front, "from dopt.tasks.pick.scene import DeformableScene\n") == []


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
