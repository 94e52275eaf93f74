"""The house's import arrows point down: experiments -> planners -> deformables, dopt.

Every import statement of every module (top level, inside functions, under TYPE_CHECKING) is
parsed with ast, so a lazy import that runs up the house fails here as well. deformables may
import the pure-Python modules of dopt, dopt.validation, dopt.lab.provenance, dopt.lab.cli,
dopt.atomic and dopt.blas, and importing them must not load MuJoCo.

Inside dopt the same holds between its rooms (``room``): the core (every module outside
dopt/tasks, dopt/bench and dopt/view) imports nothing of ``dopt.tasks``; the two task wings,
``dopt.tasks.pick`` and ``dopt.tasks.push``, never import each other nor the front
``dopt.tasks`` (which imports them); the neutral modules of ``dopt.tasks`` (the Panda both wings
use, ``dopt.tasks.panda``) import neither wing. The front registers both wings, and
``dopt.bench``, the benchmarks of the tasks' scenes, may import them as a planner may. The
viewer ``dopt.view`` knows no task, and nothing of the runtime imports it: of the whole house
only the viewer's sources of trials (``planners.view``) and the top floor do.

Inside planners (``planner_room``): the algorithm modules (``ALGORITHMS``) know no paper and
import only each other; the two paper slices, ``planners.pick_place`` and ``planners.svr_mpc``,
never import each other; every module of planners has a room, so a new one is placed here.

No import circles anywhere (``circles``): a module's imports, resolved to the modules they load
(``import_targets``), never lead back to it."""

import ast
import functools
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

ROOT = Path(__file__).resolve().parents[1]

#: package -> top-level names its modules must never import
FORBIDDEN = {
    "dopt": {"planners", "deformables", "experiments"},
    # deformables may import dopt.validation, dopt.lab.provenance, dopt.lab.cli, dopt.atomic,
    # dopt.blas (ALLOWED)
    "deformables": {"dopt", "planners", "experiments", "mujoco"},
    "planners": {"experiments"},
}


#: modules importable across the rule above (pure Python, no MuJoCo, no torch; dopt.atomic:
#: the one atomic writer of every result file, the benchmarks' included; dopt.blas: the
#: OpenBLAS kernels, pinned before numpy loads)
ALLOWED = {"dopt.validation", "dopt.lab.provenance", "dopt.lab.cli", "dopt.atomic", "dopt.blas"}


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


# ------------------------------------------------------------------- resolving imports
#: the packages the house is made of; experiments/ is no package: its scripts import each other
#: by file name (their folder is on the path when they run), so they are named by it
PACKAGES = ("dopt", "planners", "deformables")


def module_name(path: Path, root: Path = ROOT) -> str:
    """The dotted name of the module at ``path`` under ``root`` (a script of experiments/: its
    file name)."""
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[0] == "experiments":
        return parts[-1]
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def house_modules(root: Path = ROOT) -> dict[str, Path]:
    """{name: file} of every module of the packages and of every script of experiments/."""
    files = [p for package in PACKAGES for p in sorted((root / package).rglob("*.py"))]
    files += sorted((root / "experiments").glob("*.py"))
    return {module_name(p, root): p for p in files}


@functools.cache
def _house() -> frozenset[str]:
    return frozenset(house_modules())


def import_targets(path: Path, text: str | None = None, known=None,
                   root: Path = ROOT) -> set[str]:
    """The modules the module at ``path`` (its source ``text``, default the file's) loads by its
    import statements, every one (lazy ones inside functions too), relative ones resolved:
    ``import a.b`` loads a.b; ``from a import b`` loads a.b where that is a module of ``known``
    (default the house's), else a (b is a name of a); each also loads the packages above it,
    less those that hold the importing module (loaded before it runs). A module outside the
    house counts by the name it is imported as."""
    known = _house() if known is None else known
    name = module_name(path, root)
    tree = ast.parse(path.read_text() if text is None else text, filename=str(path))
    package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    direct = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            direct |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package[:len(package) - node.level + 1]
                base = ".".join(anchor + ([base] if base else []))
            direct |= {f"{base}.{a.name}" if f"{base}.{a.name}" in known else base
                       for a in node.names}
    loaded = {".".join(package[:i]) for i in range(1, len(package) + 1)}
    out = set()
    for target in direct:
        parts = target.split(".")
        out |= {".".join(parts[:i]) for i in range(1, len(parts))} - loaded
        out.add(target)
    return out - {name}


# ------------------------------------------------------------------------ inside dopt
#: room -> the rooms of dopt it must never import (``room`` names them)
DOPT_FORBIDDEN = {
    "core": {"front", "pick", "push", "neutral", "view", "lab"},
    "pick": {"front", "push", "view", "lab"},
    "push": {"front", "pick", "view", "lab"},
    "neutral": {"front", "pick", "push", "view", "lab"},
    "front": {"view", "lab"},
    "bench": {"view"},
    "view": {"front", "pick", "push", "neutral", "bench"},
    # the lab (sweeps, trial files, provenance, statistics, command lines) knows no physics:
    # of the rest of dopt only the base modules (``BASE``) and the package front
    "lab": {"core", "front", "pick", "push", "neutral", "view", "bench"},
}

#: pure-Python modules every room may import: argument checks, the atomic file writer and the
#: BLAS pin
BASE = {"dopt", "dopt.validation", "dopt.atomic", "dopt.blas"}


def room(module: str) -> str | None:
    """The room of dopt a dotted module name lies in (None outside dopt): "front"
    (``dopt.tasks`` itself), "pick" / "push" (a wing), "neutral" (another module of
    ``dopt.tasks``), "bench" (``dopt.bench``), "view" (``dopt.view``), "lab" (``dopt.lab``),
    "base" (``BASE``, importable from every room) or "core" (the rest)."""
    parts = module.split(".")
    if parts[0] != "dopt":
        return None
    if module in BASE:
        return "base"
    if parts[1:2] in (["bench"], ["view"], ["lab"]):
        return parts[1]
    if parts[1:2] != ["tasks"]:
        return "core"
    if len(parts) == 2:
        return "front"
    return parts[2] if parts[2] in ("pick", "push") else "neutral"


def leaks(path: Path, text: str | None = None) -> list[str]:
    """The modules the dopt module at ``path`` imports from a room it must not."""
    here = room(module_name(path))
    if here == "base":
        return sorted(m for m in import_targets(path, text) if room(m) not in (None, "base"))
    return sorted(m for m in import_targets(path, text)
                  if room(m) in DOPT_FORBIDDEN[here] and room(m) != here)


def test_inside_dopt_the_core_imports_no_task_and_the_wings_not_each_other():
    bad = {str(p.relative_to(ROOT)): hits for p in sorted((ROOT / "dopt").rglob("*.py"))
           if (hits := leaks(p))}
    assert bad == {}


def test_the_rooms_of_dopt_and_the_leaks_the_checker_sees():
    assert [room(m) for m in ("dopt.render", "dopt.blowup", "dopt.view.cli", "dopt.tasks",
                              "dopt.tasks.panda", "dopt.tasks.pick.replay", "dopt.tasks.push",
                              "dopt.bench.rollout", "dopt.lab.sweep", "dopt.atomic", "numpy")] == [
        "core", "core", "view", "front", "neutral", "pick", "push", "bench", "lab", "base", None]
    # parsed as if they were these files (nothing is written)
    wing = ROOT / "dopt" / "tasks" / "pick" / "fake.py"
    code = "from ..push import clutter\nfrom . import picker\ndef f():\n    import dopt.render\n"
    assert leaks(wing, code) == ["dopt.tasks.push", "dopt.tasks.push.clutter"]
    core = ROOT / "dopt" / "fake.py"
    assert leaks(core, "def g():\n    from dopt.tasks.pick.scene import DeformableScene\n") \
        == ["dopt.tasks", "dopt.tasks.pick", "dopt.tasks.pick.scene"]
    assert leaks(core, "from dopt.tasks import get_task\n") == ["dopt.tasks"]
    assert leaks(core, "if TYPE_CHECKING:\n    from dopt.view.episode import Episode\n") \
        == ["dopt.view", "dopt.view.episode"]
    assert leaks(core, "from dopt import blowup, state\n") == []
    neutral = ROOT / "dopt" / "tasks" / "fake.py"
    assert leaks(neutral, "from dopt.tasks.push.clutter import STANDOFF\n") != []
    front = ROOT / "dopt" / "tasks" / "__init__.py"
    assert leaks(front, "from dopt.tasks.pick.scene import DeformableScene\n") == []
    viewer = ROOT / "dopt" / "view" / "fake.py"
    assert leaks(viewer, "from dopt.tasks.pick import scene\n") == ["dopt.tasks",
                                                                    "dopt.tasks.pick",
                                                                    "dopt.tasks.pick.scene"]
    assert leaks(viewer, "from .episode import Episode\nfrom dopt.blowup import FORMAT\n") == []
    assert leaks(core, "from dopt.lab import jsonio\n") == ["dopt.lab", "dopt.lab.jsonio"]
    lab = ROOT / "dopt" / "lab" / "fake.py"
    assert leaks(lab, "from dopt import atomic\nfrom .jsonio import dumps\n") == []
    assert leaks(lab, "def f():\n    from dopt.rollout import RolloutService\n") \
        == ["dopt.rollout"]
    base = ROOT / "dopt" / "atomic.py"
    assert leaks(base, "from dopt.lab import jsonio\n") == ["dopt.lab", "dopt.lab.jsonio"]


#: the modules outside dopt that may import the viewer: its sources of the planners' trials
VIEWER_SOURCES = {"planners.view"}


def is_slice_experiment(name: str) -> bool:
    """A paper's experiment inside its slice (``planners.<slice>.experiments``): the top
    floor's work (flags, printing, pictures), kept beside its paper."""
    return any(name == f"{s}.experiments" or name.startswith(f"{s}.experiments.")
               for s in SLICES)


def test_nothing_of_the_runtime_imports_the_viewer():
    """dopt's rooms forbid it inside dopt; in planners and deformables only the viewer's
    sources import it (the top floor, experiments/ and the slices' experiments, may show what
    it ran)."""
    bad = {name: hits for name, path in house_modules().items()
           if name.split(".")[0] in ("planners", "deformables") and name not in VIEWER_SOURCES
           and not is_slice_experiment(name)
           and (hits := sorted(m for m in import_targets(path) if room(m) == "view"))}
    assert bad == {}


# -------------------------------------------------------------------- inside planners
#: the algorithm modules (they know no paper) and the checks they share
ALGORITHMS = ("planners.cem", "planners.ilqr", "planners.svr", "planners.scripted",
              "planners.keypoints", "planners.gaussian_cem", "planners._checks")
#: the paper slices, each a room of its own
SLICES = ("planners.pick_place", "planners.svr_mpc")
#: the rest of planners: the front, what the slices share (a saved trial's progress), the
#: viewer's sources and the benchmarks (over both papers, as a command line is)
PLANNER_TOOLS = ("planners", "planners.trial_progress", "planners.view", "planners.bench")
#: room -> the rooms of planners it must never import (``planner_room`` names them)
PLANNER_FORBIDDEN = {"algorithm": {"pick_place", "svr_mpc", "tools"},
                     "pick_place": {"svr_mpc"}, "svr_mpc": {"pick_place"}, "tools": set()}


def planner_room(module: str) -> str | None:
    """The room of planners a dotted module name lies in (None outside planners):
    "algorithm", "pick_place", "svr_mpc", "tools", or "unplaced" (named by no table above)."""
    if module.split(".")[0] != "planners":
        return None
    if module in ALGORITHMS:
        return "algorithm"
    for place, rooms in (("slice", SLICES), ("tools", PLANNER_TOOLS)):
        for top in rooms:
            if module == top or (top != "planners" and module.startswith(top + ".")):
                return top.split(".")[1] if place == "slice" else place
    return "unplaced"


def planner_leaks(path: Path, text: str | None = None) -> list[str]:
    """The modules the planners module at ``path`` imports from a room it must not."""
    here = planner_room(module_name(path))
    return sorted(m for m in import_targets(path, text)
                  if planner_room(m) in PLANNER_FORBIDDEN[here] and planner_room(m) != here)


def test_inside_planners_the_algorithms_know_no_paper_and_the_slices_not_each_other():
    modules = {n: p for n, p in house_modules().items() if planner_room(n) is not None}
    assert len(modules) > 30
    assert sorted(n for n in modules if planner_room(n) == "unplaced") == []
    bad = {n: hits for n, p in modules.items() if (hits := planner_leaks(p))}
    assert bad == {}


def test_the_rooms_of_planners_and_the_leaks_the_checker_sees():
    assert [planner_room(m) for m in (
        "planners.cem", "planners._checks", "planners.pick_place", "planners.pick_place.run",
        "planners.svr_mpc.episode", "planners", "planners.bench.clock", "planners.view",
        "planners.new_module", "dopt.mpc")] == [
        "algorithm", "algorithm", "pick_place", "pick_place", "svr_mpc", "tools", "tools",
        "tools", "unplaced", None]
    # parsed as if they were these files (nothing is written)
    algorithm = ROOT / "planners" / "ilqr.py"
    assert planner_leaks(algorithm, "from planners import keypoints\nfrom ._checks import x\n"
                                    "import dopt.mpc\n") == []
    assert planner_leaks(algorithm, "def f():\n    from planners.svr_mpc.settings import S\n") \
        == ["planners.svr_mpc", "planners.svr_mpc.settings"]
    assert planner_leaks(algorithm, "from planners.trial_progress import T\n") \
        == ["planners.trial_progress"]
    pick = ROOT / "planners" / "pick_place" / "fake.py"
    assert planner_leaks(pick, "from planners.svr_mpc import run_svr_mpc\n") \
        == ["planners.svr_mpc"]
    assert planner_leaks(pick, "from . import run\nfrom planners.cem import CEM\n"
                               "from planners.trial_progress import T\n") == []
    svr = ROOT / "planners" / "svr_mpc" / "fake.py"
    assert planner_leaks(svr, "from ..pick_place import tasks\n") == ["planners.pick_place",
                                                                     "planners.pick_place.tasks"]


# ------------------------------------------------------------------------------ circles
def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The import circles of ``graph`` ({module: the modules it imports}): every set of two or
    more modules each of which reaches every other, sorted, in order of their first module.
    (Reachability by a depth-first walk from each module: a few hundred modules.)"""
    reach = {}
    for start in graph:
        seen, todo = set(), [start]
        while todo:
            for nxt in graph.get(todo.pop(), ()):
                if nxt not in seen:
                    seen.add(nxt)
                    todo.append(nxt)
        reach[start] = seen
    found = {tuple(sorted({m} | {n for n in reach[m] if m in reach.get(n, ())}))
             for m in graph}
    return sorted(list(c) for c in found if len(c) > 1)


def import_graph(modules: dict[str, Path], root: Path = ROOT) -> dict[str, set[str]]:
    """{module: the modules of ``modules`` it imports} (``import_targets``)."""
    known = frozenset(modules)
    return {m: import_targets(p, known=known, root=root) & known for m, p in modules.items()}


def test_no_import_circles_anywhere():
    assert circles(import_graph(house_modules())) == []


def test_the_checker_finds_circles_through_lazy_imports_and_package_fronts(tmp_path):
    files = {
        "dopt/__init__.py": "",
        "dopt/a.py": "import numpy\ndef f():\n    from dopt.b import g\n",
        "dopt/b.py": "from dopt import a\n",                         # a <-> b, one lazy arrow
        "dopt/c.py": "from dopt.a import f\n",                       # into the circle only
        "planners/__init__.py": "",
        "planners/pipe/__init__.py": "from .run import run\n",
        "planners/pipe/run.py": "from . import steps\n",             # its package: loaded
        "planners/pipe/steps.py": "",
        "planners/pipe/late.py": "from planners.pipe import run\n",  # a submodule: no arrow
        "planners/loop/__init__.py": "from .core import go\n",
        "planners/loop/core.py": "from planners.loop import CONSTANT\n",   # the front's name
        "deformables/__init__.py": "",
        "experiments/x.py": "from y import h\n",
        "experiments/y.py": "if TYPE_CHECKING:\n    from x import k\n",
    }
    for rel, code in files.items():
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_text(code)
    graph = import_graph(house_modules(tmp_path), tmp_path)
    assert graph["planners.pipe.late"] == {"planners.pipe.run"}
    assert graph["dopt.c"] == {"dopt.a"}
    assert circles(graph) == [["dopt.a", "dopt.b"], ["planners.loop", "planners.loop.core"],
                              ["x", "y"]]


@settings(max_examples=60, deadline=None)
@given(st.integers(2, 9).flatmap(lambda n: st.sets(
    st.tuples(st.integers(0, n - 1), st.integers(0, n - 1)), max_size=3 * n)
    .map(lambda edges: (n, edges))))
def test_circles_are_the_strongly_connected_sets_of_a_transitive_closure(sized):
    """Against Warshall's transitive closure of the adjacency matrix: i and j share a circle
    when each reaches the other."""
    n, edges = sized
    names = [f"m{i}" for i in range(n)]
    graph = {m: set() for m in names}
    reach = np.zeros((n, n), dtype=bool)
    for i, j in edges:
        if i != j:
            graph[names[i]].add(names[j])
            reach[i, j] = True
    for k in range(n):
        reach |= reach[:, [k]] & reach[[k], :]
    mutual = reach & reach.T
    expected = sorted({tuple(names[j] for j in range(n) if mutual[i, j] or i == j)
                       for i in range(n) if mutual[i].any()})
    assert circles(graph) == [list(c) for c in expected]


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
