"""--fold-start of cloth_fold.py: the protocol's start by default (paper: prepared; ours:
chained), either by name, a usage error otherwise; rope.py has no such flag."""

import pytest

from planners.pick_place.experiments import fig7


def _parse(*flags, task="cloth"):
    ap = fig7.parser(task)
    return fig7.parse(ap, task, [*flags, "--out", "results/x"])[1]


def test_fold_start_defaults_to_the_protocols_and_takes_either_start():
    assert _parse("--goal", "reflective", "--preset", "paper").fold_start == "prepared"
    assert _parse("--goal", "underneath").fold_start is None
    assert _parse("--goal", "reflective", "--preset", "paper",
                  "--fold-start", "chained").fold_start is None
    assert _parse("--goal", "underneath", "--fold-start", "prepared").fold_start == "prepared"
    assert _parse("--goal", "diagonal", "--fold-start", "prepared").fold_start is None


def test_fold_start_rejects_other_values_and_is_not_a_rope_flag(capsys):
    with pytest.raises(SystemExit):
        _parse("--goal", "reflective", "--fold-start", "teleported")
    assert "--fold-start" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        _parse("--fold-start", "prepared", task="rope")
