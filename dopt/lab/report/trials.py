"""The committed trials behind each summary: which files under ``<results dir>/runs/`` a
summary holds, the commits they were written at, and how many came from uncommitted code.

A summary's trials lie in the folder its command wrote them to (``--out
docs/results/runs/<sweep>``, read from the command of the run whose trials it holds, also for a
re-summarised file): ``trials/*.json`` there and the records packed in ``trials/pack.jsonl``
and ``pack.jsonl.gz`` (``dopt.lab.trialpack``, the one reader: a loose file overrides them), and
other folders where an experiment keeps them elsewhere. Where several summaries share a
folder, only the summary's own are taken: those its "trial_keys" names, else those its
experiment's ``trial_files`` hook picks (``dopt.lab.experiment``: a Fig. 7 summary's methods
and seeds, a clock check's seeds). Everything else in the folder is the summary's (the
docs/results test checks the counts against "trial_commits").

A trial's commit is read from its record's "code" (``dopt.lab.sweep`` writes it last, so the tail
of the file is enough; the whole file is parsed when it is not there). "-dirty", "unknown",
"no git" or no commit at all: uncommitted code, which no one can check out to rerun.
"""

from __future__ import annotations

import json
import re
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

from dopt.lab.experiment import experiment_of, own_trials
from dopt.lab.report.base import ReportError, Result, short_commit
from dopt.lab.trialpack import PackError, StoredTrial

#: a trial record's last keys: its code stamp, then (since 7b3eb64) its machine
TAIL = re.compile(r'"code":\s*(?P<code>\{[^{}]*\})\s*'
                  r'(?:,\s*"machine":\s*(?P<machine>null|\{[^{}]*\})\s*)?\}\s*$')
#: commits that name no code anyone can check out
NO_COMMIT = ("unknown", "no git", "")


@dataclass
class TrialInfo:
    """The committed trials of one summary.

    Attributes:
        folder: their sweep folder, relative to the results folder ("runs/<sweep>").
        files: the trials the summary holds (``dopt.lab.trialpack.StoredTrial``: a loose file or
            a packed record, read alike).
        commits: {commit: trials} over ``files``, as recorded.
        recorded: the trials the summary's "trial_commits" counts (None: it has none).
        machines: {"CPU, N cores": trials} over ``files``, None for those naming none.
    """

    folder: str
    files: list = field(default_factory=list)
    commits: Counter = field(default_factory=Counter)
    recorded: int | None = None
    machines: Counter = field(default_factory=Counter)

    @property
    def n(self) -> int:
        return len(self.files)

    @property
    def uncommitted(self) -> int:
        return sum(n for c, n in self.commits.items() if uncommitted(c))


def uncommitted(commit) -> bool:
    """Whether a recorded commit names code no one can check out."""
    return not isinstance(commit, str) or commit in NO_COMMIT or commit.endswith("-dirty")


def out_folder(results_dir: Path, command: str) -> Path | None:
    """The sweep folder a command's ``--out`` names under ``<results dir>/runs/``; None when
    it wrote its trials elsewhere."""
    m = re.search(r"--out[ =](\S+)", command or "")
    if not m:
        return None
    parts = Path(m.group(1).strip("'\"")).parts
    if "runs" not in parts or parts.index("runs") == 0 or parts[parts.index("runs") - 1] \
            != "results":
        return None
    return Path(results_dir).joinpath(*parts[parts.index("runs"):])


def trial_stamp(path: Path | StoredTrial) -> tuple[str, str | None]:
    """``(commit, machine)`` a trial records: its code's commit ("unknown" for none or an
    unreadable file) and its machine as "CPU, N cores" (``dopt.lab.provenance.machine()``; None
    for a trial that names none: a sweep's records carry it since 7b3eb64)."""
    try:
        text = path.read_text()
    except OSError:
        return "unknown", None
    tail = TAIL.search(text[-800:])
    try:
        rec = ({"code": json.loads(tail["code"]), "machine": json.loads(tail["machine"] or "null")}
               if tail else json.loads(text))
    except ValueError:
        return "unknown", None
    return record_stamp(rec)


def record_stamp(rec) -> tuple[str, str | None]:
    """:func:`trial_stamp` of a trial record already parsed."""
    code = rec.get("code") if isinstance(rec, dict) else None
    commit = code.get("commit") if isinstance(code, dict) else None
    where = rec.get("machine") if isinstance(rec, dict) else None
    return (commit if isinstance(commit, str) and commit else "unknown",
            machine_words(where) if isinstance(where, dict) else None)


def machine_words(machine: dict) -> str:
    """"CPU, N cores" of a ``dopt.lab.provenance.machine()`` record ("unnamed CPU" without one)."""
    cores = machine.get("cpus")
    return (f"{machine.get('cpu') or 'unnamed CPU'}"
            + (f", {cores} cores" if isinstance(cores, int) else ""))


def _total(value) -> int:
    """The trials a "trial_commits" counts ({commit: n}, nested by sweep)."""
    if isinstance(value, dict):
        return sum(_total(v) for v in value.values())
    return value if isinstance(value, int) else 0


def summary_trials(results_dir: Path, r: Result) -> TrialInfo | None:
    """The committed trials of summary ``r`` (None when its command wrote them elsewhere or
    its folder holds none). ReportError: a pack of them cannot be read."""
    folder = out_folder(results_dir, r.origin_command)
    if folder is None or not folder.is_dir():
        return None
    try:
        experiment = experiment_of(r)
        files = (experiment.trial_files(folder, r) if experiment is not None
                 else own_trials(folder, r))
    except PackError as e:
        raise ReportError(f"{r.path.name}: its trials cannot be read: {e}") from e
    stamps = [trial_stamp(p) for p in files]
    info = TrialInfo(folder.relative_to(results_dir).as_posix(), files,
                     Counter(commit for commit, _ in stamps),
                     _total(r.data["trial_commits"]) if "trial_commits" in r.data else None,
                     Counter(where for _, where in stamps))
    return info if files else None


def first_params(info: TrialInfo | None) -> dict | None:
    """The params of the summary's first baseline trial (else its first trial): every
    setting the trial ran with."""
    if info is None or not info.files:
        return None
    files = sorted(info.files, key=lambda p: ("-baseline-" not in p.stem, p.name))
    try:
        params = json.loads(files[0].read_text()).get("params")
    except (OSError, ValueError, AttributeError):
        return None
    return params if isinstance(params, dict) else None


def _commits_text(commits: dict) -> str:
    return ", ".join(f"`{short_commit(c)}` ({n})" for c, n in commits.items())


def trials_line(r: Result, info: TrialInfo | None) -> str:
    """The line RESULTS.md gives under a summary's source: its committed trials, their
    commits and those from uncommitted code; or, without committed trials, the summary's own
    "trial_commits"; "" for a summary without either."""
    recorded = r.data.get("trial_commits")
    if info is None:
        if not recorded:
            return ""
        parts = []
        for k, v in recorded.items():
            if isinstance(v, dict):                 # nested by sweep (the clock check's)
                parts += [f"{k} `{short_commit(c)}` ({n})" for c, n in v.items()]
            else:
                parts.append(f"`{short_commit(k)}` ({v})")
        return ("Trial commits (the summary's \"trial_commits\"; its trials are not "
                f"committed): {', '.join(parts)}.")
    line = (f"Trials: {info.n} committed under `{info.folder}/`, written at "
            f"{_commits_text(dict(sorted(info.commits.items(), key=lambda kv: -kv[1])))}")
    if info.recorded is not None and info.recorded != info.n:
        line += f" (its \"trial_commits\" counts {info.recorded})"
    if info.uncommitted:
        line += f"; **{uncommitted_note(info)}**"
    where = machines_text(info)
    return line + (f"; {where}" if where else "") + "."


def machines_text(info: TrialInfo) -> str:
    """Where the trials ran, as they record it: their machines with counts, and how many name
    none (their times, a CPU-time clock's lags included, may then come from several
    machines: a sweep resumed elsewhere runs at another speed)."""
    named = sorted(((m, n) for m, n in info.machines.items() if m is not None),
                   key=lambda kv: -kv[1])
    unnamed = info.machines.get(None, 0)
    parts = [f"ran on {', '.join(f'{m} ({n})' for m, n in named)}"] if named else []
    if unnamed:
        parts.append(("machine not recorded" if unnamed == info.n else
                      f"{unnamed} with no machine recorded") + " (times may mix machines)")
    return "; ".join(parts)


def uncommitted_note(info: TrialInfo | None) -> str:
    """"N of M trials from uncommitted code" ("" when none is)."""
    if info is None or not info.uncommitted:
        return ""
    return f"{info.uncommitted} of {info.n} trials from uncommitted code"
