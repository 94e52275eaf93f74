"""Console scripts print their own names (dopt.lab.scripts, dopt.lab.cli.shown_as): ``dopt-fold
--help`` says ``usage: dopt-fold``, not the file it runs; usage errors and runtime failures
name the console script too, and the name is the file's again once the run is over."""

import contextlib
import io

import pytest

from dopt.lab.cli import ArgumentParser, guarded, shown_as, shown_name
from dopt.lab.scripts import SCRIPTS, run


def _run(name: str, argv: list[str]) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        with pytest.raises(SystemExit) as e:
            run(name, argv)
    return e.value.code, out.getvalue(), err.getvalue()


@pytest.mark.parametrize("name", sorted(SCRIPTS))
def test_help_and_usage_errors_name_the_console_script(name):
    code, out, _ = _run(name, ["--help"])
    assert code == 0 and out.startswith(f"usage: {name} ")
    assert f"usage: {SCRIPTS[name]}" not in out
    code, _, err = _run(name, ["--no-such-flag"])
    assert code == 2
    assert err.startswith(f"{name}: error: ") and f"({name} --help lists the flags)" in err
    assert shown_name(SCRIPTS[name]) == SCRIPTS[name]          # restored after the run


def test_a_runtime_failure_names_the_console_script(capsys):
    @guarded("x.py")
    def main():
        raise RuntimeError("disk full")

    with shown_as("x.py", "dopt-x"):
        assert main() == 1
    assert capsys.readouterr().err == "dopt-x: error: RuntimeError: disk full\n"
    assert main() == 1
    assert capsys.readouterr().err == "x.py: error: RuntimeError: disk full\n"


def test_the_prog_and_other_scripts_keep_their_names():
    """Only the file the console script runs is renamed: its parser's prog (from which a
    script derives its default --out folder) stays the file's, and another parser made
    during the run keeps its own name."""
    with shown_as("x.py", "dopt-x"):
        mine, other = ArgumentParser(prog="x.py"), ArgumentParser(prog="y.py")
        assert mine.prog == "x.py" and mine.format_usage().startswith("usage: dopt-x")
        assert other.format_usage().startswith("usage: y.py")
        with shown_as("x.py", "dopt-inner"):
            assert shown_name("x.py") == "dopt-inner"
        assert shown_name("x.py") == "dopt-x"
    assert shown_name("x.py") == "x.py"
