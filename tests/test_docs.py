"""Every ```python block of README.md and docs/*.md runs.

The blocks of one file run in order in one namespace (a later block may use the names of an
earlier one), in a fresh Python process (so a block can neither lean on nor disturb what the
test session imported), from an empty temporary folder, with MUJOCO_GL=egl. A block fenced as
```python no-run is skipped. A failure names the file, the block and its first line, with the
traceback in the file's own line numbers.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
FENCE = re.compile(r"^(?P<indent> {0,3})(?P<fence>`{3,}|~{3,})\s*(?P<info>[^`]*?)\s*$")
#: seconds one file's blocks may take together
TIMEOUT = 600

# runs in the child: executes the blocks, stops at the first failure and says which
RUNNER = r"""
import json, sys, traceback
blocks = json.load(sys.stdin)
namespace = {"__name__": "__main__"}
for b in blocks:
    # pad so that a traceback's line numbers are the Markdown file's
    code = compile("\n" * b["line"] + b["code"], b["file"], "exec")
    try:
        exec(code, namespace)
    except BaseException:
        print("\n@@FAILED@@ " + json.dumps(b["index"]), file=sys.stderr)
        traceback.print_exc()
        sys.exit(1)
"""


def python_blocks(text: str) -> list[dict]:
    """The fenced code blocks of a Markdown text whose info string is "python":
    [{"line": the opening fence's line number (1-based; the code starts on the next),
    "code", "run": False for "python no-run"}]."""
    blocks, lines, i = [], text.splitlines(), 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        fence, words = m["fence"], m["info"].split()
        end = i + 1
        while end < len(lines):
            close = FENCE.match(lines[end])
            if close and close["fence"][0] == fence[0] and len(close["fence"]) >= len(fence) \
                    and not close["info"]:
                break
            end += 1
        if words and words[0] == "python":
            indent = len(m["indent"])
            body = [line[indent:] if line[:indent].strip() == "" else line
                    for line in lines[i + 1:end]]
            blocks.append({"line": i + 1, "code": "\n".join(body) + "\n",
                           "run": "no-run" not in words[1:]})
        i = end + 1
    return blocks


def test_python_blocks_are_found_and_no_run_is_skipped():
    text = "\n".join(["# t", "```python", "a = 1", "```", "text", "```python no-run",
                      "boom()", "```", "````python", "b = a + 1", "```", "````", "```bash",
                      "ls", "```", "  ```python", "  c = 2", "  ```"])
    blocks = python_blocks(text)
    assert [b["run"] for b in blocks] == [True, False, True, True]
    assert blocks[0] == {"line": 2, "code": "a = 1\n", "run": True}
    assert blocks[2]["code"] == "b = a + 1\n```\n"                 # a longer fence nests
    assert blocks[3]["code"] == "c = 2\n"


def test_guide_has_runnable_examples():
    blocks = python_blocks((ROOT / "docs" / "GUIDE.md").read_text())
    assert sum(b["run"] for b in blocks) >= 4


@pytest.mark.slow
@pytest.mark.parametrize("doc", DOCS, ids=[p.relative_to(ROOT).as_posix() for p in DOCS])
def test_python_blocks_run(doc: Path, tmp_path):
    name = doc.relative_to(ROOT).as_posix() if doc.is_relative_to(ROOT) else str(doc)
    blocks = [dict(b, file=str(doc), index=k) for k, b in enumerate(python_blocks(doc.read_text()))
              if b["run"]]
    if not blocks:
        return                                         # nothing to run in this file
    env = {**os.environ, "MUJOCO_GL": "egl"}
    env.setdefault("OMP_NUM_THREADS", "1")             # torch's pool vs the simulation threads
    env.setdefault("OPENBLAS_NUM_THREADS", "1")
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    run = subprocess.run([sys.executable, "-c", RUNNER], input=json.dumps(blocks), text=True,
                         capture_output=True, cwd=tmp_path, env=env, timeout=TIMEOUT)
    if run.returncode == 0:
        return
    marker = re.search(r"@@FAILED@@ (\d+)", run.stderr)
    if marker is None:
        pytest.fail(f"{name}: the python blocks did not run (exit {run.returncode}):\n"
                    f"{run.stderr[-4000:]}")
    b = blocks[int(marker.group(1))]
    first = next((line for line in b["code"].splitlines() if line.strip()), "")
    trace = run.stderr[marker.end():].strip()
    pytest.fail(f"{name}: python block {b['index'] + 1} (fenced at line {b['line']}: "
                f"`{first.strip()}`) failed:\n{trace[-4000:]}", pytrace=False)


def test_the_docs_stay_short():
    """README.md is read in minutes (at most 150 lines and 1,500 words), docs/ARCHITECTURE.md
    is a map (at most 150 lines), docs/DESIGN-NOTES.md keeps reasons, not measurements (at
    most 4,000 words)."""
    def size(path: Path) -> tuple[int, int]:
        text = path.read_text()
        return len(text.splitlines()), len(text.split())

    lines, words = size(ROOT / "README.md")
    assert lines <= 150 and words <= 1500, (lines, words)
    assert size(ROOT / "docs" / "ARCHITECTURE.md")[0] <= 150
    assert size(ROOT / "docs" / "DESIGN-NOTES.md")[1] <= 4000
