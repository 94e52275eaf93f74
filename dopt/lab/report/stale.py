"""Stale results, the generic part: a result recorded on a named preset that no longer
resolves to the fields it ran with (each experiment's ``stale`` hook compares its recorded
settings with what its preset resolves to today, with ``_diff``), or whose trials ran on code
that has changed since in the files that compute them (``code_findings``, over the git
pathspecs an experiment names), and how the pages show the findings (``stale_note``).
"""

from __future__ import annotations

import functools
import json
import re
import shlex
import subprocess
from pathlib import Path

from dopt.lab.dicts import flatten
from dopt.lab.report.base import Result


def base_commit(commit) -> str | None:
    """A recorded commit without "-dirty" (None when there is none)."""
    return commit.removesuffix("-dirty") if isinstance(commit, str) and commit else None


def _same(a, b) -> bool:
    """Equal as JSON values (tuples and lists alike; 1 and 1.0 alike)."""
    return json.loads(json.dumps(a)) == json.loads(json.dumps(b))


def _value(v) -> str:
    return f"{v:g}" if isinstance(v, float) else json.dumps(v)


def _diff(recorded: dict, today: dict, skip=()) -> list[str]:
    """"field recorded -> today" of the fields both hold that differ (``skip`` left out)."""
    rec, now = flatten(recorded), flatten(today)
    return [f"{k} {_value(rec[k])} -> {_value(now[k])}" for k in now
            if k in rec and k.split(".")[0] not in skip and k not in skip
            and not _same(rec[k], now[k])]


def command_preset(command: str) -> tuple[str | None, set]:
    """The ``--preset`` a command names (None: none) and the flags it gives."""
    try:
        words = shlex.split(command)
    except ValueError:
        words = command.split()
    flags = {w.split("=")[0] for w in words if w.startswith("--")}
    for i, w in enumerate(words):
        if w == "--preset" and i + 1 < len(words):
            return words[i + 1], flags
        if w.startswith("--preset="):
            return w.split("=", 1)[1], flags
    return None, flags


def _head(root: str) -> str | None:
    """HEAD's sha of the git checkout at ``root`` (None: not one)."""
    try:
        proc = subprocess.run(["git", "-C", root, "rev-parse", "HEAD"], capture_output=True,
                              text=True, timeout=60, check=False)
    except (OSError, subprocess.TimeoutExpired):
        return None
    return proc.stdout.strip() if proc.returncode == 0 else None


@functools.cache
def _changed_since(root: str, commit: str, head: str, paths: tuple[str, ...]
                   ) -> tuple[str, ...] | None:
    """The files of ``paths`` (git pathspecs) that differ between ``commit`` and ``head`` in the
    git checkout at ``root``; None where git cannot say (a commit it does not know)."""
    try:
        proc = subprocess.run(["git", "-C", root, "diff", "--name-only", commit, head, "--",
                               *(f":(top{',exclude' if p.startswith(':(exclude)') else ''})"
                                 + p.removeprefix(":(exclude)") for p in paths)],
                              capture_output=True, text=True, timeout=60, check=False)
    except (OSError, subprocess.TimeoutExpired):
        return None
    return tuple(proc.stdout.split()) if proc.returncode == 0 else None


def _verification(root: Path, r: Result, head: str, paths: tuple[str, ...]) -> str | None:
    """What ``verified/<result>`` (experiments/verify_trials.py) says of ``r`` today: None
    without one, or when the code that computes trials changed since it ran; "" where every
    rerun gave its recorded outcome at a commit with today's code; a finding where a rerun
    differed."""
    path = Path(root) / "verified" / r.name
    try:
        v = json.loads(path.read_text())
        commit = v["provenance"]["git_commit"]
    except (OSError, ValueError, KeyError, TypeError):
        return None
    base = base_commit(commit)
    if not base or base != commit or _changed_since(str(root), base, head, paths) != ():
        return None
    if v.get("all_equal") is True:
        return "verified"
    return (f"the code at {base[:8]} reruns {sum(not t.get('equal') for t in v['trials'])} of "
            f"{len(v['trials'])} sampled trials to other outcomes (verified/{r.name})")


def code_findings(r: Result, root: Path, paths: tuple[str, ...]) -> list[str]:
    """Per commit its trials ran on (``trial_commits``), of a result on Table 1's protocol:
    the files that compute its trials and changed since, one finding each (none: the code is
    the same, git cannot say, or a sample of its trials reran to the last bit at a commit whose
    code is today's: ``experiments/verify_trials.py``). ``paths``: the git pathspecs of the
    files that compute its trials."""
    if not isinstance(r.data.get("trial_commits"), dict):
        return []
    head = _head(str(root))
    if head is None:
        return []
    checked = _verification(root, r, head, paths)
    if checked is not None and not checked.startswith("the code "):
        return []                        # a sample reran to the last bit since the change
    out = [checked] if checked else []
    for commit in sorted(r.data["trial_commits"]):
        base = base_commit(commit)
        changed = _changed_since(str(root), base, head, paths) if base else None
        if changed:
            more = f" and {len(changed) - 3} more" if len(changed) > 3 else ""
            out.append(f"the code that computes its trials changed since {base[:8]} ("
                       + ", ".join(changed[:3]) + more + ")")
    return out


def stale_note(findings: list[str] | None, *, short: bool = False) -> str:
    """How a page shows a result's findings: "" when current; the README (``short``) gives
    the first finding and how many more."""
    if findings is None or not findings:
        return ""
    if short:
        more = f" (and {len(findings) - 1} more)" if len(findings) > 1 else ""
        return f"**stale**: {_arrows(findings[0])}{more}"
    presets = [_arrows(f) for f in findings if not f.startswith("the code ")]
    code = [f for f in findings if f.startswith("the code ")]
    return ("**Stale**: " + "; ".join(
        ([f"recorded on presets that today's code resolves otherwise ({'; '.join(presets)})"]
         if presets else []) + code) + "; rerun the command to record it on today's code.")


def _arrows(text: str) -> str:
    return re.sub(r" -> ", " → ", text)
