"""Every bad input of every experiment script is a usage error (one line, exit 2) naming the flag,
before anything runs or any folder is created; a failure at run time is one line on stderr and
exit 1; an experiment with a failed trial exits 1 and lists it in summary.json; bad trial files
are named, moved aside and recomputed; --help shows every flag. The scripts' main(argv) run
in-process (their trial functions patched where a run would take long), a subprocess only where the
exit status of a real process is the point."""

import argparse
import ast
import json
import logging
import os
import stat
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import cloth_fold
import numpy as np
import pytest
import rope

import dopt.lab.cli
from dopt.lab import cli
from dopt.lab.report import cli as report
from planners.pick_place.experiments import fig7, key_particles, sweep
from planners.svr_mpc.experiments import clock_check, mapping, runner
from planners.svr_mpc.experiments import explain as svr_explain
from planners.svr_mpc.experiments import fig4 as rho_sweep
from planners.svr_mpc.experiments import table1 as mpc

ROOT = Path(__file__).resolve().parents[2]
EXPERIMENTS = ROOT / "experiments"
PICK = ROOT / "planners" / "pick_place" / "experiments"
#: where the SVR experiments' flags are added (their scripts in experiments/ are thin)
SVR_SOURCES = ROOT / "planners" / "svr_mpc" / "experiments"
SCRIPTS = {"cloth_fold": cloth_fold, "rope": rope, "mpc": mpc, "rho_sweep": rho_sweep,
           "key_particles": key_particles, "report": report, "svr_explain": svr_explain,
           "clock_check": clock_check}


@pytest.fixture
def no_run(monkeypatch):
    """Whatever follows parsing in each script fails loudly: a probe that parses by mistake
    returns 1 instead of running an experiment (and the test, expecting exit 2, fails)."""
    def stop(*args, **kwargs):
        raise AssertionError("the arguments were accepted")
    monkeypatch.setattr(fig7, "make_problem", stop)
    monkeypatch.setattr(mapping, "make_trials", stop)
    monkeypatch.setattr(key_particles, "goal_sequence", stop)
    monkeypatch.setattr(report, "generate", stop)


def usage_error(capsys, script: str, argv: list) -> str:
    """Run ``script``'s main on ``argv``; assert argparse's exit 2; return stderr."""
    with pytest.raises(SystemExit) as exc:
        SCRIPTS[script].main([str(a) for a in argv])
    err = capsys.readouterr().err
    assert exc.value.code == 2, err
    assert "Traceback" not in err
    assert len(err.strip().splitlines()) == 1, err                 # one line, no usage block
    assert err.rstrip().endswith("--help lists the flags)"), err
    return err


BAD = [
    # negative or zero sizes and seeds
    ("cloth_fold", ["--seed", "-1"], "argument --seed: must be >= 0, got -1"),
    ("rope", ["--seed", "-1"], "argument --seed: must be >= 0, got -1"),
    ("mpc", ["--seed", "-1"], "argument --seed: must be >= 0, got -1"),
    ("rho_sweep", ["--seed", "-1"], "argument --seed: must be >= 0, got -1"),
    ("key_particles", ["--seed", "-1"], "argument --seed: must be >= 0, got -1"),
    ("key_particles", ["--cloth-n", "1"], "argument --cloth-n: must be >= 2, got 1"),
    ("key_particles", ["--cloth-n", "0"], "argument --cloth-n: must be >= 2, got 0"),
    ("key_particles", ["--cloth-n", "2.5"], "argument --cloth-n: '2.5' is not an integer"),
    ("key_particles", ["--noise-seeds", "0"], "argument --noise-seeds: must be >= 1, got 0"),
    ("cloth_fold", ["--threads", "-1"], "argument --threads: must be >= 0, got -1"),
    ("rope", ["--threads", "-1"], "argument --threads: must be >= 0, got -1"),
    ("mpc", ["--threads", "-1"], "argument --threads: must be >= 0, got -1"),
    ("rho_sweep", ["--threads", "-1"], "argument --threads: must be >= 0, got -1"),
    ("cloth_fold", ["--seeds", "0"], "argument --seeds: must be >= 1, got 0"),
    ("cloth_fold", ["--n", "2"], ">= 3, got 2"),
    ("rope", ["--population", "0"], "argument --population: must be >= 1, got 0"),
    ("rope", ["--elites", "9", "--population", "8"], "elites <= population"),
    ("rope", ["--bound", "nan"], "argument --bound: must be > 0, got nan"),
    ("mpc", ["--trials", "0"], "argument --trials: must be >= 1, got 0"),
    ("mpc", ["--workers", "0"], "argument --workers: must be >= 1, got 0"),
    ("mpc", ["--slowdown", "-2"], "argument --slowdown: must be > 0, got -2"),
    ("mpc", ["--control-noise", "inf"], "argument --control-noise: must be >= 0, got inf"),
    ("mpc", ["--task", "nope"], "argument --task: invalid choice: 'nope'"),
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
    ("cloth_fold", ["--methods", "simple,nope"], "argument --methods: unknown methods "
                                                 "['nope']"),
    ("rope", ["--methods", "simple,simple"], "argument --methods: methods simple given twice"),
    ("rope", ["--methods", ","], "argument --methods: unknown methods ['', '']"),
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
    out = tmp_path / "out"
    err = usage_error(capsys, script, [*argv, "--out", out])
    assert message in err and f"{script}.py: error:" in err
    assert not out.exists()


@pytest.mark.parametrize("script", ["cloth_fold", "rope", "mpc", "rho_sweep", "key_particles"])
def test_out_and_record_must_be_writable_places(tmp_path, capsys, no_run, script):
    afile = tmp_path / "afile"
    afile.write_text("")
    err = usage_error(capsys, script, ["--out", afile])
    assert f"argument --out: {afile} exists and is not a folder" in err
    err = usage_error(capsys, script, ["--out", afile / "sub"])
    assert f"argument --out: cannot create {afile / 'sub'}: {afile} is not a folder" in err
    assert "argument --out: an empty path" in usage_error(capsys, script, ["--out", ""])
    out = tmp_path / "out"
    err = usage_error(capsys, script, ["--out", out, "--record", tmp_path])
    assert f"argument --record: {tmp_path} is a folder" in err
    err = usage_error(capsys, script, ["--out", out, "--record", out])
    assert "argument --record: " in err and "is the --out folder" in err
    assert not out.exists()


@pytest.mark.parametrize("script", ["cloth_fold", "rope", "mpc", "rho_sweep", "key_particles"])
def test_places_that_fail_only_when_written_fail_before_the_run(tmp_path, capsys, no_run,
                                                                script):
    """/sys and /proc pass every permission check (root may write anything), yet a file cannot
    be created there: the scripts try, before the first trial, and say so."""
    if not Path("/sys").is_dir():
        pytest.skip("no /sys here")
    out = tmp_path / "out"
    err = usage_error(capsys, script, ["--out", out, "--record", "/sys/rec.json"])
    assert "argument --record: cannot write /sys/rec.json: " in err
    err = usage_error(capsys, script, ["--out", "/sys/out"])
    assert "argument --out: cannot write /sys/out: " in err
    assert not out.exists()


def _read_only(folder: Path) -> None:
    folder.mkdir()
    folder.chmod(stat.S_IRUSR | stat.S_IXUSR)


@pytest.mark.parametrize("script", ["cloth_fold", "mpc", "key_particles"])
def test_an_unwritable_out_is_a_usage_error(tmp_path, capsys, no_run, script):
    ro = tmp_path / "ro"
    _read_only(ro)
    try:
        if os.access(ro, os.W_OK):
            pytest.skip("chmod does not stop this user (root) from writing")
        err = usage_error(capsys, script, ["--out", ro])
        assert f"argument --out: {ro} is not writable" in err
        err = usage_error(capsys, script, ["--out", ro / "a" / "b"])
        assert f"argument --out: cannot create {ro / 'a' / 'b'}: {ro} is not writable" in err
    finally:
        ro.chmod(stat.S_IRWXU)


@pytest.mark.parametrize("script", ["cloth_fold", "mpc", "key_particles"])
def test_an_unwritable_out_is_a_usage_error_even_for_root(tmp_path, capsys, no_run,
                                                          monkeypatch, script):
    """The same check with os.access answering as it does for a user without the right."""
    ro = tmp_path / "ro"
    ro.mkdir()
    real = os.access
    monkeypatch.setattr(dopt.lab.cli.os, "access",
                        lambda p, mode: False if Path(p) == ro else real(p, mode))
    assert f"argument --out: {ro} is not writable" in usage_error(capsys, script,
                                                                  ["--out", ro])
    err = usage_error(capsys, script, ["--out", ro / "new"])
    assert f"cannot create {ro / 'new'}: {ro} is not writable" in err
    assert not (ro / "new").exists()


def test_report_rejects_a_missing_results_dir_and_an_unwritable_page(tmp_path, capsys, no_run,
                                                                     monkeypatch):
    err = usage_error(capsys, "report", ["--results-dir", tmp_path / "nope"])
    assert f"argument --results-dir: {tmp_path / 'nope'} does not exist" in err
    (tmp_path / "afile").write_text("")
    err = usage_error(capsys, "report", ["--results-dir", tmp_path / "afile"])
    assert "is not a folder" in err
    err = usage_error(capsys, "report", ["--results-dir", tmp_path, "--results-md", tmp_path])
    assert f"argument --results-md: {tmp_path} is a folder" in err


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
    """The exit status and stderr of the script run as a program (report.py: a result file
    that is not JSON; key_particles.py: a failure after parsing)."""
    results = tmp_path / "results"
    results.mkdir()
    (results / "broken.json").write_text('{"experiment": "fig7", ')
    proc = subprocess.run([sys.executable, str(EXPERIMENTS / "report.py"), "--results-dir",
                           str(results), "--results-md", str(tmp_path / "R.md"), "--readme",
                           str(tmp_path / "README.md")], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert "report.py: error:" in proc.stderr and "broken.json" in proc.stderr
    code = ("import sys\n"
            f"sys.path.insert(0, {str(EXPERIMENTS)!r})\n"
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
def _impossible(params, *args, **kwargs):
    raise RuntimeError(f"impossible setting for seed {params['seed']}")


def _check_provenance(summary: dict, script: str) -> None:
    p = summary["provenance"]
    assert p["command"].startswith(f"python experiments/{script}") and p["git_commit"]
    assert all(p["versions"][k] for k in ("dopt", "mujoco", "torch"))


def test_mpc_with_every_trial_failing_exits_1(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(runner, "run_trial", _impossible)
    out = tmp_path / "mpc"
    assert mpc.main(["--quick", "--rules", "baseline,naive", "--out", str(out),
                     "--no-render"]) == 1
    summary = json.loads((out / "summary.json").read_text())
    assert sorted(k.split("-")[1] for k in summary["failed"]) == ["baseline", "naive"]
    assert all(k.startswith("clutter-") and "-seed0" in k for k in summary["failed"])
    assert set(summary["failed"].values()) == {"RuntimeError: impossible setting for seed 0"}
    assert summary["methods"] == {} and summary["trial_commits"] == {}
    _check_provenance(summary, "mpc.py")
    assert "FAILED clutter-naive" in capsys.readouterr().err
    assert not list((out / "trials").glob("*.json"))


def test_rho_sweep_with_a_failing_trial_exits_1(tmp_path, monkeypatch):
    monkeypatch.setattr(runner, "run_trial", _impossible)
    out = tmp_path / "rho"
    assert rho_sweep.main(["--quick", "--rhos", "1", "--thetas", "0", "--out", str(out)]) == 1
    summary = json.loads((out / "summary.json").read_text())
    assert len(summary["failed"]) == 2 and summary["points"] == []
    _check_provenance(summary, "rho_sweep.py")


def test_pick_place_with_failing_trials_exits_1(tmp_path, monkeypatch):
    monkeypatch.setattr(sweep, "run_trial", _impossible)
    out = tmp_path / "rope"
    assert rope.main(["--quick", "--methods", "scripted,random", "--out", str(out),
                      "--no-render"]) == 1
    summary = json.loads((out / "summary.json").read_text())
    assert sorted(k.split("-")[0] for k in summary["failed"]) == ["random", "scripted"]
    assert summary["methods"] == {}
    _check_provenance(summary, "rope.py")


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
        _check_provenance(summary, "key_particles.py")
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
    assert rope.main(argv) == 0
    first = json.loads((out / "summary.json").read_text())
    (trial,) = (out / "trials").glob("*.json")
    assert json.loads(trial.read_text())["code"]["commit"] in first["trial_commits"]
    trial.write_text(trial.read_text()[:60])                           # a write cut short
    (out / "trials" / "notes.json").write_text('{"note": "not a trial"}')
    with caplog.at_level(logging.WARNING, logger="dopt.lab.sweep"):
        assert rope.main(argv) == 0
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
    assert rope.main([*argv, "--fresh"]) == 0                           # recompute anyway
    assert trial.stat().st_mtime_ns != stamp
    assert (out / "trials" / "outdated" / trial.name).exists()
    capsys.readouterr()


# ------------------------------------------------------------------------------- --help
def _parsers() -> dict:
    """{script: its parser} and, per source file, the parsers its add_argument calls build."""
    return {"cloth_fold": fig7.parser("cloth"), "rope": fig7.parser("rope"), "mpc": mpc.parser(),
            "rho_sweep": rho_sweep.parser(), "key_particles": key_particles.parser(),
            "report": report.parser(), "svr_explain": svr_explain.parser(),
            "clock_check": clock_check.parser()}


def _flags(ap) -> set:
    """The flags ``ap`` shows (a renamed flag's hidden old spelling left out)."""
    return {s for a in ap._actions if a.help != argparse.SUPPRESS for s in a.option_strings}


def _literal_flags(path: Path) -> set:
    """Every flag literal of every add_argument call in a source file."""
    flags = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Call) and getattr(node.func, "attr", "") == "add_argument":
            flags |= {a.value for a in node.args if isinstance(a, ast.Constant)
                      and isinstance(a.value, str) and a.value.startswith("-")}
    return flags


def test_every_add_argument_is_in_a_parser():
    parsers = _parsers()
    sources = {PICK / "fig7.py": ["cloth_fold", "rope"],
               SVR_SOURCES / "flags.py": ["mpc", "rho_sweep"],
               SVR_SOURCES / "table1.py": ["mpc"], SVR_SOURCES / "fig4.py": ["rho_sweep"],
               PICK / "key_particles.py": ["key_particles"],
               # the report's command line lives in the lab (experiments/report.py is thin)
               ROOT / "dopt" / "lab" / "report" / "cli.py": ["report"]}
    for path, scripts in sources.items():
        literal = _literal_flags(path)
        assert literal, path
        covered = set().union(*(_flags(parsers[s]) for s in scripts))
        assert literal <= covered, (path, literal - covered)
    assert _literal_flags(SVR_SOURCES / "flags.py") <= _flags(parsers["mpc"])


@pytest.mark.parametrize("script", list(SCRIPTS))
def test_help_lists_every_flag(script, capsys):
    with pytest.raises(SystemExit) as exc:
        SCRIPTS[script].main(["--help"])
    text = capsys.readouterr().out
    assert exc.value.code == 0
    flags = {s for a in _parsers()[script]._actions if a.help != argparse.SUPPRESS
             for s in a.option_strings}               # hidden old spellings aside
    assert {"--out", "--help"} <= flags or script == "report"
    missing = [f for f in flags if f not in text]
    assert not missing, missing
    assert cli.TRACEBACK_ENV in text                   # how to see a traceback


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
