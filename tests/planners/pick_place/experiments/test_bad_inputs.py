"""Every bad input of the pick experiments (fig7: cloth_fold.py, rope.py; key_particles.py) is a
usage error (one line, exit 2) naming the flag, before anything runs or any folder is created; a
failure at run time is one line on stderr and exit 1; an experiment with a failed trial exits 1
and lists it in summary.json; bad trial files are named, moved aside and recomputed; --help
shows every flag. Each main(argv) runs in-process (its trial functions patched where a run
would take long), a subprocess only where the exit status of a real process is the point. The
contract's checks: tests/dopt/lab/cli_checks.py; the SVR experiments':
tests/planners/svr_mpc/experiments/test_bad_inputs.py."""

import json
import logging
import os
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from dopt.lab import cli
from planners.pick_place.experiments import fig7, key_particles, sweep
from tests.dopt.lab import cli_checks
from tests.dopt.lab.cli_checks import check_provenance, impossible

ROOT = Path(__file__).resolve().parents[4]
PICK = ROOT / "planners" / "pick_place" / "experiments"
#: script (as its usage lines name it) -> its main
SCRIPTS = {"cloth_fold": fig7.cloth, "rope": fig7.rope, "key_particles": key_particles.main}
WRITERS = ["cloth_fold", "rope", "key_particles"]


@pytest.fixture
def no_run(monkeypatch):
    """Whatever follows parsing in each script fails loudly: a probe that parses by mistake
    returns 1 instead of running an experiment (and the test, expecting exit 2, fails)."""
    cli_checks.refuse_runs(monkeypatch, [(fig7, "make_problem"),
                                         (key_particles, "goal_sequence")])


BAD = [
    # negative or zero sizes and seeds
    ("cloth_fold", ["--seed", "-1"], "argument --seed: must be >= 0, got -1"),
    ("rope", ["--seed", "-1"], "argument --seed: must be >= 0, got -1"),
    ("key_particles", ["--seed", "-1"], "argument --seed: must be >= 0, got -1"),
    ("key_particles", ["--cloth-n", "1"], "argument --cloth-n: must be >= 2, got 1"),
    ("key_particles", ["--cloth-n", "0"], "argument --cloth-n: must be >= 2, got 0"),
    ("key_particles", ["--cloth-n", "2.5"], "argument --cloth-n: '2.5' is not an integer"),
    ("key_particles", ["--noise-seeds", "0"], "argument --noise-seeds: must be >= 1, got 0"),
    ("cloth_fold", ["--threads", "-1"], "argument --threads: must be >= 0, got -1"),
    ("rope", ["--threads", "-1"], "argument --threads: must be >= 0, got -1"),
    ("cloth_fold", ["--seeds", "0"], "argument --seeds: must be >= 1, got 0"),
    ("cloth_fold", ["--n", "2"], ">= 3, got 2"),
    ("rope", ["--population", "0"], "argument --population: must be >= 1, got 0"),
    ("rope", ["--elites", "9", "--population", "8"], "elites <= population"),
    ("rope", ["--bound", "nan"], "argument --bound: must be > 0, got nan"),
    # bad comma lists
    ("key_particles", ["--noise-n", "16,,25"], "argument --noise-n: '16,,25' is not a "
                                               "comma-separated list"),
    ("key_particles", ["--noise-n", "16,x"], "argument --noise-n: 'x' in '16,x' is not an "
                                             "integer"),
    ("key_particles", ["--noise-n", "1"], "argument --noise-n: particles per side must be "
                                          "finite and >= 2, got 1"),
    ("key_particles", ["--noise-n", "16,16"], "argument --noise-n: 16 given twice"),
    ("key_particles", ["--noise-panels", "on,on"], "argument --noise-panels: panel modes on "
                                                   "given twice"),
    ("key_particles", ["--noise-panels", "maybe"], "argument --noise-panels: unknown panel "
                                                   "modes ['maybe']"),
    ("key_particles", ["--task", "cloth"], "argument --task: invalid choice: 'cloth'"),
    # bad --methods
    ("cloth_fold", ["--methods", "simple,nope"], "argument --methods: unknown methods "
                                                 "['nope']"),
    ("rope", ["--methods", "simple,simple"], "argument --methods: methods simple given twice"),
    ("rope", ["--methods", ","], "argument --methods: unknown methods ['', '']"),
    # sizes a setting implies, against the workspace, the picker's steps and the memory
    ("rope", ["--bound", "1e9"], "argument --bound: PickerConfig.bound 1e+09 m is beyond the "
                                 "workspace: the picker cannot move farther than 1 m along x"),
    ("rope", ["--picker-speed", "1e-9"], "argument --picker-speed: PickerConfig: one action "
                                         "would take 1.73e+10 steps of 0.01 s"),
    ("rope", ["--n", "100000"], "argument --n: RopeSceneConfig.n 100000 puts the particles "
                                "5e-06 m apart, closer than their diameter"),
    ("cloth_fold", ["--n", "100000"], "argument --n: one CEM population's rollout (32 plans x "
                                      "2 actions x 271 steps per action on 10000000000 "
                                      "particles) needs about"),
    ("cloth_fold", ["--horizon", "1000000"], "argument --horizon: one CEM population's"),
    ("key_particles", ["--n", "100000"], "argument --n=100000: a cloth of 100000 x "
                                               "100000 = 1e+10 particles needs about 37.3 TiB,"
                                               " more than this machine's memory"),
    ("key_particles", ["--noise-n", "16,100000"], "argument --noise-n=100000: a cloth of"),
    ("key_particles", ["--simulated-n", "100000"], "argument --simulated-n=100000: a cloth"),
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


@pytest.mark.parametrize("script", ["cloth_fold", "key_particles"])
def test_an_unwritable_out_is_a_usage_error(tmp_path, capsys, no_run, script):
    cli_checks.an_unwritable_out_is_a_usage_error(tmp_path, capsys, SCRIPTS[script])


@pytest.mark.parametrize("script", ["cloth_fold", "key_particles"])
def test_an_unwritable_out_is_a_usage_error_even_for_root(tmp_path, capsys, no_run,
                                                          monkeypatch, script):
    cli_checks.an_unwritable_out_is_a_usage_error_even_for_root(tmp_path, capsys, monkeypatch,
                                                                SCRIPTS[script])


# ------------------------------------------------------------------------ run-time failures
def test_a_runtime_failure_is_one_line_and_exit_1(tmp_path, capsys, monkeypatch):
    def full_disk(*args, **kwargs):
        raise OSError("No space left on device\nwhile writing")
    monkeypatch.setattr(key_particles, "write_curve", full_disk)
    monkeypatch.delenv(cli.TRACEBACK_ENV, raising=False)
    argv = ["--quick", "--task", "rope_straighten", "--out", str(tmp_path / "kp")]
    assert key_particles.main(argv) == 1
    err = capsys.readouterr().err
    assert err.strip().splitlines()[-1] == ("key_particles.py: error: OSError: No space left "
                                            "on device while writing")
    assert "Traceback" not in err
    monkeypatch.setenv(cli.TRACEBACK_ENV, "1")             # the traceback on request
    assert key_particles.main(argv) == 1
    err = capsys.readouterr().err
    assert "Traceback (most recent call last)" in err and "full_disk" in err
    assert err.strip().splitlines()[-1].startswith("key_particles.py: error: OSError")


def test_a_runtime_failure_in_a_real_process(tmp_path):
    """The exit status and stderr of key_particles.py run as a program, failing after parsing
    (report.py's: tests/experiments/test_scripts.py)."""
    code = ("import sys\n"
            "from planners.pick_place.experiments import key_particles\n"
            "def boom(*a, **k):\n"
            "    raise RuntimeError('the plot failed')\n"
            "key_particles.plot_task = boom\n"
            "sys.exit(key_particles.main())\n")
    proc = subprocess.run([sys.executable, "-c", code, "--quick", "--task", "rope_fold",
                           "--out", str(tmp_path / "kp")], capture_output=True, text=True,
                          timeout=300, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert proc.returncode == 1 and "Traceback" not in proc.stderr, proc.stderr
    assert proc.stderr.strip().splitlines()[-1] == \
        "key_particles.py: error: RuntimeError: the plot failed"


# ------------------------------------------------------------- failed trials: exit 1, listed
def test_pick_place_with_failing_trials_exits_1(tmp_path, monkeypatch):
    monkeypatch.setattr(sweep, "run_trial", impossible)
    out = tmp_path / "rope"
    assert fig7.rope(["--quick", "--methods", "scripted,random", "--out", str(out),
                      "--no-render"]) == 1
    summary = json.loads((out / "summary.json").read_text())
    assert sorted(k.split("-")[0] for k in summary["failed"]) == ["random", "scripted"]
    assert summary["methods"] == {}
    check_provenance(summary, "rope.py")


def test_key_particles_lists_a_failed_task_and_exits_1(tmp_path, monkeypatch):
    real = key_particles.reduce_goal

    def reduce_goal(goal, *args):
        if goal.name.startswith("rope_fold"):
            raise RuntimeError("polyline QP ended with status infeasible")
        return real(goal, *args)
    monkeypatch.setattr(key_particles, "reduce_goal", reduce_goal)
    out = tmp_path / "kp"
    for task in ("rope_straighten", "rope_fold"):
        code = key_particles.main(["--quick", "--task", task, "--out", str(out)])
        summary = json.loads((out / "summary.json").read_text())
        check_provenance(summary, "key_particles.py")
        if task == "rope_straighten":
            assert code == 0 and summary["failed"] == {} and summary["tasks"]
            assert list(summary["trial_commits"].values()) == [1]
        else:
            assert code == 1 and summary["tasks"] == {} and summary["trial_commits"] == {}
            assert summary["failed"] == {
                "rope_fold": "RuntimeError: polyline QP ended with status infeasible"}


def test_key_particles_noise_sweep_failures_and_resume(tmp_path, monkeypatch, caplog):
    """A goal that does not converge is a result (flagged), an error a failure (listed, not
    counted, retried on resume); lines cut short and rows of another dopt version are
    recomputed."""
    calls = []
    broken = {"fail": True}
    clean_fold = key_particles.make_goal("rope_fold").positions

    def reduce_goal(goal, rope_config, cloth_config):
        calls.append(goal.name)
        if broken["fail"] and getattr(goal, "faces", None) is not None \
                and cloth_config.panels == "off":
            raise RuntimeError("decimation crashed")
        if goal.name == "rope_fold" and not np.array_equal(goal.positions, clean_fold):
            return SimpleNamespace(n_keys=7, reached_threshold=False)
        return SimpleNamespace(n_keys=key_particles.CLOTH_REFERENCE_KEYS.get(goal.name, 2),
                               reached_threshold=True)

    monkeypatch.setattr(key_particles, "reduce_goal", reduce_goal)
    monkeypatch.setattr(key_particles, "code_version",
                        lambda: {"version": "1.0.0", "commit": "abc"})
    journal = tmp_path / "noise.jsonl"

    def sweep():
        calls.clear()
        return key_particles.noise_sweep(journal, None, key_particles.ClothConfig(),
                                         sigmas=[1e-4], resolutions=[3], seeds=1,
                                         panel_modes=["on", "off"])
    rows, failed = sweep()
    n_cloth = len(key_particles.CLOTH_TASKS) * len(key_particles.TRIANGULATIONS)
    assert len(rows) == len(key_particles.ROPE_TASKS) + 2 * n_cloth
    assert len(failed) == n_cloth and all(k.startswith("noise/cloth_") and "panels-off" in k
                                          for k in failed)
    assert set(failed.values()) == {"RuntimeError: decimation crashed"}
    table = key_particles.noise_table(rows)
    assert table["cloth, panels on"] == {"0.1 mm": f"{n_cloth}/{n_cloth}"}
    assert "cloth, panels off" not in table                  # failures are not counted
    fold = next(r for r in rows if r["task"] == "rope_fold")
    assert fold["n_keys"] == 7 and "error" not in fold      # did not converge: a result
    assert fold["reached_threshold"] is False and not fold["held"]
    assert all(r["code"] == {"version": "1.0.0", "commit": "abc"} for r in rows)

    # resume: the failed goals run again, and a row cut short and another version's row too
    lines = journal.read_text().splitlines()
    straighten = next(i for i, ln in enumerate(lines) if '"rope_straighten"' in ln)
    old = json.loads(lines[straighten])
    old["code"]["version"] = "0.9.0"
    lines[straighten] = json.dumps(old)
    unequal = next(i for i, ln in enumerate(lines) if '"rope_fold_unequal"' in ln)
    cut = lines.pop(unequal)[:25]
    journal.write_text("\n".join(lines) + "\n" + cut)            # the last write cut short
    broken["fail"] = False
    with caplog.at_level(logging.WARNING, logger="key_particles"):
        rows, failed = sweep()
    assert failed == {} and len(rows) == len(key_particles.ROPE_TASKS) + 2 * n_cloth
    assert f"{journal} line {len(lines) + 1} is not a noise row" in caplog.text
    assert "written by dopt 0.9.0" in caplog.text
    reference = list(key_particles.ROPE_TASKS)
    assert sorted(calls) == sorted(reference + ["rope_straighten", "rope_fold_unequal"]
                                   + [c for c in key_particles.CLOTH_TASKS
                                      for _ in key_particles.TRIANGULATIONS])
    assert key_particles.noise_table(rows)["cloth, panels off"] == {
        "0.1 mm": f"{n_cloth}/{n_cloth}"}
    assert all(json.loads(ln) for ln in journal.read_text().splitlines()[len(lines) + 1:])


# --------------------------------------------------------------------------- trial files
def test_truncated_and_stray_trial_files_are_named_and_recomputed(tmp_path, caplog, capsys):
    out = tmp_path / "rope"
    argv = ["--quick", "--methods", "scripted", "--out", str(out), "--no-render"]
    assert fig7.rope(argv) == 0
    first = json.loads((out / "summary.json").read_text())
    (trial,) = (out / "trials").glob("*.json")
    assert json.loads(trial.read_text())["code"]["commit"] in first["trial_commits"]
    trial.write_text(trial.read_text()[:60])                           # a write cut short
    (out / "trials" / "notes.json").write_text('{"note": "not a trial"}')
    with caplog.at_level(logging.WARNING, logger="dopt.lab.sweep"):
        assert fig7.rope(argv) == 0
    assert f"trial file {trial} is not used (not valid JSON" in caplog.text
    assert f"trial file {out / 'trials' / 'notes.json'} is not used (not a trial record" \
        in caplog.text
    assert (out / "trials" / "corrupt" / trial.name).exists()
    assert (out / "trials" / "corrupt" / "notes.json").exists()
    assert json.loads(trial.read_text())["result"]["method"] == "scripted"   # recomputed
    again = json.loads((out / "summary.json").read_text())
    assert again["methods"] == first["methods"] and again["failed"] == {}
    assert sum(again["trial_commits"].values()) == 1
    stamp = trial.stat().st_mtime_ns
    assert fig7.rope([*argv, "--fresh"]) == 0                           # recompute anyway
    assert trial.stat().st_mtime_ns != stamp
    assert (out / "trials" / "outdated" / trial.name).exists()
    capsys.readouterr()


# ------------------------------------------------------------------------------- --help
def _parsers() -> dict:
    return {"cloth_fold": fig7.parser("cloth"), "rope": fig7.parser("rope"),
            "key_particles": key_particles.parser()}


def test_every_add_argument_is_in_a_parser():
    parsers = _parsers()
    cli_checks.every_add_argument_is_in_a_parser({
        PICK / "fig7.py": [parsers["cloth_fold"], parsers["rope"]],
        PICK / "key_particles.py": [parsers["key_particles"]]})


@pytest.mark.parametrize("script", list(SCRIPTS))
def test_help_lists_every_flag(script, capsys):
    flags = cli_checks.help_lists_every_flag(capsys, SCRIPTS[script], _parsers()[script])
    assert {"--out", "--help"} <= flags
