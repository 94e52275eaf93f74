"""The runtime's bench command line (``python -m dopt.bench``): a bad flag value is an argparse
usage error (exit 2) naming the flag, before anything is built; a failure at run time is one
line on stderr and exit 1. Each main runs in-process; a probe that parses by mistake would start
a bench, and the ``no_run`` fixture turns that into a failure of the test (the contract's
checks: tests/dopt/lab/cli_checks.py)."""

import subprocess
import sys
from pathlib import Path

import pytest

import dopt.bench.__main__ as dopt_bench
import dopt.bench.cloth_steps
import dopt.bench.cloth_warp
import dopt.bench.rollout
from tests.dopt.lab import cli_checks
from tests.dopt.lab.cli_checks import usage_error

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture
def no_run(monkeypatch):
    """Every bench function raises: a usage error must come before any of them runs."""
    cli_checks.refuse_runs(monkeypatch, [(dopt.bench.rollout, "bench_rollout"),
                                         (dopt.bench.rollout, "bench_derivatives"),
                                         (dopt.bench.cloth_steps, "bench_cloth_steps"),
                                         (dopt.bench.cloth_warp, "bench_cloth_warp")])


BAD = [
    ("dopt", ["rollout", "--P", "0"], "argument --P: must be >= 1, got 0"),
    ("dopt", ["rollout", "--T", "x"], "argument --T: 'x' is not an integer"),
    ("dopt", ["rollout", "--threads", "-1"], "argument --threads: must be >= 0, got -1"),
    ("dopt", ["derivatives", "--objects", "1.5"], "argument --objects: '1.5' is not an integer"),
    ("dopt", ["cloth-steps", "--sizes", "12,x"], "argument --sizes: 'x' in '12,x' is not an "
                                                 "integer"),
    ("dopt", ["cloth-steps", "--sizes", "1"], "argument --sizes: particles per side must be "
                                              "finite and >= 2, got 1"),
    ("dopt", ["cloth-steps", "--sizes", "12,,25"], "(empty item)"),
    ("dopt", ["cloth-warp", "--nworlds", "1,0"], "argument --nworlds: world counts must be "
                                                 "finite and >= 1, got 0 in '1,0'"),
    ("dopt", ["cloth-warp", "--sizes", "20,20"], "argument --sizes: 20 given twice"),
]


@pytest.mark.parametrize("argv, message", [b[1:] for b in BAD],
                         ids=[f"{p}-{' '.join(a)}" for p, a, _ in BAD])
def test_a_bad_flag_is_a_usage_error_naming_it(capsys, no_run, argv, message):
    assert message in usage_error(capsys, dopt_bench.main, argv, hint=False)


@pytest.mark.parametrize("argv", [["cloth-steps"]])
def test_an_unwritable_record_is_a_usage_error(tmp_path, capsys, no_run, argv):
    err = usage_error(capsys, dopt_bench.main, [*argv, "--record", str(tmp_path)],  # a folder
                      hint=False)
    assert f"argument --record: {tmp_path} is a folder" in err


def test_a_failure_at_run_time_is_one_line_and_exit_1(capsys, monkeypatch):
    monkeypatch.delenv("DOPT_TRACEBACK", raising=False)
    assert dopt_bench.main(["cloth-steps", "--sizes", "6", "--variants", "no such"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "ValueError: unknown cloth-steps variants ['no such']" in err[0]
    assert err[0].startswith("python -m dopt.bench: error: ")


def test_a_real_process_exits_2_on_a_bad_list():
    proc = subprocess.run([sys.executable, "-m", "dopt.bench", "cloth-warp", "--sizes", "6,x"],
                          cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert "argument --sizes: 'x' in '6,x' is not an integer" in proc.stderr
    assert "Traceback" not in proc.stderr
