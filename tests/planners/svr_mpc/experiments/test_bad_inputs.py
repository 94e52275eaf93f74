"""Every bad input of the SVR experiments (Table 1: mpc.py; Fig. 4: rho_sweep.py; svr_explain.py;
clock_check.py) is a usage error (one line, exit 2) naming the flag, before anything runs or any
folder is created; an experiment with a failed trial exits 1 and lists it in summary.json;
--help shows every flag. Each main(argv) runs in-process, its trial function patched. The
contract's checks: tests/dopt/lab/cli_checks.py; the pick experiments':
tests/planners/pick_place/experiments/test_bad_inputs.py."""

import json
from pathlib import Path

import pytest

from planners.svr_mpc.experiments import clock_check, explain, fig4, mapping, runner, table1
from tests.dopt.lab import cli_checks
from tests.dopt.lab.cli_checks import check_provenance, impossible

ROOT = Path(__file__).resolve().parents[4]
#: where the SVR experiments' flags are added (their scripts in experiments/ are thin)
SVR_SOURCES = ROOT / "planners" / "svr_mpc" / "experiments"
#: script (as its usage lines name it) -> its main
SCRIPTS = {"mpc": table1.main, "rho_sweep": fig4.main, "svr_explain": explain.main,
           "clock_check": clock_check.main}
WRITERS = ["mpc", "rho_sweep"]


@pytest.fixture
def no_run(monkeypatch):
    """Whatever follows parsing in each script fails loudly: a probe that parses by mistake
    returns 1 instead of running an experiment (and the test, expecting exit 2, fails)."""
    cli_checks.refuse_runs(monkeypatch, [(mapping, "make_trials")])


BAD = [
    # negative or zero sizes and seeds
    ("mpc", ["--seed", "-1"], "argument --seed: must be >= 0, got -1"),
    ("rho_sweep", ["--seed", "-1"], "argument --seed: must be >= 0, got -1"),
    ("mpc", ["--threads", "-1"], "argument --threads: must be >= 0, got -1"),
    ("rho_sweep", ["--threads", "-1"], "argument --threads: must be >= 0, got -1"),
    ("mpc", ["--trials", "0"], "argument --trials: must be >= 1, got 0"),
    ("mpc", ["--workers", "0"], "argument --workers: must be >= 1, got 0"),
    ("mpc", ["--slowdown", "-2"], "argument --slowdown: must be > 0, got -2"),
    ("mpc", ["--control-noise", "inf"], "argument --control-noise: must be >= 0, got inf"),
    ("mpc", ["--task", "nope"], "argument --task: invalid choice: 'nope'"),
    # bad comma lists
    ("rho_sweep", ["--rhos", "1,,2"], "argument --rhos: '1,,2' is not a comma-separated list"),
    ("rho_sweep", ["--rhos", "1,inf"], "argument --rhos: rhos must be finite and >= 0, got inf"),
    ("rho_sweep", ["--rhos", "-1"], "argument --rhos: rhos must be finite and >= 0, got -1"),
    ("rho_sweep", ["--rhos", "1,1"], "argument --rhos: 1 given twice in '1,1'"),
    ("rho_sweep", ["--rhos", "a"], "argument --rhos: 'a' is not a number"),
    ("rho_sweep", ["--rhos", ""], "argument --rhos: '' is not a comma-separated list"),
    ("rho_sweep", ["--thetas", "1.5"], "argument --thetas: '1.5' is not an integer"),
    ("rho_sweep", ["--thetas", "0,-5"], "argument --thetas: thetas must be finite and >= 0"),
    ("rho_sweep", ["--feedback", "both"], "--feedback both is for experiments/mpc.py"),
    # bad --methods
    ("mpc", ["--rules", "baseline,svr"], "argument --rules: unknown rule(s) ['svr']"),
    ("mpc", ["--rules", ""], "argument --rules: unknown rule(s) ['']"),
    ("mpc", ["--rules", "naive,naive"], "argument --rules: rule(s) naive given twice"),
    ("mpc", ["--methods", "baseline,svr"], "argument --methods: unknown rule(s) ['svr']"),
    ("rho_sweep", ["--rule", "rand"], "argument --rule: invalid choice: 'rand'"),
    ("rho_sweep", ["--method", "rand"], "argument --method: invalid choice: 'rand'"),
    # the paper protocol's flags, and the scripts built on mpc.py's run flags
    ("mpc", ["--preset", "theirs"], "argument --preset: invalid choice: 'theirs'"),
    ("mpc", ["--fd-skip", "0"], "argument --fd-skip: must be >= 1, got 0"),
    ("mpc", ["--nominal-threads", "0"], "argument --nominal-threads: must be > 0"),
    ("mpc", ["--keypoints", "often"], "argument --keypoints: invalid choice: 'often'"),
    ("svr_explain", ["--rows", "sum-t7"], "argument --rows: unknown Table 1 row 'sum-t7'"),
    ("mpc", ["--rows", "baseline,svr"], "argument --rows: unknown Table 1 row 'svr'"),
    ("mpc", ["--rows", "shooting+boxqp"], "argument --rows: unknown Table 1 row 'shooting'"),
    ("svr_explain", ["--bins", "0"], "argument --bins: must be >= 1, got 0"),
    ("svr_explain", ["--feedback", "both"], "--feedback both is for experiments/mpc.py"),
    ("clock_check", ["--real-threads", "0"], "argument --real-threads: must be >= 1, got 0"),
    ("clock_check", ["--clock", "wall"], "argument --clock: invalid choice: 'wall'"),
]


@pytest.mark.parametrize("script, argv, message", BAD,
                         ids=[f"{s}{' '.join(a)}" for s, a, _ in BAD])
def test_a_bad_argument_is_a_usage_error_and_creates_nothing(tmp_path, capsys, no_run, script,
                                                             argv, message):
    cli_checks.bad_argument_is_a_usage_error_and_creates_nothing(
        tmp_path, capsys, SCRIPTS[script], script, argv, message)


@pytest.mark.parametrize("script", WRITERS)
def test_out_and_record_must_be_writable_places(tmp_path, capsys, no_run, script):
    cli_checks.out_and_record_must_be_writable_places(tmp_path, capsys, SCRIPTS[script])


@pytest.mark.parametrize("script", WRITERS)
def test_places_that_fail_only_when_written_fail_before_the_run(tmp_path, capsys, no_run,
                                                                script):
    cli_checks.places_that_fail_only_when_written_fail_before_the_run(tmp_path, capsys,
                                                                      SCRIPTS[script])


@pytest.mark.parametrize("script", ["mpc"])
def test_an_unwritable_out_is_a_usage_error(tmp_path, capsys, no_run, script):
    cli_checks.an_unwritable_out_is_a_usage_error(tmp_path, capsys, SCRIPTS[script])


@pytest.mark.parametrize("script", ["mpc"])
def test_an_unwritable_out_is_a_usage_error_even_for_root(tmp_path, capsys, no_run,
                                                          monkeypatch, script):
    cli_checks.an_unwritable_out_is_a_usage_error_even_for_root(tmp_path, capsys, monkeypatch,
                                                                SCRIPTS[script])


# ------------------------------------------------------------- failed trials: exit 1, listed
def test_mpc_with_every_trial_failing_exits_1(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(runner, "run_trial", impossible)
    out = tmp_path / "mpc"
    assert table1.main(["--quick", "--rules", "baseline,naive", "--out", str(out),
                     "--no-render"]) == 1
    summary = json.loads((out / "summary.json").read_text())
    assert sorted(k.split("-")[1] for k in summary["failed"]) == ["baseline", "naive"]
    assert all(k.startswith("clutter-") and "-seed0" in k for k in summary["failed"])
    assert set(summary["failed"].values()) == {"RuntimeError: impossible setting for seed 0"}
    assert summary["methods"] == {} and summary["trial_commits"] == {}
    check_provenance(summary, "mpc.py")
    assert "FAILED clutter-naive" in capsys.readouterr().err
    assert not list((out / "trials").glob("*.json"))


def test_rho_sweep_with_a_failing_trial_exits_1(tmp_path, monkeypatch):
    monkeypatch.setattr(runner, "run_trial", impossible)
    out = tmp_path / "rho"
    assert fig4.main(["--quick", "--rhos", "1", "--thetas", "0", "--out", str(out)]) == 1
    summary = json.loads((out / "summary.json").read_text())
    assert len(summary["failed"]) == 2 and summary["points"] == []
    check_provenance(summary, "rho_sweep.py")


# ------------------------------------------------------------------------------- --help
def _parsers() -> dict:
    return {"mpc": table1.parser(), "rho_sweep": fig4.parser(), "svr_explain": explain.parser(),
            "clock_check": clock_check.parser()}


def test_every_add_argument_is_in_a_parser():
    parsers = _parsers()
    cli_checks.every_add_argument_is_in_a_parser({
        SVR_SOURCES / "flags.py": [parsers["mpc"], parsers["rho_sweep"]],
        SVR_SOURCES / "table1.py": [parsers["mpc"]],
        SVR_SOURCES / "fig4.py": [parsers["rho_sweep"]]})
    assert cli_checks.literal_flags(SVR_SOURCES / "flags.py") <= \
        cli_checks.shown_flags(parsers["mpc"])


@pytest.mark.parametrize("script", list(SCRIPTS))
def test_help_lists_every_flag(script, capsys):
    flags = cli_checks.help_lists_every_flag(capsys, SCRIPTS[script], _parsers()[script])
    assert {"--out", "--help"} <= flags
