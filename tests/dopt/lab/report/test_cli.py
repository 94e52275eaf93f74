"""The report's command line (dopt.lab.report.cli, run as experiments/report.py): a missing
results folder and an unwritable page are usage errors naming the flag; a result file without
full provenance is named; --help shows every flag the module adds. The contract's checks:
tests/dopt/lab/cli_checks.py."""

import json
from pathlib import Path

import pytest

from dopt.lab.report import cli as report
from tests.dopt.lab import cli_checks
from tests.dopt.lab.cli_checks import usage_error

ROOT = Path(__file__).resolve().parents[4]


@pytest.fixture
def no_run(monkeypatch):
    """Generating the pages fails loudly: a probe that parses by mistake fails the test."""
    cli_checks.refuse_runs(monkeypatch, [(report, "generate")])


def test_report_rejects_a_missing_results_dir_and_an_unwritable_page(tmp_path, capsys, no_run,
                                                                     monkeypatch):
    err = usage_error(capsys, report.main, ["--results-dir", tmp_path / "nope"])
    assert f"argument --results-dir: {tmp_path / 'nope'} does not exist" in err
    (tmp_path / "afile").write_text("")
    err = usage_error(capsys, report.main, ["--results-dir", tmp_path / "afile"])
    assert "is not a folder" in err
    err = usage_error(capsys, report.main, ["--results-dir", tmp_path, "--results-md", tmp_path])
    assert f"argument --results-md: {tmp_path} is a folder" in err


def test_every_add_argument_is_in_a_parser():
    # the report's command line lives in the lab (experiments/report.py is thin)
    cli_checks.every_add_argument_is_in_a_parser({
        ROOT / "dopt" / "lab" / "report" / "cli.py": [report.parser()]})


def test_help_lists_every_flag(capsys):
    assert "--help" in cli_checks.help_lists_every_flag(capsys, report.main, report.parser())


def test_report_names_a_result_file_without_full_provenance(tmp_path, capsys):
    results = tmp_path / "results"
    results.mkdir()
    (results / "old.json").write_text(json.dumps({
        "experiment": "notes", "provenance": {"command": "python x.py", "git_commit": "abc",
                                              "versions": {"python": "3.11", "dopt": "0.1.0"}}}))
    (results / "full.json").write_text(json.dumps({
        "experiment": "notes", "provenance": {"command": "python x.py", "git_commit": "abc",
                                              "versions": {"dopt": "0.1.0", "mujoco": "3",
                                                           "torch": "2"}}}))
    assert report.main(["--results-dir", str(results), "--results-md", str(tmp_path / "R.md"),
                        "--readme", str(tmp_path / "README.md")]) == 0
    notes = [ln for ln in capsys.readouterr().err.splitlines() if "provenance lacks" in ln]
    assert len(notes) == 1 and "old.json" in notes[0]
    assert notes[0].endswith("lacks versions.mujoco, versions.torch (rerun the experiment to "
                             "record them)")
