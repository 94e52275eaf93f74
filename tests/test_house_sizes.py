"""The house stays readable: no module of dopt, deformables, planners or experiments over 600
lines and no function (method, nested function) over 80 lines, counted from its ``def`` line
to its last line with ast. A new exception needs a reason written here."""

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("dopt", "deformables", "planners", "experiments")
MAX_MODULE_LINES = 600
MAX_FUNCTION_LINES = 80


def sources():
    for package in PACKAGES:
        yield from sorted((ROOT / package).rglob("*.py"))


def test_sources_are_found():
    assert len(list(sources())) > 50


def test_no_module_over_600_lines():
    long = {str(p.relative_to(ROOT)): n for p in sources()
            if (n := len(p.read_text().splitlines())) > MAX_MODULE_LINES}
    assert not long, long


def test_no_function_over_80_lines():
    long = {}
    for path in sources():
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                if n > MAX_FUNCTION_LINES:
                    long[f"{path.relative_to(ROOT)}:{node.lineno} {node.name}"] = n
    assert not long, long
