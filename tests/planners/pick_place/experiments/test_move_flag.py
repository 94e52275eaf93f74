"""--move of the pick-and-place scripts (cloth_fold.py, rope.py, fig7_scaling.py): "sized"
sets ``PickPlaceSettings.picker_move`` and gives the trials other keys; the default and
"fixed" keep the keys of the trials run before the flag existed; with --rest-speed it is a
usage error. The threads per trial share the cores out over the trials that run at once."""

from dataclasses import replace

import pytest

from dopt.rollout import share_cores
from planners.pick_place import PickPlaceSettings, trial_key
from planners.pick_place.experiments import fig7
from planners.pick_place.scaling import scaling_trials


def _parse(*flags):
    ap = fig7.parser("cloth")
    return fig7.parse(ap, "cloth", [*flags, "--out", "results/x"])


def test_move_sized_is_a_setting_with_its_own_key_and_fixed_is_the_default():
    _, default = _parse("--quick")
    _, fixed = _parse("--quick", "--move", "fixed")
    _, sized = _parse("--quick", "--move", "sized")
    assert default.picker_move is None and fixed.picker_move is None
    assert sized.picker_move == "sized" and sized.picker().move == "sized"
    assert default.picker().move == "fixed"
    key = trial_key("simple", 0, default)
    assert trial_key("simple", 0, fixed) == key
    assert trial_key("simple", 0, replace(default, picker_move="fixed")) == key
    assert trial_key("simple", 0, sized) != key
    assert "move" not in default.identity()["resolved"]["picker"]
    assert sized.identity()["resolved"]["picker"]["move"] == "sized"
    assert sized.departures(quick=True) == {"picker_move": "sized"}
    assert PickPlaceSettings.from_dict(sized.to_dict()) == sized


def test_move_sized_with_a_rest_speed_is_a_usage_error(capsys):
    with pytest.raises(SystemExit):
        _parse("--move", "sized", "--rest-speed", "0.01")
    assert "picker_move" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        _parse("--move", "slow")
    with pytest.raises(ValueError, match="PickPlaceSettings.picker_move"):
        replace(PickPlaceSettings.preset("cloth", "diagonal"), picker_move="slow")


def test_threads_share_the_cores_over_the_trials_at_once():
    args, s = _parse("--quick")
    assert s.threads == share_cores(1) == 0                  # one trial: every core
    _, s = _parse("--seeds", "3", "--workers", "2")
    assert s.threads == share_cores(2)
    _, s = _parse("--seeds", "3", "--workers", "2", "--threads", "3")
    assert s.threads == 3


def test_the_scaling_trials_take_the_move():
    fixed = scaling_trials("diagonal", [10], [0], ["simple"])
    sized = scaling_trials("diagonal", [10], [0], ["simple"], move="sized")
    assert fixed[0].key != sized[0].key
    assert sized[0].params["settings"]["picker_move"] == "sized"
    assert "picker_move" not in fixed[0].params["settings"]      # as before the flag
