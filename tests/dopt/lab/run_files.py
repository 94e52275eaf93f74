"""Checks of what an experiment's run writes, shared by the slices' experiment tests: a strict
JSON reader (no bare NaN), a script run by path as a user runs it, and a rewrite on a full disk
(a file-size limit) that must keep the old file whole and name it."""

import errno
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from dopt.lab import provenance
from tests.dopt.lab.test_atomic_write import file_size_limit

ROOT = Path(__file__).resolve().parents[3]


def strict(text: str):
    """json.loads that rejects NaN, Infinity and -Infinity (as JSON itself does)."""
    def refuse(name):
        raise ValueError(f"bare {name}")
    return json.loads(text, parse_constant=refuse)


def strict_files(folder: Path) -> int:
    """Parse every JSON file (and every line of every JSON Lines file) under ``folder``
    strictly (raises on a bare NaN); the number of files read."""
    files = [p for p in folder.rglob("*.json*") if p.is_file()]
    for path in files:
        lines = path.read_text().splitlines() if path.suffix == ".jsonl" else [path.read_text()]
        for line in filter(None, lines):
            strict(line)
    return len(files)


def run_script(name: str, *args) -> None:
    """Run ``python experiments/<name> args`` as a process; assert it exits 0."""
    proc = subprocess.run([sys.executable, str(ROOT / "experiments" / name), *map(str, args)],
                          capture_output=True, text=True, timeout=900,
                          env={**os.environ, "MUJOCO_GL": "egl"})
    assert proc.returncode == 0, proc.stderr[-3000:]


def rewrite_on_a_full_disk(tmp_path: Path, monkeypatch, write, name: str) -> None:
    """``write(folder, big=False)`` makes ``folder/name``; ``write(folder, big=True)`` under a
    4 kB file-size limit (RLIMIT_FSIZE: a write fails as on a full disk) must fail naming the
    file and leave the old one whole with no temporary file; with room again it rewrites it.
    Provenance is read without git (git may write its index: not under the limit)."""
    monkeypatch.setattr(provenance, "provenance", lambda *a, **k: {"git_commit": "c0ffee"})
    write(tmp_path, big=False)
    path = tmp_path / name
    old = path.read_bytes()
    if name.endswith(".json"):
        json.loads(old)
    with file_size_limit(4096), pytest.raises(OSError) as exc:
        write(tmp_path, big=True)
    print(exc.value)
    assert exc.value.errno == errno.EFBIG and str(path) in str(exc.value)
    assert path.read_bytes() == old                               # whole, as it was
    assert not [p for p in path.parent.iterdir() if p.name.startswith(".tmp-")]
    write(tmp_path, big=True)                                     # room again: rewritten
    assert path.read_bytes() != old and path.stat().st_size > 4096
