"""Command-line plumbing shared by every CLI of the project (``python -m dopt.bench``,
``python -m planners.bench``, ``python -m deformables.bench`` and the experiment scripts).
Standard library only: importing it loads neither MuJoCo nor torch.

The ``*_int`` / ``*_float``, ``int_at_least``, ``number_list``, ``choices_type``,
``output_dir``, ``output_file`` and ``existing_dir`` functions are argparse ``type=`` callables:
a bad value becomes a usage error (exit 2) naming the flag, before anything runs or any
folder is created; :class:`ArgumentParser`, every CLI's parser, prints it as one line.
``guarded`` turns a failure of a CLI's main into one line on stderr and exit status 1 (the
traceback with ``DOPT_TRACEBACK=1``).
"""
from __future__ import annotations

import argparse
import contextlib
import functools
import math
import os
import sys
import traceback
from collections.abc import Callable, Sequence
from pathlib import Path

#: set to 1 for the full traceback of a failed script instead of its one-line error
TRACEBACK_ENV = "DOPT_TRACEBACK"
#: the --help epilog of every script: exit codes and how to see a traceback
EPILOG = (f"Exit status: 0 done; 1 a trial or the run failed (one line 'SCRIPT: error: ...' on "
          f"stderr;\n{TRACEBACK_ENV}=1 in the environment prints the full traceback); 2 bad "
          "arguments;\n130 or 143 interrupted by Ctrl-C or SIGTERM (what finished is kept: the "
          "same command resumes).")


#: script file -> the name a console script runs it under (``shown_as``): what its usage,
#: help and error lines call it
_SHOWN: dict[str, str] = {}


def shown_name(prog: str) -> str:
    """The name that the script ``prog`` (its file name, e.g. "mpc.py") goes by in what it
    prints: the console script's that runs it (``shown_as``), else ``prog``."""
    return _SHOWN.get(prog, prog)


@contextlib.contextmanager
def shown_as(script: str, name: str):
    """While the block runs, the script file ``script`` calls itself ``name`` (its console
    script, e.g. ``dopt-mpc`` for "mpc.py") in its usage, help and one-line errors; its
    ``prog``, and what is derived from it (the default --out folder), stay the file's."""
    before = _SHOWN.get(script)
    _SHOWN[script] = name
    try:
        yield
    finally:
        if before is None:
            _SHOWN.pop(script, None)
        else:
            _SHOWN[script] = before


class ArgumentParser(argparse.ArgumentParser):
    """argparse's parser with usage errors on one line: "PROG: error: MESSAGE (PROG --help
    lists the flags)" on stderr, exit status 2, where plain argparse prints its usage block
    first. PROG is ``shown_name(prog)``: a console script's own name where one runs it."""

    def _get_formatter(self):
        return self.formatter_class(prog=shown_name(self.prog))

    def error(self, message: str):
        prog = shown_name(self.prog)
        self.exit(2, f"{prog}: error: {' '.join(message.split())} "
                     f"({prog} --help lists the flags)\n")


def choices_list(text: str, choices: Sequence[str], what: str) -> list[str]:
    """Comma-separated names -> list, each one of ``choices``.

    Raises:
        ValueError: an unknown name, or none at all (the message names ``what`` and lists
            ``choices``).
    """
    names = [name.strip() for name in text.split(",")]
    bad = [name for name in names if name not in choices]
    if bad or not names:
        raise ValueError(f"unknown {what} {bad}; choose from {', '.join(choices)}")
    return no_repeats(names, what)


def no_repeats(names: list[str], what: str) -> list[str]:
    """``names`` unchanged. Raises ValueError naming ``what`` and the names given twice."""
    repeated = sorted({name for name in names if names.count(name) > 1})
    if repeated:
        raise ValueError(f"{what} {', '.join(repeated)} given twice")
    return names


def choices_type(choices: Sequence[str], what: str) -> Callable[[str], list[str]]:
    """``choices_list`` as an argparse ``type=`` (the message names ``what``)."""
    def parse(text: str) -> list[str]:
        try:
            return choices_list(text, choices, what)
        except ValueError as e:
            raise argparse.ArgumentTypeError(str(e)) from None
    return parse


def _number(kind, low: float, strict: bool):
    def parse(text: str):
        try:
            v = kind(text)
        except ValueError:
            what = "an integer" if kind is int else "a number"
            raise argparse.ArgumentTypeError(f"{text!r} is not {what}") from None
        if not math.isfinite(v) or (v <= low if strict else v < low):
            least = f">= {low + 1:g}" if strict and kind is int else \
                f"{'>' if strict else '>='} {low:g}"
            raise argparse.ArgumentTypeError(f"must be {least}, got {text}")
        return v
    return parse


#: an int >= 1
positive_int = _number(int, 0, strict=True)
#: an int >= 0
nonneg_int = _number(int, 0, strict=False)
#: a finite float > 0
positive_float = _number(float, 0.0, strict=True)
#: a finite float >= 0
nonneg_float = _number(float, 0.0, strict=False)


def number_in(kind, low: float, high: float) -> Callable[[str], float]:
    """An argparse ``type=``: a finite number of ``kind`` (int or float) with
    ``low <= value <= high``."""
    at_least = _number(kind, low, strict=False)

    def parse(text: str):
        v = at_least(text)
        if v > high:
            raise argparse.ArgumentTypeError(f"must be <= {high:g}, got {text}")
        return v
    return parse


def int_at_least(low: int) -> Callable[[str], int]:
    """An argparse ``type=``: an int >= ``low``."""
    return _number(int, low, strict=False)


def number_list(kind, low: float, what: str = "values",
                strict: bool = False) -> Callable[[str], list]:
    """An argparse ``type=``: comma-separated finite numbers of ``kind`` (int or float), each
    >= ``low`` (> ``low`` when ``strict``), none given twice, no empty item."""
    def parse(text: str) -> list:
        items = [item.strip() for item in text.split(",")]
        if not text.strip() or any(not item for item in items):
            raise argparse.ArgumentTypeError(f"{text!r} is not a comma-separated list of "
                                             f"{what} (empty item)")
        vals = []
        where = f" in {text!r}" if len(items) > 1 else ""
        for item in items:
            try:
                v = kind(item)
            except ValueError:
                raise argparse.ArgumentTypeError(
                    f"{item!r}{where} is not {'an integer' if kind is int else 'a number'}"
                ) from None
            if not math.isfinite(v) or (v <= low if strict else v < low):
                raise argparse.ArgumentTypeError(f"{what} must be finite and "
                                                 f"{'>' if strict else '>='} {low:g}, got "
                                                 f"{item}{where}")
            vals.append(v)
        repeated = sorted({v for v in vals if vals.count(v) > 1})
        if repeated:
            raise argparse.ArgumentTypeError(f"{', '.join(f'{v:g}' for v in repeated)} given "
                                             f"twice in {text!r}")
        return vals
    return parse


def _nearest_existing(path: Path) -> Path:
    for p in (path, *path.parents):
        if p.exists():
            return p
    return Path.cwd()


def folder_problem(path: Path) -> str | None:
    """Why ``path`` cannot be an output folder (exists as a file, not writable, under a file
    or an unwritable folder), or None; creates nothing."""
    path = Path(path).absolute()
    if path.exists():
        if not path.is_dir():
            return f"{path} exists and is not a folder"
        if not os.access(path, os.W_OK | os.X_OK):
            return f"{path} is not writable"
        return None
    parent = _nearest_existing(path)
    if not parent.is_dir():
        return f"cannot create {path}: {parent} is not a folder"
    if not os.access(parent, os.W_OK | os.X_OK):
        return f"cannot create {path}: {parent} is not writable"
    return None


def file_problem(path: Path) -> str | None:
    """Why a file cannot be written at ``path`` (a folder there, not writable, its folder
    cannot be created or written), or None; creates nothing."""
    path = Path(path).absolute()
    if path.is_dir():
        return f"{path} is a folder"
    if path.exists():
        return None if os.access(path, os.W_OK) else f"{path} is not writable"
    return folder_problem(path.parent)


def output_dir(text: str) -> Path:
    """An argparse ``type=``: a folder that exists and is writable or can be created (it is
    not created here)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty path is not a folder")
    problem = folder_problem(Path(text))
    if problem:
        raise argparse.ArgumentTypeError(problem)
    return Path(text)


def output_file(text: str) -> Path:
    """An argparse ``type=``: a file that can be written (or created, with its folder)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty path is not a file")
    problem = file_problem(Path(text))
    if problem:
        raise argparse.ArgumentTypeError(problem)
    return Path(text)


def existing_dir(text: str) -> Path:
    """An argparse ``type=``: a folder that exists."""
    if not Path(text).is_dir():
        raise argparse.ArgumentTypeError(f"{text} is not a folder" if Path(text).exists()
                                         else f"{text} does not exist")
    return Path(text)


def one_line(e: BaseException) -> str:
    """"ErrorType: message" on one line."""
    return f"{type(e).__name__}: {' '.join(str(e).split())}"


def resume_command() -> str:
    """The command line of this process, as a shell would take it again."""
    import shlex
    return " ".join(shlex.quote(a) for a in ["python", *sys.argv])


def guarded(script: str):
    """Decorator of a script's ``main(argv) -> int``: an exception becomes one line
    "SCRIPT: error: ErrorType: message" on stderr and exit status 1 (the traceback first when
    the environment sets DOPT_TRACEBACK=1); Ctrl-C exits 130 with one line, and an
    interrupted sweep (``dopt.lab.sweep.SweepInterrupted``) its ``exit_code`` (130, SIGTERM 143)
    with its message and the command that resumes it. Usage errors (argparse's SystemExit 2)
    pass through. SCRIPT is ``shown_name(script)``: a console script's own name where one runs
    it."""
    def wrap(main):
        @functools.wraps(main)
        def run(*args, **kwargs) -> int:
            try:
                return main(*args, **kwargs)
            except KeyboardInterrupt as e:
                sweep = hasattr(e, "exit_code")
                print(f"{shown_name(script)}: {e if sweep else 'interrupted'}"
                      + (f"; to resume: {resume_command()}" if sweep else ""), file=sys.stderr)
                return int(getattr(e, "exit_code", 130))
            except Exception as e:
                if os.environ.get(TRACEBACK_ENV, "") not in ("", "0"):
                    traceback.print_exc()
                print(f"{shown_name(script)}: error: {one_line(e)}", file=sys.stderr)
                return 1
        return run
    return wrap
