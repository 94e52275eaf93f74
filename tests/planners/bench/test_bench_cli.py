"""The planners' bench command line (``python -m planners.bench``): a bad flag value is an argparse
usage error (exit 2) naming the flag, before anything is built; a failure at run time is one
line on stderr and exit 1. Each main runs in-process; a probe that parses by mistake would start
a bench, and the ``no_run`` fixture turns that into a failure of the test (the contract's
checks: tests/dopt/lab/cli_checks.py)."""

import pytest

import planners.bench.__main__ as planners_bench
import planners.bench.budget
import planners.bench.cem
import planners.bench.clock
import planners.bench.ilqr
import planners.bench.physics
import planners.bench.reference
import planners.bench.settle
from tests.dopt.lab import cli_checks
from tests.dopt.lab.cli_checks import usage_error


@pytest.fixture
def no_run(monkeypatch):
    """Every bench function raises: a usage error must come before any of them runs."""
    cli_checks.refuse_runs(monkeypatch, [(planners.bench.ilqr, "bench_ilqr"),
                                         (planners.bench.clock, "bench_clock"),
                                         (planners.bench.cem, "bench_cem"),
                                         (planners.bench.cem, "bench_cem_limit"),
                                         (planners.bench.budget, "bench_cloth_budget"),
                                         (planners.bench.physics, "bench_physics"),
                                         (planners.bench.reference, "bench_reference"),
                                         (planners.bench.settle, "bench_settle")])


BAD = [
    ("planners", ["ilqr", "--rho", "nan"], "argument --rho: must be > 0, got nan"),
    ("planners", ["ilqr", "--iterations", "0"], "argument --iterations: must be >= 1"),
    ("planners", ["clock", "--sizes", "1"], "argument --sizes: must be >= 2, got 1"),
    ("planners", ["cem", "--bound", "-0.1"], "argument --bound: must be > 0, got -0.1"),
    ("planners", ["cem", "--n", "1"], "argument --n: must be >= 2, got 1"),
    ("planners", ["cem-limit", "--sizes", "10,2"], "argument --sizes: particles per side must "
                                                   "be finite and >= 3, got 2 in '10,2'"),
    ("planners", ["cem-limit", "--iterations", "0"], "argument --iterations: must be >= 1"),
    ("planners", ["cloth-budget", "--folds", "diagonal,reflective"],
     "argument --folds: unknown folds"),
    ("planners", ["cloth-budget", "--n", "2"], "argument --n: must be >= 3, got 2"),
    ("planners", ["cloth-budget", "--population", "1"], "argument --population: must be >= 2"),
    ("planners", ["settle", "--speeds", "0.01,0"], "argument --speeds: rest speeds must be "
                                                    "finite and > 0, got 0 in '0.01,0'"),
    ("planners", ["settle", "--samples", "1"], "argument --samples: must be >= 2, got 1"),
    ("planners", ["cloth", "--sizes", "12,abc"], "argument --sizes: 'abc' in '12,abc' is not "
                                                 "an integer"),
    ("planners", ["rope", "--picker-speeds", "0.5,0"], "argument --picker-speeds: picker "
                                                       "speeds must be finite and > 0, got 0"),
    ("planners", ["rope", "--actions", "-3"], "argument --actions: must be >= 1, got -3"),
    ("planners", ["reference", "--presets", "fast,exact"], "argument --presets: unknown "
                                                          "presets"),
    ("planners", ["reference", "--checks", "pendulum"], "argument --checks: unknown checks"),
    ("planners", ["reference", "--rope-n", "2"], "argument --rope-n: must be >= 3, got 2"),
]


@pytest.mark.parametrize("argv, message", [b[1:] for b in BAD],
                         ids=[f"{p}-{' '.join(a)}" for p, a, _ in BAD])
def test_a_bad_flag_is_a_usage_error_naming_it(capsys, no_run, argv, message):
    assert message in usage_error(capsys, planners_bench.main, argv, hint=False)


@pytest.mark.parametrize("argv", [["ilqr"], ["cem-limit"], ["cloth-budget"], ["reference"]])
def test_an_unwritable_record_is_a_usage_error(tmp_path, capsys, no_run, argv):
    err = usage_error(capsys, planners_bench.main, [*argv, "--record", str(tmp_path)],  # a folder
                      hint=False)
    assert f"argument --record: {tmp_path} is a folder" in err


def test_a_failure_at_run_time_is_one_line_and_exit_1(capsys, monkeypatch):
    monkeypatch.delenv("DOPT_TRACEBACK", raising=False)
    assert planners_bench.main(["cloth", "--sizes", "6", "--settings", "nonsense"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "ValueError: unknown cloth settings ['nonsense']" in err[0]
    assert err[0].startswith("python -m planners.bench: error: ")
