"""Flags of the SVR experiments checked for sense at parse time, each once accepted: a control
noise that can only make a non-finite cost (1e300: the trial was stored with mpc_cost null and
every rerun died in the summary), --layouts where the preset or the task never reads them
(silently ignored), a --layouts scene that makes no sense (found by its trial alone), --quick
dropping an explicit --trials, and an output file being a folder (reported after every trial
ran). Each is a usage error (one line naming the flag, exit 2) that creates nothing, or, for
--quick, the explicit count kept."""

import pytest

from planners.svr_mpc.experiments import fig4, flags, mapping, runner, table1
from tests.dopt.tasks.push.test_authors_layout_sense import CYLINDER_XY, _layout


@pytest.fixture(autouse=True)
def no_run(monkeypatch):
    """What follows the flag checks fails loudly: a flag accepted by mistake gives exit 1
    (the test, expecting 2, fails) instead of running a sweep."""
    def stop(*args, **kwargs):
        raise AssertionError("the arguments were accepted")
    monkeypatch.setattr(runner, "run", stop)


def usage_error(capsys, main, argv) -> str:
    with pytest.raises(SystemExit) as exc:
        main([str(a) for a in argv])
    err = capsys.readouterr().err
    assert exc.value.code == 2, err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    return err


@pytest.mark.parametrize("main", [table1.main, fig4.main])
@pytest.mark.parametrize("noise", ["1e300", "2"])
def test_a_control_noise_beyond_the_control_range_is_refused(tmp_path, capsys, main, noise):
    out = tmp_path / "out"
    err = usage_error(capsys, main, ["--quick", "--control-noise", noise, "--out", out])
    assert f"argument --control-noise: must be <= 1, got {noise}" in err
    assert not out.exists()


def test_the_largest_control_noise_is_accepted(tmp_path):
    args = table1.parse_args(["--quick", "--control-noise", "1", "--out", str(tmp_path / "o")])
    assert mapping.make_trials(args)[0].params["control_noise"] == 1.0


@pytest.mark.parametrize("flags", [["--preset", "ours"], ["--preset", "paper"],
                                   ["--preset", "authors", "--task", "soft"],
                                   ["--preset", "authors", "--task", "soft_rigid"]])
def test_layouts_where_nothing_reads_them_are_refused(tmp_path, capsys, flags):
    _layout(tmp_path)
    out = tmp_path / "out"
    err = usage_error(capsys, table1.main, [*flags, "--layouts", tmp_path, "--out", out])
    assert "argument --layouts: only --preset authors on --task clutter" in err
    assert not out.exists()


def test_a_senseless_layout_is_refused_before_any_trial(tmp_path, capsys):
    layouts = tmp_path / "layouts"
    layouts.mkdir()
    _layout(layouts, name="0.csv")
    _layout(layouts, goal=CYLINDER_XY, name="1.csv")            # the goal on its cylinder
    out = tmp_path / "out"
    err = usage_error(capsys, table1.main, ["--preset", "authors", "--layouts", layouts,
                                            "--trials", "2", "--out", out])
    assert f"argument --layouts: {layouts / '1.csv'}: the goal" in err
    assert "on the goal cylinder" in err and not out.exists()
    err = usage_error(capsys, table1.main, ["--preset", "authors", "--layouts", layouts,
                                            "--trials", "3", "--seed", "1", "--out", out])
    assert "on the goal cylinder" in err                         # the first bad one
    err = usage_error(capsys, table1.main, ["--preset", "authors", "--layouts", layouts,
                                            "--seed", "2", "--trials", "1", "--out", out])
    assert f"argument --layouts: no {layouts / '2.csv'}" in err


def test_quick_keeps_an_explicit_trial_count(tmp_path):
    out = str(tmp_path / "o")
    assert table1.parse_args(["--quick", "--trials", "3", "--out", out]).trials == 3
    assert table1.parse_args(["--quick", "--out", out]).trials == 1
    assert table1.parse_args(["--out", out]).trials == flags.DEFAULT_TRIALS


@pytest.mark.parametrize("name", ["summary.json", "table1.md"])
def test_an_output_file_that_is_a_folder_is_refused_before_any_trial(tmp_path, capsys, name):
    out = tmp_path / "out"
    (out / name).mkdir(parents=True)
    err = usage_error(capsys, table1.main, ["--quick", "--out", out])
    assert f"argument --out: the run writes {name} there, but {out.absolute() / name} is a " \
           f"folder" in err
    assert not (out / "trials").exists()
