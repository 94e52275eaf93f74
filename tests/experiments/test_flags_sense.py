"""Flags checked for sense at parse time, each once accepted (the SVR experiments' in
tests/planners/svr_mpc/experiments/test_flags_sense.py): --quick dropping an explicit --trials
or --seeds, and OUT/summary.json being a folder (reported after every trial ran). Each is a
usage error (one line naming the flag, exit 2) that creates nothing, or, for --quick, the
explicit count kept."""

import panda_execute
import pick_place_cli
import pytest
import rope

REAL_MAKE_PROBLEM = pick_place_cli.make_problem


@pytest.fixture(autouse=True)
def no_run(monkeypatch):
    """What follows the flag checks fails loudly: a flag accepted by mistake gives exit 1
    (the test, expecting 2, fails) instead of running a sweep."""
    def stop(*args, **kwargs):
        raise AssertionError("the arguments were accepted")
    monkeypatch.setattr(pick_place_cli, "make_problem", stop)
    monkeypatch.setattr(panda_execute, "run_with_console", stop)


def usage_error(capsys, main, argv) -> str:
    with pytest.raises(SystemExit) as exc:
        main([str(a) for a in argv])
    err = capsys.readouterr().err
    assert exc.value.code == 2, err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    return err


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
    (rope.main, ["--quick", "--methods", "scripted"]),
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


@pytest.mark.parametrize("main, argv, name", [(rope.main, ["--quick"], "curves.csv")])
def test_every_file_a_run_writes_is_checked(tmp_path, capsys, main, argv, name):
    out = tmp_path / "out"
    (out / name).mkdir(parents=True)
    assert f"{name} there" in usage_error(capsys, main, [*argv, "--out", out])
