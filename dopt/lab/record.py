"""What a run writes and when it may: ``--record`` checked (not the --out folder, only from
committed code), the sweeps' --reuse-any flag, and OUT/summary.json with the run's provenance.
The shared argparse types and one-line errors are ``dopt.lab.cli``'s.

Settings: every summary records the settings it ran with in full (``settings_dict``: every
field of the resolved settings objects, not only a preset's name): Fig. 7 its
``PickPlaceSettings`` and their resolved scene, picker and stability bounds ("physics"); the
Panda's execution the same per goal; the key-particle experiment its reduction configs and the
scenes of its simulated goals; Fig. 4 the protocol and each row's ``SVRMPCSettings``. The
Table 1 experiments record the protocol's fields in the summary and every ``SVRMPCSettings``
field in each trial's params.

Recording: ``--record PATH`` is refused, one line naming the changed files, when files that can
change a result (dopt/, deformables/, planners/, experiments/, pyproject.toml, setup.py; the
exact rule is ``dopt.lab.provenance``'s) differ from HEAD, or outside a git checkout:
``record_problem`` says so before anything runs, and ``write_summary`` checks again before it
writes the copy (OUT/summary.json is written either way, marked "-dirty" in its provenance).
A run with --out only is never refused. ``record_problem`` also tries the places a run writes
(the --record file and the --out folder: a file created and removed, nothing overwritten), so
that a path the user cannot write fails before the first trial, not after the run.

Strict JSON: ``write_summary`` writes with ``dopt.lab.jsonio`` (a value that is not a finite
number is ``null`` with its reason beside it under "<field>_undefined"; no bare NaN).

Standard library and the lab only (pure Python), so the MuJoCo-free key-particle experiment
can use them without importing torch or MuJoCo.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

from dopt.lab.cli import file_problem, folder_problem


def write_problem(path: Path, folder: bool = False) -> str | None:
    """Why nothing can be written at ``path`` (a folder when ``folder``), found by trying: a
    temporary file is created and removed in the folder (or the nearest one that exists, for
    a path not created yet), and an existing file is opened for appending (nothing written).
    None when it can; creates nothing that stays."""
    import os
    import tempfile

    path = Path(path).absolute()
    if not folder and path.exists() and not path.is_file():
        return f"cannot write {path}: not a regular file"
    try:
        if not folder and path.is_file():
            with open(path, "a"):
                pass
            return None
        where = next(p for p in (path if folder else path.parent, *path.parents) if p.exists())
        fd, tmp = tempfile.mkstemp(dir=where, prefix=".write-test-")
        os.close(fd)
        os.unlink(tmp)
    except OSError as e:
        return f"cannot write {path}: {e.strerror or e}"
    return None


#: the packages every experiment needs after its trials (the plots extra: bars, plots, GIFs)
RUN_PACKAGES = ("tqdm", "matplotlib", "imageio")


def record_problem(record: Path | None, out: Path, root: Path | None = None) -> str | None:
    """Why the run cannot write what it will (one line, argparse's "argument --out: ..." or
    "argument --record: ..."): a package of ``RUN_PACKAGES`` missing, a place that fails
    ``write_problem``, --record the --out folder, or this code (``root``: default this
    checkout) not committed (``dopt.lab.provenance.CodeState.record_problem``). None when the
    run can write both. Every experiment asks it before its first trial."""
    import importlib.util

    missing = [m for m in RUN_PACKAGES if importlib.util.find_spec(m) is None]
    if missing:
        return (f"the run needs {', '.join(missing)} (the plots extra: pip install "
                f"'dopt[plots]')")
    if (problem := write_problem(out, folder=True)) is not None:
        return f"argument --out: {problem}"
    if record is None:
        return None
    if Path(record).absolute() == Path(out).absolute():
        return f"argument --record: {record} is the --out folder"
    if (problem := write_problem(record)) is not None:
        return f"argument --record: {problem}"
    from dopt.lab.provenance import code_state  # pure Python: no MuJoCo, no torch

    problem = code_state(root).record_problem()
    return None if problem is None else f"argument --record: {problem}"


def check_outputs(ap, args, default: str, files: tuple[str, ...] = ("summary.json",)
                  ) -> None:
    """Every experiment's last flag check: ``args.out`` defaults to ``results/<default>`` (a
    folder of this checkout's, ignored by git), then a usage error (one line, exit 2) when the
    run cannot write its --out or --record (``record_problem``) or one of the ``files`` it
    writes in --out (a folder there, a file it may not write: ``file_problem``), so that the
    run stops before its first trial rather than after its last."""
    if args.out is None:
        args.out = Path("results") / default
        if (problem := folder_problem(args.out)) is not None:
            ap.error(f"argument --out: (default) {problem}")
    if (problem := record_problem(args.record, args.out)) is not None:
        ap.error(problem)
    for name in files:
        if (problem := file_problem(Path(args.out) / name)) is not None:
            ap.error(f"argument --out: the run writes {name} there, but {problem}")


def settings_dict(settings) -> dict:
    """Every field of a settings object as plain JSON values: a dataclass (nested ones as
    dicts, ``dataclasses.asdict``), or a dict of them (per goal, per row), or a dict already.
    What a summary records under "settings": the resolved fields, not only a preset's name,
    so that the report can tell when the preset no longer gives them (an experiment's
    ``stale``, ``dopt.lab.experiment``)."""
    import dataclasses

    def plain(x):
        if dataclasses.is_dataclass(x) and not isinstance(x, type):
            return dataclasses.asdict(x)
        if isinstance(x, dict):
            return {k: plain(v) for k, v in x.items()}
        return x
    return json.loads(json.dumps(plain(settings)))


def add_reuse_argument(ap) -> None:
    """--reuse-any: a sweep's flag to reuse its finished trials across code changes
    deliberately (``dopt.lab.sweep.run_sweep(reuse="any")``; ``reuse_mode`` reads it)."""
    ap.add_argument("--reuse-any", action="store_true",
                    help="reuse every finished trial under --out, even one written by code "
                         "that may give another result (listed in summary.json under "
                         "reused_across_code); by default a trial is reused only when git "
                         "shows no change since its commit to dopt/, deformables/, planners/, "
                         "experiments/, pyproject.toml or setup.py")


def reuse_mode(args) -> str:
    """``run_sweep``'s ``reuse`` for parsed ``args``: "any" with --reuse-any, else
    "same-code"."""
    return "any" if getattr(args, "reuse_any", False) else "same-code"


def write_summary(summary: dict, out: Path, record: Path | None, script: str, argv,
                  indent: int = 2, root: Path | None = None) -> str:
    """Add this run's provenance (``script`` and its flags: ``argv``, or ``sys.argv[1:]`` when
    None) and the trials its sweeps reused deliberately across code changes ("reused_across_code":
    {key: why}, only when there are any) to ``summary``, write it to OUT/summary.json and, with
    --record, to that path too, each atomically (``dopt.atomic``). Returns the JSON text.

    Raises:
        OSError: a file cannot be written (a full disk): it names the file, which is left as
            it was.
        RuntimeError: --record from uncommitted code, outside git, or from code that changed
            during the run (HEAD is not the commit the provenance names, or the one the last
            sweep of this process ran at); the --record file is then not written
            (OUT/summary.json is).
    """
    from dopt import atomic
    from dopt.lab import jsonio
    from dopt.lab.provenance import code_state, provenance  # pure Python: no MuJoCo, no torch
    from dopt.lab.sweep import current_code, take_deliberate_reuse

    reused = take_deliberate_reuse()
    if reused:
        summary["reused_across_code"] = reused
    summary["provenance"] = provenance([script, *(sys.argv[1:] if argv is None else argv)],
                                       root)
    text = jsonio.dumps(summary, indent=indent)
    atomic.write_text(Path(out) / "summary.json", text)
    if record:
        state = code_state(root)
        problem = state.record_problem()
        # the commit the provenance names, and the one this process's last sweep ran at
        for started in (summary["provenance"]["git_commit"], current_code(root).commit):
            if problem is None and started != state.commit:
                problem = (f"the code changed during the run (it started at {started}, "
                           f"HEAD is now {state.commit})")
        if problem is not None:
            raise RuntimeError(f"{record} is not written: {problem}")
        atomic.write_text(record, text)
    return text


def record_figure(figure: Path, record: Path | None) -> Path | None:
    """With --record, copy the run's ``figure`` where RESULTS.md shows it beside the record:
    <docs>/images/<record's name>.png where the record lies in a folder named "results" (the
    docs layout: docs/results/X.json, docs/images/X.png), else <record's name>.png beside the
    record. Call it after ``write_summary`` wrote the record. Returns the copy's path; None
    without --record or without the figure (matplotlib not installed)."""
    from dopt import atomic

    if record is None or not Path(figure).is_file():
        return None
    record = Path(record)
    folder = (record.parent.parent / "images" if record.parent.name == "results"
              else record.parent)
    folder.mkdir(parents=True, exist_ok=True)
    dest = folder / f"{record.stem}.png"
    atomic.copy_file(figure, dest)
    return dest
