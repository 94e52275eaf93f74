"""The bench command lines (``python -m dopt.bench``, ``python -m planners.bench``,
``python -m deformables.bench``): a bad flag value is an argparse usage error (exit 2) naming
the flag, before anything is built; a failure at run time is one line on stderr and exit 1.
Each main runs in-process; a probe that parses by mistake would start a bench, and the
``no_run`` fixture turns that into a failure of the test."""

import subprocess
import sys
from pathlib import Path

import pytest

import deformables.bench as deformables_bench
import dopt.bench.__main__ as dopt_bench
import dopt.bench.cloth_steps
import dopt.bench.cloth_warp
import dopt.bench.rollout
import planners.bench.__main__ as planners_bench
import planners.bench.budget
import planners.bench.cem
import planners.bench.clock
import planners.bench.ilqr
import planners.bench.physics
import planners.bench.reference
import planners.bench.settle

ROOT = Path(__file__).resolve().parents[2]
MAINS = {"dopt": dopt_bench.main, "planners": planners_bench.main,
         "deformables": deformables_bench.main}


@pytest.fixture
def no_run(monkeypatch):
    """Every bench function raises: a usage error must come before any of them runs."""
    def stop(*args, **kwargs):
        raise AssertionError("the arguments were accepted")
    for module, name in [(dopt.bench.rollout, "bench_rollout"),
                         (dopt.bench.rollout, "bench_derivatives"),
                         (dopt.bench.cloth_steps, "bench_cloth_steps"),
                         (dopt.bench.cloth_warp, "bench_cloth_warp"),
                         (planners.bench.ilqr, "bench_ilqr"),
                         (planners.bench.clock, "bench_clock"),
                         (planners.bench.cem, "bench_cem"),
                         (planners.bench.cem, "bench_cem_limit"),
                         (planners.bench.budget, "bench_cloth_budget"),
                         (planners.bench.physics, "bench_physics"),
                         (planners.bench.reference, "bench_reference"),
                         (planners.bench.settle, "bench_settle"),
                         (deformables_bench, "bench"), (deformables_bench, "paper_scale"),
                         (deformables_bench, "compare")]:
        monkeypatch.setattr(module, name, stop)


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
    ("deformables", ["compare", "--resolutions", "16,x"], "argument --resolutions: 'x' in "
                                                          "'16,x' is not an integer"),
    ("deformables", ["--cloth-n", "1"], "argument --cloth-n: must be >= 2, got 1"),
    ("deformables", ["--noise=-1e-3"], "argument --noise: must be >= 0, got -1e-3"),
    ("deformables", ["--repeats", "two"], "argument --repeats: 'two' is not an integer"),
]


@pytest.mark.parametrize("package, argv, message", BAD,
                         ids=[f"{p}-{' '.join(a)}" for p, a, _ in BAD])
def test_a_bad_flag_is_a_usage_error_naming_it(capsys, no_run, package, argv, message):
    with pytest.raises(SystemExit) as exc:
        MAINS[package](argv)
    err = capsys.readouterr().err
    assert exc.value.code == 2, err
    assert message in err
    assert "Traceback" not in err
    assert len(err.strip().splitlines()) == 1, err                 # one line, no usage block


@pytest.mark.parametrize("package, argv", [("dopt", ["cloth-steps"]),
                                            ("planners", ["ilqr"]),
                                            ("planners", ["cem-limit"]),
                                            ("planners", ["cloth-budget"]),
                                            ("planners", ["reference"]),
                                            ("deformables", ["tasks"])])
def test_an_unwritable_record_is_a_usage_error(tmp_path, capsys, no_run, package, argv):
    flag = "--out" if package == "deformables" else "--record"
    with pytest.raises(SystemExit) as exc:
        MAINS[package]([*argv, flag, str(tmp_path)])          # a folder, not a file
    assert exc.value.code == 2
    assert f"argument {flag}: {tmp_path} is a folder" in capsys.readouterr().err


@pytest.mark.parametrize("package, argv, message", [
    ("dopt", ["cloth-steps", "--sizes", "6", "--variants", "no such"],
     "ValueError: unknown cloth-steps variants ['no such']"),
    ("planners", ["cloth", "--sizes", "6", "--settings", "nonsense"],
     "ValueError: unknown cloth settings ['nonsense']"),
])
def test_a_failure_at_run_time_is_one_line_and_exit_1(capsys, monkeypatch, package, argv,
                                                      message):
    monkeypatch.delenv("DOPT_TRACEBACK", raising=False)
    assert MAINS[package](argv) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]
    assert err[0].startswith(f"python -m {package}.bench: error: ")


def test_a_real_process_exits_2_on_a_bad_list():
    proc = subprocess.run([sys.executable, "-m", "dopt.bench", "cloth-warp", "--sizes", "6,x"],
                          cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert "argument --sizes: 'x' in '6,x' is not an integer" in proc.stderr
    assert "Traceback" not in proc.stderr
