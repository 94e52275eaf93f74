"""No committed file names an absolute folder of a machine (issue 93): a command, a setting or
a docstring that does means nothing on another machine and tells a reader where someone kept
their files. Every file git tracks is read, trial packs (gzip) as their text.

Recorded result fields are never edited after the fact, so the result files recorded before the
writers stopped naming such folders (``dopt.lab.provenance.command_line``, ``root_relative``) are
exempt by name (``RECORDED_BEFORE``, a frozen list): a new result with an absolute path fails,
and so does an exempt file that no longer holds one (the list only shrinks). The report shows
their commands relative (``dopt.lab.provenance.recorded_command``,
tests/dopt/lab/test_provenance.py)."""

from __future__ import annotations

import gzip
import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: an absolute path of a machine: a folder under one of the places machines keep their users'
#: and jobs' files (POSIX), or a Windows user's folder
MACHINE_PATH = re.compile(
    r"(?<![\w.~$-])/(?:home|root|Users|work|tmp|mnt|media|scratch|data|srv|opt|var|private"
    r"|builds|nfs|gpfs|lustre|cluster)/[\w.-]"
    r"|(?<!\w)[A-Z]:\\{1,2}Users\\")

#: the result files recorded, before the fix, with such a path in their recorded fields (their
#: commands, their settings' "layouts", a library's error message, their trials' params)
RECORDED_BEFORE = frozenset({
    "docs/results/clock-model.json",
    "docs/results/cloth-steps-100-fast.json",
    "docs/results/cloth-steps-100-newton.json",
    "docs/results/cloth-warp-h200-100-w1-256.json",
    "docs/results/cloth-warp-h200-100.json",
    "docs/results/cloth-warp-h200-8.json",
    "docs/results/cloth-warp-h200-eager.json",
    "docs/results/cloth-warp-h200-graph-capture.json",
    "docs/results/fig4-clutter-authors-full.json",
    "docs/results/fig4-clutter-authors.json",
    "docs/results/fig7-random-reach.json",
    "docs/results/key-particles-authors.json",
    "docs/results/svr-explain-clutter-authors-notail.json",
    "docs/results/svr-explain-clutter-authors.json",
    "docs/results/table1-clutter-authors-ms150.json",
    "docs/results/table1-clutter-authors-unoptimised.json",
    "docs/results/table1-clutter-authors.json",
    "docs/results/runs/fig4-clutter-authors-full/trials/pack.jsonl.gz",
    "docs/results/runs/fig4-clutter-authors/trials/pack.jsonl.gz",
    "docs/results/runs/svr-explain-clutter-authors-notail/trials/pack.jsonl.gz",
    "docs/results/runs/svr-explain-clutter-authors/trials/pack.jsonl.gz",
    "docs/results/runs/table1-clutter-authors-ms150/trials/pack.jsonl.gz",
    "docs/results/runs/table1-clutter-authors/trials/pack.jsonl.gz",
})


def tracked_files() -> list[str]:
    try:
        proc = subprocess.run(["git", "-C", str(ROOT), "ls-files", "-z"], capture_output=True,
                              timeout=60)
    except (OSError, subprocess.SubprocessError):
        proc = None
    if proc is None or proc.returncode != 0:
        pytest.skip("not a git checkout: no committed files to read")
    return sorted(f for f in proc.stdout.decode().split("\0") if f)


def machine_paths(data: bytes) -> list[str]:
    """The machine paths in a file's bytes (gzip ones decompressed), each with its next
    characters, in order; none in a file that is not text."""
    if data[:2] == b"\x1f\x8b":
        data = gzip.decompress(data)
    text = data.decode("utf-8", errors="ignore")
    return [text[m.start():m.start() + 60].split()[0] for m in MACHINE_PATH.finditer(text)]


def test_the_pattern_finds_machine_paths_and_nothing_else():
    # the paths are built of parts, so that this file names none
    work, tmp, home = "/" + "work/shared/a", "/" + "tmp/o", "/" + "home/u/layouts"
    users = "C:" + "\\\\Users\\\\me"
    found = machine_paths(f'"command": "python x.py --layouts {work} --out {tmp}",\n'
                          f'~/notes /usr/bin/env /dev/null /proc/cpuinfo ${{HOME}}x a/home/b '
                          f'docs/results/runs/ "{users}" ../shared/seeds/p.txt\n'.encode())
    assert found == [work, tmp + '",', users + '"']
    assert machine_paths(gzip.compress(f'{{"layouts": "{home}"}}'.encode())) == [home + '"}']
    assert machine_paths(b"\x89PNG\r\n\x1a\n\x00\x00") == []


def test_no_committed_file_names_a_folder_of_a_machine():
    assert all(f.startswith("docs/results/") for f in RECORDED_BEFORE)   # result files only
    files = tracked_files()
    found = {f: hits for f in files if (hits := machine_paths((ROOT / f).read_bytes()))}
    assert {f: hits[:3] for f, hits in found.items() if f not in RECORDED_BEFORE} == {}
    assert sorted(RECORDED_BEFORE - set(found)) == []      # an exempt file without one: drop it
