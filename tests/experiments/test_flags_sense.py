"""Flags checked for sense at parse time, each once accepted: a control noise that can only
make a non-finite cost (1e300: the trial was stored with mpc_cost null and every rerun died in
the summary), --layouts where the preset or the task never reads them (silently ignored), a
--layouts scene that makes no sense (found by its trial alone), --quick dropping an explicit
--trials or --seeds, and OUT/summary.json being a folder (reported after every trial ran).
Each is a usage error (one line naming the flag, exit 2) that creates nothing, or, for
--quick, the explicit count kept."""

import mpc
import panda_execute
import pick_place_cli
import pytest
import rho_sweep
import rope

from tests.dopt.tasks.test_authors_layout_sense import CYLINDER_XY, _layout

REAL_MAKE_PROBLEM = pick_place_cli.make_problem


@pytest.fixture(autouse=True)
def no_run(monkeypatch):
    """What follows the flag checks fails loudly: a flag accepted by mistake gives exit 1
    (the test, expecting 2, fails) instead of running a sweep."""
    def stop(*args, **kwargs):
        raise AssertionError("the arguments were accepted")
    monkeypatch.setattr(pick_place_cli, "make_problem", stop)
    monkeypatch.setattr(mpc, "run", stop)
    monkeypatch.setattr(panda_execute, "run_with_console", stop)


def usage_error(capsys, main, argv) -> str:
    with pytest.raises(SystemExit) as exc:
        main([str(a) for a in argv])
    err = capsys.readouterr().err
    assert exc.value.code == 2, err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    return err


@pytest.mark.parametrize("main", [mpc.main, rho_sweep.main])
@pytest.mark.parametrize("noise", ["1e300", "2"])
def test_a_control_noise_beyond_the_control_range_is_refused(tmp_path, capsys, main, noise):
    out = tmp_path / "out"
    err = usage_error(capsys, main, ["--quick", "--control-noise", noise, "--out", out])
    assert f"argument --control-noise: must be <= 1, got {noise}" in err
    assert not out.exists()


def test_the_largest_control_noise_is_accepted(tmp_path):
    args = mpc.parse_args(["--quick", "--control-noise", "1", "--out", str(tmp_path / "o")])
    assert mpc.make_trials(args)[0].params["control_noise"] == 1.0


@pytest.mark.parametrize("flags", [["--preset", "ours"], ["--preset", "paper"],
                                   ["--preset", "authors", "--task", "soft"],
                                   ["--preset", "authors", "--task", "soft_rigid"]])
def test_layouts_where_nothing_reads_them_are_refused(tmp_path, capsys, flags):
    _layout(tmp_path)
    out = tmp_path / "out"
    err = usage_error(capsys, mpc.main, [*flags, "--layouts", tmp_path, "--out", out])
    assert "argument --layouts: only --preset authors on --task clutter" in err
    assert not out.exists()


def test_a_senseless_layout_is_refused_before_any_trial(tmp_path, capsys):
    layouts = tmp_path / "layouts"
    layouts.mkdir()
    _layout(layouts, name="0.csv")
    _layout(layouts, goal=CYLINDER_XY, name="1.csv")            # the goal on its cylinder
    out = tmp_path / "out"
    err = usage_error(capsys, mpc.main, ["--preset", "authors", "--layouts", layouts,
                                         "--trials", "2", "--out", out])
    assert f"argument --layouts: {layouts / '1.csv'}: the goal" in err
    assert "on the goal cylinder" in err and not out.exists()
    err = usage_error(capsys, mpc.main, ["--preset", "authors", "--layouts", layouts,
                                         "--trials", "3", "--seed", "1", "--out", out])
    assert "on the goal cylinder" in err                         # the first bad one
    err = usage_error(capsys, mpc.main, ["--preset", "authors", "--layouts", layouts,
                                         "--seed", "2", "--trials", "1", "--out", out])
    assert f"argument --layouts: no {layouts / '2.csv'}" in err


class Trials(SystemExit):
    """Raised in place of the sweep (past the scripts' one-line error handler, as an exit
    is): the trials the run would run."""

    def __init__(self, trials):
        super().__init__(0)
        self.trials = trials


def _seeds(trials) -> list:
    return sorted({t.params["seed"] for t in trials})


def test_quick_keeps_an_explicit_trial_count(tmp_path, monkeypatch):
    out = str(tmp_path / "o")
    assert mpc.parse_args(["--quick", "--trials", "3", "--out", out]).trials == 3
    assert mpc.parse_args(["--quick", "--out", out]).trials == 1
    assert mpc.parse_args(["--out", out]).trials == mpc.DEFAULT_TRIALS

    def capture(fn, trials, *args, **kwargs):
        raise Trials(trials)
    monkeypatch.setattr(panda_execute, "run_with_console", capture)
    for flags, seeds in [(["--seeds", "2"], [0, 1]), ([], [0])]:
        with pytest.raises(Trials) as run:
            panda_execute.main(["--quick", "--goals", "diagonal", *flags, "--out", out])
        assert _seeds(run.value.trials) == seeds


@pytest.mark.parametrize("flags, seeds", [(["--quick", "--seeds", "2"], [0, 1]),
                                          (["--quick"], [0]),
                                          (["--quick", "--preset", "ours", "--seeds", "3"],
                                           [0, 1, 2])])
def test_quick_keeps_explicit_seeds(tmp_path, monkeypatch, flags, seeds):
    """The seeds the run's trials have (the sweep stopped just before it starts)."""
    def capture(problem, settings, trials, *args):
        raise Trials(trials)
    monkeypatch.setattr(pick_place_cli, "make_problem", REAL_MAKE_PROBLEM)
    monkeypatch.setattr(pick_place_cli, "estimate_line", capture)
    with pytest.raises(Trials) as run:
        rope.main([*flags, "--methods", "scripted", "--out", str(tmp_path / "o")])
    assert _seeds(run.value.trials) == seeds


@pytest.mark.parametrize("main, argv", [
    (mpc.main, ["--quick"]), (rope.main, ["--quick", "--methods", "scripted"]),
    (panda_execute.main, ["--quick"])])
@pytest.mark.parametrize("name", ["summary.json"])
def test_an_output_file_that_is_a_folder_is_refused_before_any_trial(tmp_path, capsys, main,
                                                                     argv, name):
    out = tmp_path / "out"
    (out / name).mkdir(parents=True)
    err = usage_error(capsys, main, [*argv, "--out", out])
    assert f"argument --out: the run writes {name} there, but {out.absolute() / name} is a " \
           f"folder" in err
    assert not (out / "trials").exists()


@pytest.mark.parametrize("main, argv, name", [(mpc.main, ["--quick"], "table1.md"),
                                              (rope.main, ["--quick"], "curves.csv")])
def test_every_file_a_run_writes_is_checked(tmp_path, capsys, main, argv, name):
    out = tmp_path / "out"
    (out / name).mkdir(parents=True)
    assert f"{name} there" in usage_error(capsys, main, [*argv, "--out", out])
