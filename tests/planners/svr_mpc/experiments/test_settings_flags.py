"""The SVR experiments' settings flags, derived from ``SVRMPCSettings`` (``mapping.SETTINGS``):
every derived flag sets its field in the trials' params (a property over values generated
here from the fields' meaning: a fraction of the control range, a positive duration, the
registered names), on/off switches as recorded commands spell them, --config between the
preset and the flags (a TOML file naming settings flat or nested, and a run's summary.json
giving back its trials), a bad settings file as one usage line, and each flag's help naming
its default under each preset where the presets differ."""
from __future__ import annotations

import argparse
import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dopt.mpc import EXECUTORS, MAX_CONTROL_NOISE
from dopt.tasks import PUSH_TASKS
from dopt.tasks.push.costs import COST_PRESETS
from planners.svr_mpc import SVR_CLOCKS
from planners.svr_mpc.experiments import fig4, mapping, table1
from planners.svr_mpc.presets import AUTHORS, PAPER
from planners.svr_mpc.settings import RECORD_PATHS

positive = st.floats(1e-3, 1e4, allow_nan=False)
switch = st.booleans()
#: a valid value of each derived field (by its flat name), from what the field means
VALUES = {
    "cost": st.sampled_from(sorted(COST_PRESETS)),
    "warm_start": switch,
    "control_noise": st.floats(0.0, MAX_CONTROL_NOISE),
    "clock": st.sampled_from(SVR_CLOCKS),
    "clock_ms": positive,
    "executor": st.sampled_from(EXECUTORS),
    "nominal_threads": positive,
    "slowdown": positive,
    "timeout": st.integers(1, 10 ** 5),
    "islands": switch,
    "push_tail": switch,
}
#: the derived flags by the flat name of their field (a group's field: its own name)
FLAGS = {f.path.rsplit(".", 1)[-1]: f for f in mapping.SETTINGS.flags}


def test_every_derived_flag_has_a_generator_and_its_fields_name():
    assert set(VALUES) == set(FLAGS)
    assert [f.path for f in mapping.SETTINGS.flags] == list(mapping.SETTINGS_FIELDS)
    for name, f in FLAGS.items():                  # the flat name, the field's path and flag
        assert f.flag == "--" + name.replace("_", "-") and RECORD_PATHS[name] == f.path


def _words(flag, value, spelling: int) -> list[str]:
    if flag.kind is bool:
        name = flag.flag[2:]
        return [[f"--{name}" if value else f"--no-{name}"],
                [f"--{name}", "on" if value else "off"]][spelling]
    return [f"{flag.flag}={value!r}" if isinstance(value, float) else f"{flag.flag}={value}"]


def _trials(tmp_path, *argv):
    args = table1.parse_args([*argv, "--rows", "baseline,sum-t10-r1", "--trials", "1",
                              "--out", str(tmp_path / "o")])
    return args, mapping.make_trials(args)


@settings(max_examples=120, deadline=None)
@given(st.sampled_from(sorted(VALUES)).flatmap(
    lambda path: st.tuples(st.just(path), VALUES[path], st.integers(0, 1))))
def test_a_derived_flag_sets_its_field_in_every_trial(tmp_path_factory, case):
    path, value, spelling = case
    tmp = tmp_path_factory.mktemp("flag")
    _, trials = _trials(tmp, *_words(FLAGS[path], value, spelling))
    assert trials and all(t.params[path] == value for t in trials)
    if path == "clock_ms":                          # the flag sets the model clock
        assert all(t.params["clock"] == "model" for t in trials)


def test_the_derived_flags_refuse_what_the_settings_refuse(tmp_path, capsys):
    for argv, message in ((["--control-noise", "1.5"], "argument --control-noise: must be <= 1"),
                          (["--timeout", "0"], "argument --timeout: must be >= 1, got 0"),
                          (["--clock", "wall"], "argument --clock: invalid choice: 'wall'"),
                          (["--islands", "maybe"], "argument --islands: 'maybe' is not on or"),
                          (["--no-islands", "off"], "unrecognized arguments: off")):
        with pytest.raises(SystemExit) as exc:
            _trials(tmp_path, *argv)
        err = capsys.readouterr().err
        assert exc.value.code == 2 and message in err, err
    assert not (tmp_path / "o").exists()


def test_config_sits_between_the_preset_and_the_flags(tmp_path):
    toml = tmp_path / "s.toml"
    toml.write_text('control_noise = 0.02\ntimeout = 50\nfd_skip = 5\nkeypoints = "skip"\n'
                    'push_tail = false\n')
    _, paper = _trials(tmp_path, "--preset", "paper")
    _, mine = _trials(tmp_path, "--preset", "paper", "--config", str(toml))
    p, q = paper[0].params, mine[0].params
    assert (q["control_noise"], q["timeout"], q["fd_skip"], q["push_tail"]) == (0.02, 50, 5, False)
    assert p["control_noise"] == 0.05 and (q["cost"], q["clock"]) == (p["cost"], p["clock"])
    _, flagged = _trials(tmp_path, "--preset", "paper", "--config", str(toml),
                         "--control-noise", "0.1", "--fd-skip", "2", "--push-tail", "on")
    r = flagged[0].params
    assert (r["control_noise"], r["timeout"], r["fd_skip"], r["push_tail"]) == (0.1, 50, 2, True)
    nested = tmp_path / "n.toml"                   # the same settings by their nested paths
    nested.write_text('start.push_tail = false\n[execution]\ncontrol_noise = 0.02\n'
                      'timeout = 50\n[derivatives]\nkeypoints = "skip"\nfd_skip = 5\n')
    _, same = _trials(tmp_path, "--preset", "paper", "--config", str(nested))
    assert [t.params for t in same] == [t.params for t in mine]
    js = tmp_path / "s.json"
    js.write_text(json.dumps({"task": "soft", "clock": "model"}))
    args, trials = _trials(tmp_path, "--config", str(js))
    assert args.task == "soft" and trials[0].params["task"] == "soft"
    args, _ = _trials(tmp_path, "--config", str(js), "--task", "soft_rigid")
    assert args.task == "soft_rigid"


def test_a_summary_as_config_gives_its_trials_again(tmp_path):
    """The protocol a summary records is a settings file that makes the same trial keys,
    without the preset; a fig4 summary's per-row settings give the fields common to them."""
    args, trials = _trials(tmp_path, "--preset", "paper", "--task", "soft", "--timeout", "80",
                           "--fd", "central", "--clock-ms", "90")
    summary = tmp_path / "summary.json"
    summary.write_text(json.dumps({"experiment": "table1", "task": args.task,
                                   **mapping.protocol(args, trials[0].params),
                                   "provenance": {"command": "python experiments/mpc.py"}}))
    again, same = _trials(tmp_path, "--config", str(summary))
    assert again.task == "soft" and [t.key for t in same] == [t.key for t in trials]
    rows = {"baseline": trials[0].params, "sum": trials[1].params}
    summary.write_text(json.dumps({"experiment": "fig4", "settings": rows,
                                   "provenance": {"command": "python experiments/rho_sweep.py"}}))
    _, same = _trials(tmp_path, "--config", str(summary))
    assert [t.key for t in same] == [t.key for t in trials]


@pytest.mark.parametrize("text, message", [
    ('clocks = "model"\n', "unknown setting 'clocks' of SVRMPCSettings"),
    ('control_noise = "a lot"\n', "setting 'control_noise' must be float"),
    ('control_noise = 3\n', "setting 'control_noise' must be <= 1"),
    ('method = "svr-svd"\n', "setting 'method' is this run's own (--rows/--rules)"),
    ('threads = 3\n', "setting 'threads' is this run's own (--threads)"),
    ('task = "sand"\n', "unknown task 'sand'"),
    ('clock_ms = 50\nclock = "real"\n', "clock_ms sets the model clock's duration"),
    ('clock = "model"\n[timing]\nclock = "virtual"\n', "'timing.clock', given twice"),
    ('[timing]\nclocks = "model"\n', "unknown setting 'timing.clocks' of SVRMPCSettings"),
    ('fd_centered = "yes"\n', "setting 'fd_centered' must be one of"),
    ('timeout = \n', "s.toml: "),
])
def test_a_bad_config_is_one_usage_line_naming_it(tmp_path, capsys, text, message):
    config = tmp_path / "s.toml"
    config.write_text(text)
    with pytest.raises(SystemExit) as exc:
        fig4.main(["--config", str(config), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and len(err.strip().splitlines()) == 1, err
    assert "argument --config" in err and message in err, err
    assert not (tmp_path / "o").exists()


def _shown(value) -> str:
    return ("on" if value else "off") if isinstance(value, bool) else f"{value:g}" \
        if isinstance(value, float) else str(value)


@pytest.mark.parametrize("parser", [table1.parser, fig4.parser])
def test_a_flags_help_gives_each_presets_default_where_they_differ(parser):
    helps = {a.dest: a.help for a in parser()._actions if a.help != argparse.SUPPRESS}
    for path, flag in FLAGS.items():
        text = helps[flag.dest]
        presets = [name for name, table in (("paper", PAPER), ("authors", AUTHORS))
                   if path in table]
        for name in presets:
            setting = (AUTHORS if name == "authors" and path in AUTHORS else PAPER)[path]
            part = text.split(f"--preset {name}: ")[1].split("; --preset")[0]
            for task in PUSH_TASKS:                 # each task's value, named where it differs
                assert _shown(setting.on(task)) in part, (path, name, task, text)
        if not presets and path in ("islands", "push_tail", "nominal_threads"):
            assert "--preset" not in text and "(default " in text, (path, text)
