"""What the SVR experiments read and write under --out: a stored MPC trial without a field
the summary reads is recomputed (each experiment's schema); what a run needs is checked before
its first trial; every JSON file a --quick run writes parses with a strict parser (no bare
NaN: null with its reason)."""
import json
from pathlib import Path

import pytest

from dopt.lab.provenance import COMMIT_ENV
from planners.svr_mpc.experiments import fig4, mapping, runner, table1
from tests.dopt.lab.run_files import run_script, strict, strict_files

ROOT = Path(__file__).resolve().parents[4]


@pytest.fixture(autouse=True)
def fixed_code(monkeypatch):
    """The code of this process (and its children) fixed: others may commit or edit the
    checkout while a test runs, and a resumed trial must see the code that wrote it."""
    monkeypatch.setenv(COMMIT_ENV, "c0ffee")


# ---------------------------------------------------------------- records of another format
def test_the_mpc_experiment_passes_its_schema(tmp_path, capsys):
    """A stored MPC trial without a field the summary reads is recomputed, not summarised."""
    args = table1.parse_args(["--quick", "--rules", "baseline", "--out", str(tmp_path)])
    (trial,) = mapping.make_trials(args)
    full = dict.fromkeys(runner.SCHEMA.result, 0)
    (tmp_path / "trials").mkdir()
    (tmp_path / "trials" / f"{trial.key}.json").write_text(json.dumps(
        {"key": trial.key, "params": trial.params, "code": {"version": "0", "commit": "c0ffee"},
         "result": {k: v for k, v in full.items() if k != "unstable"}}))
    records, res = runner.run(args, [trial], fn=_fake_episode)
    assert res.ran == [trial.key] and records[0]["result"]["unstable"] is False
    assert "its result lacks 'unstable'" in res.recomputed[trial.key]
    assert "sweep: 1 trials: 0 reused, 0 resumed from a checkpoint, 1 run from the start (1 " \
           "recomputed" in capsys.readouterr().err


def _fake_episode(params, report=None, keep_controls=False):
    for _ in range(3):
        report()
    return {**dict.fromkeys(runner.SCHEMA.result, 0), "unstable": False}


# ---------------------------------------------------------- what a run needs, checked first
@pytest.mark.parametrize("text, message", [
    ("{not json", "is not experiments/paper_reference.py's file (JSONDecodeError"),
    ('{"rows": []}', "is not experiments/paper_reference.py's file (KeyError"),
    ('{"tasks": {"clutter": {"fig4": [{"theta": 0, "rho": 1}]}}}',
     "1 of the clutter Fig. 4 points lack a number"),
])
def test_a_bad_paper_reference_is_refused_before_the_sweep(tmp_path, capsys, text, message):
    """rho_sweep read --paper-reference only after the whole sweep."""
    ref, out = tmp_path / "ref.json", tmp_path / "out"
    ref.write_text(text)
    with pytest.raises(SystemExit) as exc:
        fig4.main(["--quick", "--rhos", "1", "--thetas", "0", "--paper-reference",
                   str(ref), "--out", str(out)])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and f"argument --paper-reference: {ref}" in err
    assert message in err and not out.exists()


# ------------------------------------------------------------------------ strict JSON files
@pytest.mark.slow
def test_every_file_of_a_quick_run_parses_strictly(tmp_path):
    """mpc.py and rho_sweep.py wrote bare NaN (13 in a --quick run); every JSON file of the
    three SVR scripts' --quick runs parses strictly (cloth_fold.py's: in
    tests/planners/pick_place/experiments/test_run_files.py), and an undefined value is null
    with its reason under "<field>_undefined"."""
    runs = {"mpc": ("mpc.py", "--quick", "--rules", "baseline,svr-sum", "--no-render"),
            "rho": ("rho_sweep.py", "--quick", "--rhos", "1", "--thetas", "0"),
            "explain": ("svr_explain.py", "--quick", "--rows", "sum-t10-r1", "--bins", "2")}
    for name, (script, *flags) in runs.items():
        run_script(script, *flags, "--out", tmp_path / name)
    assert strict_files(tmp_path) >= 8      # 3 summaries, 5 trial records; a bare NaN raises
    methods = strict((tmp_path / "mpc" / "summary.json").read_text())["methods"]
    row = methods["svr-sum-t10-r1"] if "svr-sum-t10-r1" in methods else next(iter(methods.values()))
    assert row["mpc_cost_normalised_ci90"] is None                      # one trial: no CI
    assert row["mpc_cost_normalised_ci90_undefined"] == \
        "NaN: a confidence interval needs two or more values"
