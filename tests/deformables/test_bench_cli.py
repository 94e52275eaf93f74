"""The key-particle bench's command line (``python -m deformables.bench``): a bad flag value is an
argparse usage error (exit 2) naming the flag, before anything is built. Each main runs in-
process; a probe that parses by mistake would start a bench, and the ``no_run`` fixture turns
that into a failure of the test (the contract's checks: tests/dopt/lab/cli_checks.py)."""

import pytest

import deformables.bench as deformables_bench
from tests.dopt.lab import cli_checks
from tests.dopt.lab.cli_checks import usage_error


@pytest.fixture
def no_run(monkeypatch):
    """Every bench function raises: a usage error must come before any of them runs."""
    cli_checks.refuse_runs(monkeypatch, [(deformables_bench, "bench"),
                                         (deformables_bench, "paper_scale"),
                                         (deformables_bench, "compare")])


BAD = [
    ("deformables", ["compare", "--resolutions", "16,x"], "argument --resolutions: 'x' in "
                                                          "'16,x' is not an integer"),
    ("deformables", ["--cloth-n", "1"], "argument --cloth-n: must be >= 2, got 1"),
    ("deformables", ["--noise=-1e-3"], "argument --noise: must be >= 0, got -1e-3"),
    ("deformables", ["--repeats", "two"], "argument --repeats: 'two' is not an integer"),
]


@pytest.mark.parametrize("argv, message", [b[1:] for b in BAD],
                         ids=[f"{p}-{' '.join(a)}" for p, a, _ in BAD])
def test_a_bad_flag_is_a_usage_error_naming_it(capsys, no_run, argv, message):
    assert message in usage_error(capsys, deformables_bench.main, argv, hint=False)


@pytest.mark.parametrize("argv", [["tasks"]])
def test_an_unwritable_record_is_a_usage_error(tmp_path, capsys, no_run, argv):
    err = usage_error(capsys, deformables_bench.main, [*argv, "--out", str(tmp_path)],  # a folder
                      hint=False)
    assert f"argument --out: {tmp_path} is a folder" in err
