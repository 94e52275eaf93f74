"""experiments/mpc.py (planners.svr_mpc.experiments.table1) end to end (quick), its resume,
its Ray path and its input errors."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from planners.svr_mpc.experiments import mapping, table1
from planners.svr_mpc.trial_names import legacy_trial_key

ROOT = Path(__file__).resolve().parents[4]
SCRIPT = ROOT / "experiments" / "mpc.py"


def run(*args, check=True):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True,
                          env=env, timeout=300)
    if check and proc.returncode != 0:
        raise AssertionError(proc.stderr[-3000:])
    return proc


def test_quick_run_writes_table_and_resumes(tmp_path):
    out = tmp_path / "mpc"
    run("--quick", "--rules", "baseline,svr-sum", "--out", str(out))
    summary = json.loads((out / "summary.json").read_text())
    assert summary["task"] == "clutter"
    assert set(summary["methods"]) == {"baseline", "sum-t10-r1"}
    base = summary["methods"]["baseline"]
    assert base["mpc_cost_normalised_mean"] == 1.0 and base["n_trials"] == 1
    assert base["n_dofs_mean"] == 55.0 and base["opt_ms_mean"] > 0
    assert "| sum-t10-r1 |" in (out / "table1.md").read_text()
    assert (out / "table1.csv").exists()
    for name in ("mpc_dofs.png", "mpc_goal_distance.png", "final_baseline.png",
                 "final_sum-t10-r1.png"):
        assert (out / name).stat().st_size > 10_000, name
    files = sorted((out / "trials").glob("*.json"))
    assert len(files) == 2
    result = json.loads(files[0].read_text())["result"]
    stride = result["goal_distance_stride"]
    assert len(result["goal_distance"]) == -(-result["steps"] // stride) + 1
    assert result["goal_distance"][0] == pytest.approx(result["goal_distance_start"], abs=1e-5)
    assert result["goal_distance"][-1] == pytest.approx(result["goal_distance_end"], abs=1e-5)
    assert len(result["final_state"]) > 0
    assert result["blowups"] == [] and summary["blowups"] == []      # no blow-up to capture
    stamps = [f.stat().st_mtime_ns for f in files]
    run("--quick", "--rules", "baseline,svr-sum", "--out", str(out))
    assert [f.stat().st_mtime_ns for f in files] == stamps     # nothing was redone


def test_keep_controls_reaches_the_trials_and_reruns_those_without(tmp_path):
    """--keep-controls: by default the first seed's trial keeps its start state and controls
    and the others do not, all under the keys they have without them; the bare flag (all)
    reruns a stored trial without them (its file kept under trials/outdated/, not corrupt/:
    it is sound) and reuses one with them; dopt-view's replay of the kept controls ends
    within 1e-9 of its recorded final state; none keeps none."""
    from planners.view import load_mpc

    out = tmp_path / "mpc"
    flags = ("--preset", "paper", "--clock", "model", "--timeout", "8", "--rules",
             "baseline", "--no-render", "--out", str(out))
    run(*flags, "--trials", "2", "--seed", "3")
    first, plain = sorted((out / "trials").glob("*.json"))      # seed3 before seed4
    assert "-seed3-" in first.name and "-seed4-" in plain.name
    assert "controls" not in json.loads(plain.read_text())["result"]
    assert len(json.loads(first.read_text())["result"]["controls"]) == 8
    stamp = first.stat().st_mtime_ns
    run(*flags, "--trials", "2", "--seed", "3", "--keep-controls")
    assert first.stat().st_mtime_ns == stamp                   # it has them: reused
    (moved,) = (out / "trials" / "outdated").glob("*.json")
    assert moved.name.startswith(plain.stem) and not (out / "trials" / "corrupt").exists()
    assert "controls" not in json.loads(moved.read_text())["result"]
    result = json.loads(plain.read_text())["result"]
    assert len(result["controls"]) == result["steps"] == 8 and result["start_state"]
    assert load_mpc(plain).replay_error <= 1e-9
    none = tmp_path / "none"
    run(*flags[:-1], str(none), "--trials", "1", "--keep-controls", "none")
    (path,) = (none / "trials").glob("*.json")
    assert "controls" not in json.loads(path.read_text())["result"]


def test_quick_is_a_short_episode_where_svr_visibly_acts(tmp_path):
    """--quick alone: the paper's protocol on rows sum-t10-r1 and baseline, one seed, 300
    agent steps on the model clock; SVR's |C| falls below the full set after its first
    optimisation while baseline's stays there, the two rows' costs differ, the goal object
    stays upright (no success claimed for a toppled cylinder), both episodes keep their
    controls and replay exactly, and the run's last lines name its pictures and the viewer
    command; the console gave an estimate up front and each trial's cost as it finished."""
    import mujoco

    from planners.svr_mpc import split_params
    from planners.view import load_mpc

    out = tmp_path / "quick"
    proc = run("--quick", "--no-render", "--out", str(out))
    summary = json.loads((out / "summary.json").read_text())
    assert summary["preset"] == "paper" and summary["clock"] == "model"
    rows = summary["methods"]
    assert set(rows) == {"sum-t10-r1", "baseline"}
    assert rows["sum-t10-r1"]["mpc_cost_normalised_mean"] != pytest.approx(1.0, abs=1e-3)
    for path in sorted((out / "trials").glob("*.json")):
        record = json.loads(path.read_text())
        res = record["result"]
        assert res["steps"] == 300 and len(res["controls"]) == 300
        full = res["n_dofs"][0]
        if record["params"]["method"] == "baseline":
            assert set(res["n_dofs"]) == {full}
        else:
            assert max(res["n_dofs"][1:]) < full
        episode = load_mpc(path)
        assert episode.replay_error <= 1e-9
        task = split_params(record["params"])[0].build_task(0)
        m, d = task.model, mujoco.MjData(task.model)
        body = m.body(task.goal_object).id
        for state in episode.states:
            mujoco.mj_setState(m, d, state, mujoco.mjtState.mjSTATE_INTEGRATION)
            mujoco.mj_kinematics(m, d)
            assert d.xmat[body][8] > np.cos(np.radians(30))       # within 30 deg of upright
    tail = proc.stdout.strip().splitlines()[-2:]
    assert tail[0].startswith("pictures: ") and str(out / "mpc_dofs.png") in tail[0]
    assert f"dopt-view {out}" in tail[1]
    assert "estimate: about" in proc.stderr
    said = proc.stdout + proc.stderr
    assert "finished clutter-baseline" in said and "MPC cost" in said and "left" in said


def test_ray_path(tmp_path):
    pytest.importorskip("ray")
    out = tmp_path / "ray"
    run("--quick", "--rules", "naive", "--ray", "--out", str(out), "--no-render")
    summary = json.loads((out / "summary.json").read_text())
    assert summary["methods"]["naive"]["n_trials"] == 1
    # no baseline in this sweep: nothing to normalise by, said so in the table
    assert "| naive | n/a |" in (out / "table1.md").read_text()
    assert (out / "mpc_dofs.png").exists() and not list(out.glob("final_*.png"))


@pytest.mark.parametrize("args, message", [
    (["--task", "nope"], "argument --task: invalid choice: 'nope'"),
    (["--rules", "baseline,svr"], "unknown rule"),
    (["--rows", "baseline,sum-t7"], "sum-t7"),
    (["--clock", "wall"], "argument --clock: invalid choice"),
    (["--clock", "virtual", "--clock-ms", "150"], "--clock-ms sets the model clock's duration"),
    (["--clock-ms", "0"], "argument --clock-ms: must be > 0"),
    (["--preset", "theirs"], "argument --preset: invalid choice"),
    (["--preset", "authors"], "problem 'authors' on clutter needs layouts"),
    (["--preset", "authors", "--layouts", "/nonexistent"], "layouts: no folder /nonexistent"),
    (["--rho", "-1"], "argument --rho: must be >= 0, got -1"),
    (["--rho", "nan"], "argument --rho: must be >= 0, got nan"),
    (["--theta", "-2"], "argument --theta: must be >= 0, got -2"),
    (["--trials", "0"], "argument --trials: must be >= 1, got 0"),
    (["--trials", "1.5"], "argument --trials: '1.5' is not an integer"),
])
def test_bad_arguments(tmp_path, args, message):
    proc = run(*args, "--out", str(tmp_path), check=False)
    assert proc.returncode == 2 and message in proc.stderr


@pytest.mark.parametrize("flags", [[], ["--timeout", "7", "--feedback", "both"]])
def test_trials_of_the_default_flags_are_valid_settings(tmp_path, flags):
    """Every trial the flags make (the task's own timeout when --timeout is not given) builds
    valid SVRMPCSettings, so a full run cannot fail on its parameters alone."""

    from planners.svr_mpc import SVRMPCSettings

    args = table1.parse_args(["--out", str(tmp_path / "o"), "--trials", "2", *flags])
    trials = mapping.make_trials(args)
    assert len(trials) == 2 * 5 * (2 if "both" in flags else 1)
    for t in trials:
        p = {k: v for k, v in t.params.items() if k != "seed"}
        assert SVRMPCSettings.from_params(p).params() == p
        assert ("-Y7-" if flags else "-Y0-") in legacy_trial_key(t.params)


def test_paper_preset_runs_the_nine_rows_by_name(tmp_path):
    """--preset paper makes the nine Table 1 rows with the authors' protocol; flags override
    it; --rows picks rows; the trial keys say what differs from the defaults."""

    from planners.svr_mpc import TABLE1_ROWS, row_label

    args = table1.parse_args(["--preset", "paper", "--trials", "2", "--out", str(tmp_path / "p")])
    trials = mapping.make_trials(args)
    assert len(trials) == 18 and len({t.key for t in trials}) == 18
    assert [row_label(t.params) for t in trials[:9]] == list(TABLE1_ROWS)
    for t in trials:
        p = t.params
        assert (p["cost"], p["warm_start"], p["clock"], p["control_noise"]) == \
            ("paper", True, "virtual", 0.05)
        assert "-costpaper-ws-clockvirtual2" in legacy_trial_key(t.params)
    args = table1.parse_args(["--preset", "paper", "--rows", "rand-t5,svd-t5-r1", "--cost", "ee",
                           "--trials", "1",
                           "--clock", "model", "--fd", "central", "--out", str(tmp_path / "q")])
    trials = mapping.make_trials(args)
    assert [row_label(t.params) for t in trials] == ["rand-t5 +central", "svd-t5-r1 +central"]
    assert trials[0].params["cost"] == "ee" and trials[0].params["clock"] == "model"
    assert trials[0].params["fd_centered"] and trials[0].params["fd_eps"] == 1e-6
    assert legacy_trial_key(trials[0].params).endswith("fdc1e-06")


def test_derivative_options_reach_the_trials(tmp_path):

    args = table1.parse_args(["--preset", "paper", "--rows", "sum-t10-r1", "--trials", "1",
                           "--fd-skip", "5", "--box-qp", "--out", str(tmp_path / "a")])
    (t,) = mapping.make_trials(args)
    assert (t.params["keypoints"], t.params["fd_skip"], t.params["box_qp"]) == ("skip", 5, True)
    assert legacy_trial_key(t.params).endswith("-skip5-boxqp")
    args = table1.parse_args(["--rows", "sum-t10-r1", "--trials", "1", "--keypoints", "adaptive",
                           "--out", str(tmp_path / "b")])
    (t,) = mapping.make_trials(args)
    assert t.params["keypoints"] == "adaptive"
    assert legacy_trial_key(t.params).endswith("-kpadaptive")


def test_rows_carry_their_own_derivative_variants(tmp_path):
    """--rows sum-t10-r1,sum-t10-r1+skip5: the plain row's trials are those of a Table 1 run
    (same keys, so a run in the same folder reuses them); the variant row differs only in its
    derivatives, and its label says so; the baseline label follows the global flags."""

    from planners.svr_mpc import row_label

    plain = mapping.make_trials(table1.parse_args(
        ["--preset", "paper", "--rows", "baseline,sum-t10-r1", "--trials", "2",
         "--out", str(tmp_path / "a")]))
    args = table1.parse_args(["--preset", "paper", "--rows",
                           "baseline,sum-t10-r1,sum-t10-r1+skip5,sum-t10-r1+adaptive+boxqp",
                           "--trials", "2", "--out", str(tmp_path / "a")])
    trials = mapping.make_trials(args)
    labels = [row_label(t.params) for t in trials[:4]]
    assert labels == ["baseline", "sum-t10-r1", "sum-t10-r1 +skip5",
                      "sum-t10-r1 +adaptive +boxqp"]
    assert {t.key for t in plain} <= {t.key for t in trials}
    skip = trials[2].params
    assert (skip["keypoints"], skip["fd_skip"], skip["box_qp"]) == ("skip", 5, False)
    assert {k: v for k, v in skip.items() if k not in ("keypoints", "fd_skip")} == \
        {k: v for k, v in trials[1].params.items() if k not in ("keypoints", "fd_skip")}
    assert mapping.baseline_label(args) == "baseline"
    glob = table1.parse_args(["--preset", "paper", "--rows", "baseline,sum-t10-r1+adaptive",
                           "--fd-skip", "2", "--trials", "1", "--out", str(tmp_path / "b")])
    assert mapping.baseline_label(glob) == "baseline +skip2"
    central = mapping.make_trials(table1.parse_args(
        ["--preset", "paper", "--rows", "sum-t10-r1+central+skip5", "--trials", "1",
         "--out", str(tmp_path / "c")]))[0]
    assert row_label(central.params) == "sum-t10-r1 +central +skip5"
    assert (central.params["fd_centered"], central.params["fd_eps"]) == (True, 1e-6)
    assert legacy_trial_key(central.params).endswith("-fdc1e-06-skip5")
    assert [row_label(t.params) for t in mapping.make_trials(glob)] == \
        ["baseline +skip2", "sum-t10-r1 +adaptive"]          # the row's variant wins


@pytest.mark.parametrize("rows, message", [
    ("sum-t10-r1+skip0", "skip<K>, adaptive, boxqp or central"),
    ("sum-t10-r1+central+central", "repeats a variant"),
    ("sum-t10-r1+skip5+adaptive", "repeats a variant"),
    ("sum-t10-r1+boxqp+boxqp", "repeats a variant"),
    ("sum-t9-r1+skip5", "unknown Table 1 row"),
    ("sum-t10-r1+skip5,sum-t10-r1+skip5", "given twice"),
])
def test_bad_row_variants_are_usage_errors(rows, message, capsys):

    with pytest.raises(SystemExit) as e:
        table1.parse_args(["--rows", rows, "--out", "unused"])
    assert e.value.code == 2 and message in capsys.readouterr().err


#: the committed results whose rows carry derivative variants (their --rows)
VARIANT_RESULTS = ["boxqp-clutter", "boxqp-soft", "boxqp-soft_rigid", "fd-central-clutter",
                   "keypoints-clutter", "keypoints-soft"]


@pytest.mark.parametrize("name", VARIANT_RESULTS)
def test_committed_variant_rows_find_their_trials_by_key(name, tmp_path):
    """The command line of a committed result with variant rows (+boxqp, +central, +skip<K>)
    makes the keys of its committed trials, every one: the typed derivative options give the
    keys the variant strings gave, so a rerun reuses the trials and resummarize finds them."""
    import json
    import shlex
    from pathlib import Path

    from dopt.lab.sweep import load_finished
    from dopt.lab.sweep_store import find_alias
    from planners.svr_mpc.experiments import runner

    root = Path(__file__).resolve().parents[4]
    argv = shlex.split(json.loads((root / "docs" / "results" / f"{name}.json").read_text())
                       ["provenance"]["command"])[2:]
    runs = Path(argv[argv.index("--out") + 1])
    argv[argv.index("--out") + 1] = str(tmp_path / "o")
    del argv[argv.index("--record"):argv.index("--record") + 2]
    assert any("+" in row for row in argv[argv.index("--rows") + 1].split(","))
    trials = mapping.make_trials(table1.parse_args(argv))
    committed = load_finished(root / runs)                         # loose or packed
    # under their older names (the sweep's Schema.aliases)
    found = {t.key: find_alias(committed, t.params, runner.SCHEMA) for t in trials}
    missing = [k for k, v in found.items() if v is None]
    assert trials and not missing, missing[:3]
    for t in trials:
        stored = committed[found[t.key]]["params"]
        assert {k: t.params[k] for k in stored} == stored


@pytest.mark.parametrize("flags, row", [
    (["--fd", "central"], "sum-t10-r1+central"),
    (["--fd-skip", "5"], "sum-t10-r1+skip5"),
    (["--fd-skip", "10"], "sum-t10-r1+skip10"),
    (["--box-qp"], "sum-t10-r1+boxqp"),
    (["--keypoints", "adaptive", "--fd-skip", "3"], "sum-t10-r1+adaptive"),
    (["--fd", "central", "--fd-skip", "5", "--box-qp"], "sum-t10-r1+central+skip5+boxqp"),
])
def test_derivative_flags_and_row_variants_make_the_same_trials(flags, row, tmp_path):
    """The flags build typed ``Derivatives``, a row's variants replace some of its fields:
    both routes give the same params and keys for the same options."""

    def trials(*argv):
        return [(t.key, t.params) for t in mapping.make_trials(table1.parse_args(
            ["--preset", "paper", "--trials", "2", "--out", str(tmp_path / "o"), *argv]))]

    assert trials("--rows", "sum-t10-r1", *flags) == trials("--rows", row)


def test_a_registered_optimiser_is_a_row_of_the_command_line(tmp_path, monkeypatch):
    """--rows baseline,NAME: the optimiser's trials name it in their params and keys, have a
    row of their own and are normalised by the iLQR baseline; its variants apply to it."""

    from planners.svr_mpc import OPTIMISERS, row_label, svr_optimiser

    monkeypatch.setitem(OPTIMISERS, "mine", svr_optimiser)
    args = table1.parse_args(["--preset", "paper", "--rows", "baseline,mine,mine+skip5",
                           "--trials", "1", "--out", str(tmp_path / "o")])
    base, mine, skip = mapping.make_trials(args)
    assert [row_label(t.params) for t in (base, mine, skip)] == \
        ["baseline", "mine", "mine +skip5"]
    assert "optimiser" not in base.params and mine.params["optimiser"] == "mine"
    old = legacy_trial_key
    assert old(mine.params) == old(base.params) + "-optmine"
    assert old(skip.params) == old(base.params) + "-skip5-optmine"
    assert len({base.key, mine.key, skip.key}) == 3
    assert mapping.baseline_label(args) == "baseline"
    monkeypatch.setenv("DOPT_OPTIMISERS", "no_such_optimisers_module")
    with pytest.raises(SystemExit) as e:
        table1.parse_args(["--rows", "baseline,theirs", "--out", str(tmp_path / "p")])
    assert e.value.code == 2


def test_the_authors_preset_runs_their_executor_and_clock_and_the_summary_names_both(tmp_path):
    """--preset authors: the authors' executor and clock, named in the summary's protocol and
    in the trial keys; --executor alg1 --clock virtual is the paper's Alg. 1 on the host's
    clock (the keys of the records made before), and only those flags differ."""

    args = table1.parse_args(["--task", "soft", "--preset", "authors", "--rows", "baseline",
                           "--trials", "1", "--out", str(tmp_path / "a")])
    (t,) = mapping.make_trials(args)
    proto = mapping.protocol(args, t.params)
    assert (proto["executor"], proto["clock"]) == ("authors", "authors")
    assert legacy_trial_key(t.params).endswith("-ws-clockauthors-execauthors-authors")
    args = table1.parse_args(["--task", "soft", "--preset", "authors", "--rows", "baseline",
                           "--executor", "alg1", "--clock", "virtual", "--trials", "1",
                           "--out", str(tmp_path / "b")])
    (old,) = mapping.make_trials(args)
    assert (mapping.protocol(args, old.params)["executor"], old.params["clock"]) == \
        ("alg1", "virtual")
    assert legacy_trial_key(old.params).endswith("-ws-clockvirtual2-authors")
    assert old.key != t.key
    assert {k for k in t.params if t.params[k] != old.params[k]} == {"executor", "clock"}
