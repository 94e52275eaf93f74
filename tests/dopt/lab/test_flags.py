"""dopt.lab.flags: flags derived from a settings dataclass round-trip every field (a property
over generated values, the generators written here from the annotations' meaning, not the
library's parsers), --config sits between the preset and the flags, a bad settings file is a
one-line usage error naming the key, and hidden old spellings still parse, as recorded
commands use them."""
from __future__ import annotations

import dataclasses
import json
import shlex
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dopt.lab.cli import ArgumentParser
from dopt.lab.flags import (
    SettingsFlags,
    apply,
    default_text,
    derive,
    field_docs,
    field_paths,
    read_config,
)
from planners.cem import CEMConfig
from planners.pick_place import PickPlaceSettings
from planners.pick_place.drag_settings import DragSettings
from planners.pick_place.experiments import fig7

ROOT = Path(__file__).resolve().parents[3]
FLAGS = derive(PickPlaceSettings)


def test_every_leaf_field_has_a_flag_with_its_documentation():
    """Every field of the settings (nested ones too) gets a flag, documented from its class's
    Attributes section; a leaf name shared by two fields (cem.population, drag.population)
    is spelled with its whole path."""
    leaves = [f"{f.name}" for f in dataclasses.fields(PickPlaceSettings)]
    assert {f.path.split(".")[0] for f in FLAGS} == set(leaves)
    assert [f.path for f in FLAGS] == field_paths(PickPlaceSettings)
    assert all(f.doc for f in FLAGS), [f.path for f in FLAGS if not f.doc]
    by = {f.path: f for f in FLAGS}
    assert by["cem.population"].flag == "--cem-population"
    assert by["drag.population"].flag == "--drag-population"
    assert by["bound"].flag == "--bound" and by["max_stretch"].flag == "--max-stretch"
    assert by["fold_start"].choices == ("chained", "prepared") and by["fold_start"].optional
    assert by["n"].low == 3 and not by["n"].strict and by["bound"].strict
    assert field_docs(CEMConfig)["horizon"].startswith("H, actions per sequence")
    assert field_docs(DragSettings)["iterations"].startswith("CEM iterations")


def _value(flag):
    """A strategy of valid values of a flag's field, from its kind, bound and choices."""
    if flag.kind is bool:
        return st.booleans()
    if flag.choices is not None:
        return st.sampled_from(flag.choices)
    if flag.kind is str:
        return st.text(st.characters(whitelist_categories=("Ll", "Lu", "Nd")), min_size=1,
                       max_size=12)
    low = -1e6 if flag.low is None else flag.low
    if flag.kind is int:
        return st.integers(int(low) + flag.strict, 10 ** 6)
    return st.floats(low, 1e6, exclude_min=flag.strict, allow_nan=False)


@st.composite
def flag_and_value(draw):
    flag = draw(st.sampled_from(FLAGS))
    return flag, draw(_value(flag))


def _text(flag, value) -> list[str]:
    if flag.kind is bool:
        return [flag.flag if value else f"--no-{flag.flag[2:]}"]
    # FLAG=VALUE: argparse takes "-8e-78" after a space for an option
    return [f"{flag.flag}={repr(value) if flag.kind is float else value}"]


@settings(max_examples=300, deadline=None)
@given(flag_and_value())
def test_a_derived_flag_round_trips_to_its_field(case):
    flag, value = case
    flags = SettingsFlags(PickPlaceSettings, field_paths(PickPlaceSettings))
    ap = ArgumentParser(prog="t.py")
    flags.add_to(ap)
    args = ap.parse_args(_text(flag, value))
    assert flags.overrides(args) == {flag.path: value}
    base = PickPlaceSettings.preset("cloth", "diagonal")
    try:
        changed = apply(base, flags.overrides(args))
    except (TypeError, ValueError):         # a value the settings refuse together with others
        return
    got = changed
    for part in flag.path.split("."):
        got = getattr(got, part)
    if flag.path in ("picker_move", "fold_start") and value in ("fixed", "chained", "prepared"):
        assert got in (value, None)             # stored as None: the default's own name
    else:
        assert got == value


def _parse(tmp_path, *argv, task="rope"):
    return fig7.parse(fig7.parser(task), task, [*argv, "--out", str(tmp_path / "o")])


def test_config_sits_between_the_preset_and_the_flags(tmp_path):
    toml = tmp_path / "s.toml"
    toml.write_text('bound = 0.05\nphysics = "fast"\n[cem]\npopulation = 12\nelites = 3\n')
    _, preset = _parse(tmp_path)
    _, s = _parse(tmp_path, "--config", str(toml))
    assert (s.bound, s.physics, s.cem.population, s.cem.elites) == (0.05, "fast", 12, 3)
    assert s.cem.iterations == preset.cem.iterations and s.n == preset.n
    _, s = _parse(tmp_path, "--config", str(toml), "--population", "20", "--bound", "0.07")
    assert (s.bound, s.physics, s.cem.population, s.cem.elites) == (0.07, "fast", 20, 3)
    js = tmp_path / "s.json"
    js.write_text(json.dumps({"cem.horizon": 4, "goal": "fold"}))
    args, s = _parse(tmp_path, "--config", str(js))
    assert (args.goal, s.goal, s.cem.horizon) == ("fold", "fold", 4)
    args, s = _parse(tmp_path, "--config", str(js), "--goal", "straighten")
    assert (args.goal, s.goal) == ("straighten", "straighten")


def test_a_runs_summary_is_a_config_that_gives_its_settings_again(tmp_path):
    _, s = _parse(tmp_path, "--quick", "--population", "9", "--max-stretch", "0.3")
    summary = tmp_path / "summary.json"
    summary.write_text(json.dumps({"experiment": "fig7", "settings": s.to_dict(),
                                   "provenance": {"command": "python experiments/rope.py"}}))
    _, again = _parse(tmp_path, "--config", str(summary))
    assert again == s
    _, more = _parse(tmp_path, "--config", str(summary), "--elites", "2")
    assert more == dataclasses.replace(s, cem=dataclasses.replace(s.cem, elites=2))


@pytest.mark.parametrize("text, message", [
    ('bounds = 0.1\n', "unknown setting 'bounds'"),
    ('[cem]\npopulatoin = 3\n', "unknown setting 'cem.populatoin'"),
    ('n = "ten"\n', "setting 'n' must be int, got 'ten'"),
    ('n = 2.5\n', "setting 'n' must be int, got 2.5"),
    ('n = 2\n', "setting 'n' must be >= 3, got 2"),
    ('bound = 0\n', "setting 'bound' must be > 0, got 0"),
    ('physics = "slow"\n', "setting 'physics' must be one of"),
    ('selfcollide = 1\n', "setting 'selfcollide' must be bool, got 1"),
    ('goal = "spiral"\n', "unknown rope goal 'spiral'"),
    ('task = "cloth"\n', "holds settings of another task"),
    ('n = \n', "s.toml: "),
])
def test_a_bad_config_is_one_line_naming_the_key(tmp_path, capsys, text, message):
    config = tmp_path / "s.toml"
    config.write_text(text)
    with pytest.raises(SystemExit) as exc:
        _parse(tmp_path, "--config", str(config))
    err = capsys.readouterr().err
    assert exc.value.code == 2 and len(err.strip().splitlines()) == 1, err
    assert "argument --config" in err and message in err, err
    assert not (tmp_path / "o").exists()


def test_read_config_refuses_what_is_not_a_table(tmp_path):
    path = tmp_path / "s.json"
    path.write_text("[1, 2]")
    with pytest.raises(ValueError, match="a table of settings"):
        read_config(path, PickPlaceSettings)
    with pytest.raises(ValueError, match="no such file|No such file"):
        read_config(tmp_path / "none.json", PickPlaceSettings)


@dataclasses.dataclass(frozen=True)
class _Clock:
    """A group.

    Attributes:
        clock: the clock's name.
        ms: a fixed duration.
    """

    clock: str = "real"
    ms: float | None = None


@dataclasses.dataclass(frozen=True)
class _Nested:
    """Settings with a group whose fields a record names flat.

    Attributes:
        timing: the clock.
        threads: simulation threads.
    """

    timing: _Clock = _Clock()
    threads: int = 0


def test_a_settings_file_may_name_a_nested_field_by_its_flat_name(tmp_path):
    """``record=``: a file names a group's field by its path or its flat name (a trial's
    params' spelling); the same field twice, or a bad value, is refused naming the key as
    the file wrote it; without the hook a flat name is unknown."""
    flat = {"clock": "timing.clock", "ms": "timing.ms"}

    def record(key, value):
        return flat.get(key, key), value

    path = tmp_path / "s.toml"
    path.write_text('clock = "model"\nthreads = 2\n[timing]\nms = 5.0\n')
    values = read_config(path, _Nested, record=record)
    assert values == {"timing.clock": "model", "threads": 2, "timing.ms": 5.0}
    assert apply(_Nested(), values) == _Nested(_Clock("model", 5.0), 2)
    for text, message in (('clock = "model"\n[timing]\nclock = "real"\n',
                           "setting 'timing.clock' is 'timing.clock', given twice"),
                          ('ms = "long"\n', "setting 'ms' must be float"),
                          ('clocks = "model"\n', "unknown setting 'clocks' of _Nested")):
        path.write_text(text)
        with pytest.raises(ValueError, match=message):
            read_config(path, _Nested, record=record)
    path.write_text('clock = "model"\n')
    with pytest.raises(ValueError, match="unknown setting 'clock' of _Nested"):
        read_config(path, _Nested)


def _recorded_fig7_commands() -> list[tuple[str, list[str]]]:
    out = []
    for path in sorted((ROOT / "docs" / "results").glob("fig7-cloth-*.json")):
        words = shlex.split(json.loads(path.read_text())["provenance"]["command"])
        if words[:2] == ["python", "experiments/cloth_fold.py"]:
            out.append((path.name, words[2:]))
    return out


@pytest.mark.parametrize("name, argv", _recorded_fig7_commands(),
                         ids=[n for n, _ in _recorded_fig7_commands()])
def test_recorded_commands_with_old_spellings_still_parse(name, argv, tmp_path, capsys):
    """A committed Fig. 7 command (its --seeds now a hidden alias of --trials) parses to the
    trials and the departures from the protocol it recorded."""
    summary = json.loads((ROOT / "docs" / "results" / name).read_text())
    argv = [a for a in argv]
    for flag in ("--out", "--record"):
        if flag in argv:
            i = argv.index(flag)
            del argv[i:i + 2]
    args, s = fig7.parse(fig7.parser("cloth"), "cloth", [*argv, "--out", str(tmp_path / "o")])
    if "--seeds" in argv:
        assert args.trials == int(argv[argv.index("--seeds") + 1])
        assert "--seeds is now --trials" in capsys.readouterr().err
    assert args.goal == summary["goal"]
    if "departures" in summary:
        assert s.departures(args.preset, args.quick) == summary["departures"]


def test_recorded_commands_exist():
    assert _recorded_fig7_commands(), "no recorded cloth_fold.py command under docs/results"
    assert any("--seeds" in argv for _, argv in _recorded_fig7_commands())


def test_default_text_names_each_presets_value_and_the_cases_that_differ():
    same = {"ours": {"a": 1, "b": 1}, "paper": {"a": 1, "b": 1}}
    assert default_text(same) == "1"
    differ = {"ours": {"a": 32, "b": 32, "c": 16}, "paper": {"a": 8, "b": 8, "c": 8}}
    assert default_text(differ) == "--preset ours: 32; 16 c; --preset paper: 8"
    assert default_text({"ours": {"a": None}, "paper": {"a": 2}}) is None
    assert default_text({"p": {"a": True}}, lambda v: "on" if v else "off") == "on"


def test_a_switch_takes_on_off_and_its_no_spelling():
    @dataclasses.dataclass(frozen=True)
    class S:
        """Attributes:
            tail: keep the tail.
        """

        tail: bool = True

    flags = SettingsFlags(S, ["tail"])
    ap = ArgumentParser(prog="t.py")
    flags.add_to(ap, config=False)
    for argv, value in ((["--tail"], True), (["--tail", "off"], False), (["--tail", "ON"], True),
                        (["--no-tail"], False), ([], None)):
        assert ap.parse_args(argv).tail is value, argv
    assert "--no-tail" not in ap.format_usage() and "--no-tail: off" in ap.format_help()
    with pytest.raises(SystemExit):
        ap.parse_args(["--tail", "maybe"])
