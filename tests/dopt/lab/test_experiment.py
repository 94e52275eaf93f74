"""The experiment protocol (``dopt.lab.experiment``): an experiment registered at run time gets
its section and headline in RESULTS.md, a kind no one registers is listed apart, modules named
by ``DOPT_EXPERIMENTS`` are loaded, and the engine names no kind."""

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from dopt.lab.experiment import (
    Experiment,
    experiment_of,
    register_experiment,
    registered,
    unregister_experiment,
)
from dopt.lab.report.base import load_results
from tests.dopt.lab.report.report_site import headlines, provenance, run, write

ROOT = Path(__file__).resolve().parents[3]


class Reach(Experiment):
    """Files {"experiment": "test_reach", "reach": metres}."""

    kind, script = "test_reach", "python reach.py"

    def section(self, results, page):
        return ["## Reach of the test arm", "", *(f"- {r.name}: {r.data['reach']} m"
                                                  for r in results)]

    def headline(self, result):
        return f"reaches {result.data['reach']} m"


@pytest.fixture
def reach():
    x = register_experiment(Reach())
    yield x
    unregister_experiment(x.kind)


def test_a_kind_registered_at_run_time_gets_its_section_and_headline(site, reach):
    write(site["results"], "reach.json", {"experiment": "test_reach", "reach": 0.85,
                                          "provenance": provenance("python reach.py")})
    assert run(site) == 0
    md = site["md"].read_text()
    assert "## Reach of the test arm\n\n- reach.json: 0.85 m" in md
    assert "reaches 0.85 m" in headlines(site)
    assert "## Other result files" not in md
    unregister_experiment("test_reach")
    try:
        assert run(site) == 0
        md = site["md"].read_text()
        assert "Reach of the test arm" not in md and "reaches" not in headlines(site)
        assert "- [reach.json](results/reach.json): experiment `test_reach`" in md
    finally:
        register_experiment(reach)


def test_registration_refuses_what_is_not_an_experiment_of_a_new_kind(reach):
    with pytest.raises(TypeError, match="expected an Experiment"):
        register_experiment(object())
    with pytest.raises(ValueError, match="kind must be a non-empty string"):
        register_experiment(Experiment())
    with pytest.raises(ValueError, match="'test_reach' is registered already"):
        register_experiment(Reach())
    with pytest.raises(ValueError, match="no experiment of kind 'nope'"):
        unregister_experiment("nope")


def test_every_committed_result_has_its_experiment():
    """Every file under docs/results is some registered experiment's (none falls to "Other
    result files"), and each kind has exactly one owner."""
    results = load_results(ROOT / "docs" / "results")
    assert results
    for r in results:
        owners = [x for x in registered() if x.owns(r)]
        assert len(owners) == 1, (r.name, r.kind, owners)
        assert experiment_of(r) is owners[0]


def test_modules_named_by_the_environment_are_loaded(tmp_path):
    (tmp_path / "my_experiments.py").write_text(
        "from dopt.lab.experiment import Experiment, register_experiment\n"
        "class Mine(Experiment):\n    kind = 'mine'\n"
        "register_experiment(Mine())\n")
    code = ("from dopt.lab.experiment import registered\n"
            "kinds = [x.kind for x in registered()]\n"
            "assert 'mine' in kinds and 'fig7' in kinds and 'table1' in kinds, kinds\n")
    env = {**os.environ, "DOPT_EXPERIMENTS": "my_experiments",
           "PYTHONPATH": os.pathsep.join([str(tmp_path), str(ROOT)])}
    subprocess.run([sys.executable, "-c", code], check=True, env=env, timeout=120,
                   capture_output=True)
    env["DOPT_EXPERIMENTS"] = "no_such_module_here"
    proc = subprocess.run([sys.executable, "-c", code], env=env, timeout=120,
                          capture_output=True, text=True)
    assert proc.returncode != 0 and "'no_such_module_here'" in proc.stderr


def test_the_engine_names_no_kind():
    """No ``kind ==`` / ``kind in (...)`` against a literal in dopt/lab/report/: what is
    particular to a kind is its experiment's."""
    literal = re.compile(r"kind\s*(==|!=|in|not in)\s*[(\[{]?\s*[\"']")
    found = [f"{p.name}:{i}" for p in (ROOT / "dopt" / "lab" / "report").glob("*.py")
             for i, line in enumerate(p.read_text().splitlines(), 1) if literal.search(line)]
    assert found == []
    assert literal.search('if r.kind == "fig7":')              # the pattern finds one


def test_a_summary_written_by_hand_reads_as_its_kind(tmp_path):
    write(tmp_path, "x.json", {"bench": "cloth"})
    (r,) = load_results(tmp_path)
    assert r.kind == "physics" and experiment_of(r).kind == "physics"
    write(tmp_path, "x.json", {"bench": "nobody-reads-this"})
    (r,) = load_results(tmp_path)
    assert r.kind == "(none)" and experiment_of(r) is None
