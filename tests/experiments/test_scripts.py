"""The thin command lines of experiments/ themselves (issue 93): each is a few lines over its
experiment in a paper's slice (or the lab's report), defines nothing of its own, runs by path
and its --help names it; a failure in a real process is one line and a non-zero exit. What
the experiments do: tests/planners/<slice>/experiments/, tests/dopt/lab/report/."""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

from tests.test_flag_vocabulary import help_text

ROOT = Path(__file__).resolve().parents[2]
EXPERIMENTS = ROOT / "experiments"
SCRIPTS = sorted(p.name for p in EXPERIMENTS.glob("*.py"))
#: where a script's command line may come from
SOURCES = ("planners.pick_place.experiments.", "planners.svr_mpc.experiments.",
           "dopt.lab.report.")
MAX_SCRIPT_LINES = 60
MAX_FOLDER_LINES = 1000


def test_the_scripts_are_found():
    assert "cloth_fold.py" in SCRIPTS and "report.py" in SCRIPTS


@pytest.mark.parametrize("script", SCRIPTS)
def test_a_script_is_thin_over_its_experiment(script):
    """No definition of its own, at most 60 lines, and its ``main`` imported from a slice's
    experiments or the lab's report."""
    text = (EXPERIMENTS / script).read_text()
    assert len(text.splitlines()) <= MAX_SCRIPT_LINES
    tree = ast.parse(text)
    defined = [n.name for n in ast.walk(tree)
               if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef))]
    assert not defined, defined
    mains = [n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)
             and any((a.asname or a.name) == "main" for a in n.names)]
    assert len(mains) == 1 and mains[0].startswith(SOURCES), mains


def test_the_folder_stays_small():
    lines = sum(len(p.read_text().splitlines()) for p in EXPERIMENTS.glob("*.py"))
    assert lines < MAX_FOLDER_LINES


@pytest.mark.parametrize("script", SCRIPTS)
def test_a_script_runs_by_path_and_its_help_names_it(script):
    """``python experiments/<script> --help`` (in-process, as __main__, the way the console
    scripts run them) prints a usage line that names the script."""
    text = help_text(script)
    assert text is not None, f"{script} printed no help"
    assert text.startswith(f"usage: {script} "), text.splitlines()[0]


def test_a_failure_in_a_real_process_is_one_line_and_its_exit_status(tmp_path):
    """The exit status and stderr of a script run as a program (report.py: a result file that
    is not JSON; key_particles.py's failure after parsing:
    tests/planners/pick_place/experiments/test_bad_inputs.py)."""
    results = tmp_path / "results"
    results.mkdir()
    (results / "broken.json").write_text('{"experiment": "fig7", ')
    proc = subprocess.run([sys.executable, str(EXPERIMENTS / "report.py"), "--results-dir",
                           str(results), "--results-md", str(tmp_path / "R.md"), "--readme",
                           str(tmp_path / "README.md")], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert "report.py: error:" in proc.stderr and "broken.json" in proc.stderr
