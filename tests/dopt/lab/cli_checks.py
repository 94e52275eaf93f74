"""Checks of the command-line contract (``dopt.lab.cli.ArgumentParser``), shared by the tests of
the commands built on it (the slices' experiments, the report, the benches): a bad argument is
one line on stderr and exit 2 before anything runs or any folder is created; --out and
--record must be places that can be written; --help shows every flag a source file adds; a
failed trial is listed with the run's provenance. Each ``main`` runs in-process."""

import argparse
import ast
import os
import stat
from pathlib import Path

import pytest

import dopt.lab.cli
from dopt.lab import cli


def refuse_runs(monkeypatch, targets) -> None:
    """Patch each ``(module, name)`` of ``targets`` with a function that fails the test: a probe
    that parses by mistake fails instead of running an experiment or a bench."""
    def stop(*args, **kwargs):
        raise AssertionError("the arguments were accepted")
    for module, name in targets:
        monkeypatch.setattr(module, name, stop)


def usage_error(capsys, main, argv: list, hint: bool = True) -> str:
    """Run ``main(argv)``; assert argparse's exit 2 with one line on stderr (no usage block, no
    traceback; with ``hint``, ending in the pointer to --help); return stderr."""
    with pytest.raises(SystemExit) as exc:
        main([str(a) for a in argv])
    err = capsys.readouterr().err
    assert exc.value.code == 2, err
    assert "Traceback" not in err
    assert len(err.strip().splitlines()) == 1, err                 # one line, no usage block
    if hint:
        assert err.rstrip().endswith("--help lists the flags)"), err
    return err


def bad_argument_is_a_usage_error_and_creates_nothing(tmp_path, capsys, main, script: str,
                                                      argv: list, message: str) -> None:
    """``main`` (the experiment ``script``'s) refuses ``argv`` with a usage error holding
    ``message`` and its script's name, and --out is not created."""
    out = tmp_path / "out"
    err = usage_error(capsys, main, [*argv, "--out", out])
    assert message in err and f"{script}.py: error:" in err
    assert not out.exists()


# --------------------------------------------------------------------------- --out, --record
def out_and_record_must_be_writable_places(tmp_path: Path, capsys, main) -> None:
    afile = tmp_path / "afile"
    afile.write_text("")
    err = usage_error(capsys, main, ["--out", afile])
    assert f"argument --out: {afile} exists and is not a folder" in err
    err = usage_error(capsys, main, ["--out", afile / "sub"])
    assert f"argument --out: cannot create {afile / 'sub'}: {afile} is not a folder" in err
    assert "argument --out: an empty path" in usage_error(capsys, main, ["--out", ""])
    out = tmp_path / "out"
    err = usage_error(capsys, main, ["--out", out, "--record", tmp_path])
    assert f"argument --record: {tmp_path} is a folder" in err
    err = usage_error(capsys, main, ["--out", out, "--record", out])
    assert "argument --record: " in err and "is the --out folder" in err
    assert not out.exists()


def places_that_fail_only_when_written_fail_before_the_run(tmp_path: Path, capsys,
                                                           main) -> None:
    """/sys and /proc pass every permission check (root may write anything), yet a file cannot
    be created there: the scripts try, before the first trial, and say so."""
    if not Path("/sys").is_dir():
        pytest.skip("no /sys here")
    out = tmp_path / "out"
    err = usage_error(capsys, main, ["--out", out, "--record", "/sys/rec.json"])
    assert "argument --record: cannot write /sys/rec.json: " in err
    err = usage_error(capsys, main, ["--out", "/sys/out"])
    assert "argument --out: cannot write /sys/out: " in err
    assert not out.exists()


def an_unwritable_out_is_a_usage_error(tmp_path: Path, capsys, main) -> None:
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(stat.S_IRUSR | stat.S_IXUSR)
    try:
        if os.access(ro, os.W_OK):
            pytest.skip("chmod does not stop this user (root) from writing")
        err = usage_error(capsys, main, ["--out", ro])
        assert f"argument --out: {ro} is not writable" in err
        err = usage_error(capsys, main, ["--out", ro / "a" / "b"])
        assert f"argument --out: cannot create {ro / 'a' / 'b'}: {ro} is not writable" in err
    finally:
        ro.chmod(stat.S_IRWXU)


def an_unwritable_out_is_a_usage_error_even_for_root(tmp_path: Path, capsys, monkeypatch,
                                                     main) -> None:
    """The same check with os.access answering as it does for a user without the right."""
    ro = tmp_path / "ro"
    ro.mkdir()
    real = os.access
    monkeypatch.setattr(dopt.lab.cli.os, "access",
                        lambda p, mode: False if Path(p) == ro else real(p, mode))
    assert f"argument --out: {ro} is not writable" in usage_error(capsys, main, ["--out", ro])
    err = usage_error(capsys, main, ["--out", ro / "new"])
    assert f"cannot create {ro / 'new'}: {ro} is not writable" in err
    assert not (ro / "new").exists()


# ------------------------------------------------------------------------------- --help
def shown_flags(ap: argparse.ArgumentParser) -> set:
    """The flags ``ap`` shows (a renamed flag's hidden old spelling left out)."""
    return {s for a in ap._actions if a.help != argparse.SUPPRESS for s in a.option_strings}


def literal_flags(path: Path) -> set:
    """Every flag literal of every add_argument call in a source file."""
    flags = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Call) and getattr(node.func, "attr", "") == "add_argument":
            flags |= {a.value for a in node.args if isinstance(a, ast.Constant)
                      and isinstance(a.value, str) and a.value.startswith("-")}
    return flags


def every_add_argument_is_in_a_parser(sources: dict) -> None:
    """``sources``: {source file: the parsers its add_argument calls build}; each flag literal
    of each file is shown by one of its parsers."""
    for path, parsers in sources.items():
        literal = literal_flags(path)
        assert literal, path
        covered = set().union(*(shown_flags(ap) for ap in parsers))
        assert literal <= covered, (path, literal - covered)


def help_lists_every_flag(capsys, main, ap: argparse.ArgumentParser) -> set:
    """``main(["--help"])`` exits 0 and prints every flag ``ap`` shows and how to see a
    traceback; the flags shown."""
    with pytest.raises(SystemExit) as exc:
        main(["--help"])
    text = capsys.readouterr().out
    assert exc.value.code == 0
    flags = shown_flags(ap)                              # hidden old spellings aside
    missing = [f for f in flags if f not in text]
    assert not missing, missing
    assert cli.TRACEBACK_ENV in text                   # how to see a traceback
    return flags


# ------------------------------------------------------------- failed trials: exit 1, listed
def impossible(params, *args, **kwargs):
    """A trial function that fails every trial, naming its seed."""
    raise RuntimeError(f"impossible setting for seed {params['seed']}")


def check_provenance(summary: dict, script: str) -> None:
    """The summary of a failed run still records its command line, commit and versions."""
    p = summary["provenance"]
    assert p["command"].startswith(f"python experiments/{script}") and p["git_commit"]
    assert all(p["versions"][k] for k in ("dopt", "mujoco", "torch"))
