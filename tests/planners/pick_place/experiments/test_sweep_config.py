"""--config on the size sweeps (fig7_scaling.py, fig7_encoding.py): a settings file changes
the settings every size starts from, between the preset and the flags; a run's summary.json
gives its trials back (the same keys); a setting the sweep's own flags give (n by --sizes,
n_points by --points) or another goal is one usage line naming --config."""
from __future__ import annotations

import json

import pytest

from planners.pick_place.experiments import encoding, scaling
from planners.pick_place.scaling import scaling_trials


def _scaling(tmp_path, *argv):
    args = scaling.parse(["--goal", "side", "--sizes", "5,6", "--trials", "1", "--quick",
                          *argv, "--out", str(tmp_path / "o")])
    trials = scaling_trials(args.goal, args.sizes, [0], args.methods, 1, args.move, args.mode,
                            args.quick, args.base)
    return args, trials


def test_scaling_config_sits_between_the_preset_and_the_move_flag(tmp_path):
    toml = tmp_path / "s.toml"
    toml.write_text('picker_move = "sized"\nbound = 0.05\n[cem]\npopulation = 6\n')
    _, plain = _scaling(tmp_path)
    _, mine = _scaling(tmp_path, "--config", str(toml))
    s0, s = plain[0].params["settings"], mine[0].params["settings"]
    assert (s["bound"], s["cem"]["population"], s["picker_move"]) == (0.05, 6, "sized")
    assert s["n"] == s0["n"] == 5 and s["cem"]["iterations"] == s0["cem"]["iterations"]
    _, flagged = _scaling(tmp_path, "--config", str(toml), "--move", "fixed")
    assert flagged[0].params["settings"].get("picker_move") in (None, "fixed")
    assert {t.key for t in mine}.isdisjoint(t.key for t in plain)


def test_a_scaling_summary_gives_its_trials_back(tmp_path):
    toml = tmp_path / "s.toml"
    toml.write_text("bound = 0.04\n")
    _, trials = _scaling(tmp_path, "--config", str(toml))
    summary = tmp_path / "summary.json"
    by_size = {}
    for t in trials:
        by_size[str(t.params["settings"]["n"])] = t.params["settings"]
    summary.write_text(json.dumps({"experiment": "fig7_scaling", "settings": by_size,
                                   "provenance": {"command": "python x.py"}}))
    _, again = _scaling(tmp_path, "--config", str(summary))
    assert [t.key for t in again] == [t.key for t in trials]


def test_encoding_config_sits_between_quick_and_the_flags(tmp_path):
    toml = tmp_path / "d.toml"
    toml.write_text("population = 5\nhorizon = 4\nbest_over_trajectory = false\n")
    out = ["--goal", "side", "--quick", "--out", str(tmp_path / "o")]
    quick = encoding.parse(out).drag
    d = encoding.parse([*out, "--config", str(toml)]).drag
    assert (d.population, d.horizon, d.best_over_trajectory) == (5, 4, False)
    assert d.iterations == quick.iterations == encoding.QUICK_DRAG["iterations"]
    d = encoding.parse([*out, "--config", str(toml), "--population", "7", "--cost", "best"]).drag
    assert (d.population, d.horizon, d.best_over_trajectory) == (7, 4, True)
    summary = tmp_path / "summary.json"
    summary.write_text(json.dumps({"settings": {"4": {"n": 20, "drag": {**vars(d), "n_points": 4}},
                                                "9": {"n": 20, "drag": {**vars(d), "n_points": 9}}},
                                   "provenance": {}}))
    assert encoding.parse([*out, "--config", str(summary)]).drag == d


@pytest.mark.parametrize("main, argv, text, message", [
    (scaling.main, ["--goal", "side"], "n = 12\n", "n is set by --sizes"),
    (scaling.main, ["--goal", "side"], 'goal = "diagonal"\n', "another goal"),
    (scaling.main, ["--goal", "side"], "bound = -1.0\n", "setting 'bound' must be > 0"),
    (encoding.main, ["--goal", "side"], "n_points = 16\n", "n_points is --points'"),
    (encoding.main, ["--goal", "side"], "populaton = 16\n", "unknown setting 'populaton'"),
])
def test_a_bad_sweep_config_is_one_usage_line(tmp_path, capsys, main, argv, text, message):
    config = tmp_path / "s.toml"
    config.write_text(text)
    with pytest.raises(SystemExit) as exc:
        main([*argv, "--config", str(config), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and len(err.strip().splitlines()) == 1, err
    assert "argument --config" in err and message in err, err
    assert not (tmp_path / "o").exists()
