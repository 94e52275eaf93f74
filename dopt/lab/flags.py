"""Command-line flags derived from a settings dataclass, and settings files (``--config``).

A field of a settings dataclass (nested dataclasses too: "cem.population") becomes a flag:
its name is the field's with dashes (the leaf's, ``--population``, unless two chosen fields
share a leaf: then the whole path, ``--cem-population``), its type and choices come from the
annotation (``int``, ``float``, ``str``, ``bool``, ``X | None``, ``Literal[...]``) and the
field's metadata, its help text from the field's documentation: the ``Attributes:`` section
of its class docstring, the one place a setting is described (``field_docs``). So the help
cannot drift from the settings. Field metadata the flags read (``dopt.validation.check_config``
checks the same keys, so a bound is written once):

- ``"choices"``: the allowed values of a ``str`` field (None aside);
- ``"at_least"`` / ``"above"``: the inclusive / exclusive lower bound of a number;
- ``"at_most"``: the inclusive upper bound of a number.

A ``bool`` field's flag is a switch: ``--x`` / ``--no-x``, or ``--x on`` / ``--x off`` (the
spelling of recorded commands: ``--push-tail off``).

``--config FILE`` (TOML or JSON; a run's ``summary.json`` gives its ``"settings"``: with one
settings table per row or size, the values common to them all; ``summary=`` reads another
layout) maps settings field names (nested as tables / objects, or dotted keys) to values
(``record=`` lets a file name a nested field by another name too: the flat name a trial's
params record it under); an unknown key or a value of the wrong type is a one-line usage
error naming it. A run resolves
its settings as preset < config < flags (``SettingsFlags.resolve``). Standard library and
``dopt.lab.cli`` only.
"""
from __future__ import annotations

import argparse
import dataclasses
import functools
import json
import math
import sys
import types
import typing
from collections.abc import Callable, Iterable
from pathlib import Path

from dopt.lab.cli import shown_name

#: the field metadata keys of a bound (``FieldFlag.low`` / ``strict``)
BOUND_KEYS = ("at_least", "above")


@dataclasses.dataclass(frozen=True)
class FieldFlag:
    """One settings field as a flag.

    Attributes:
        path: the field's dotted path in the settings ("cem.population").
        flag: its option string ("--population").
        kind: ``int``, ``float``, ``str`` or ``bool``.
        optional: whether None is a value of the field (``X | None``).
        choices: the allowed values of a ``str`` field, or None (any).
        low: a number's lower bound, or None; strict: whether ``low`` itself is refused.
        doc: the field's documentation (``field_docs``).
        high: a number's inclusive upper bound, or None.
    """

    path: str
    flag: str
    kind: type
    optional: bool
    choices: tuple | None
    low: float | None
    strict: bool
    doc: str
    high: float | None = None

    @property
    def dest(self) -> str:
        """The argparse destination: the flag without dashes, underscores for dashes."""
        return self.flag.lstrip("-").replace("-", "_")

    def parse(self, text: str):
        """The argparse ``type=``: ``text`` as a value of the field (ArgumentTypeError
        naming what is wrong)."""
        if self.kind is str:
            if self.choices is not None and text not in self.choices:
                raise argparse.ArgumentTypeError(f"invalid choice: {text!r} (choose from "
                                                 f"{', '.join(map(repr, self.choices))})")
            return text
        try:
            value = self.kind(text)
        except ValueError:
            what = "an integer" if self.kind is int else "a number"
            raise argparse.ArgumentTypeError(f"{text!r} is not {what}") from None
        try:
            self.check(value)
        except ValueError as e:
            raise argparse.ArgumentTypeError(f"{e}, got {text}") from None
        return value

    def check(self, value) -> None:
        """ValueError (a phrase: "must be ...") unless the number ``value`` is finite and
        within the bounds."""
        if math.isfinite(value) and self.high is not None and value > self.high:
            raise ValueError(f"must be <= {self.high:g}")
        if not math.isfinite(value) or (self.low is not None and (
                value <= self.low if self.strict else value < self.low)):
            if self.low is None:
                raise ValueError("must be finite")
            least = (f">= {self.low + 1:g}" if self.strict and self.kind is int
                     else f"{'>' if self.strict else '>='} {self.low:g}")
            raise ValueError(f"must be {least}")

    def check_value(self, value, where: str) -> None:
        """TypeError / ValueError naming ``where`` unless ``value`` (from a settings file) is
        a value of the field."""
        if value is None:
            if not self.optional:
                raise TypeError(f"{where} must not be null")
            return
        ok = {bool: lambda v: isinstance(v, bool),
              int: lambda v: isinstance(v, int) and not isinstance(v, bool),
              float: lambda v: isinstance(v, (int, float)) and not isinstance(v, bool),
              str: lambda v: isinstance(v, str)}[self.kind](value)
        if not ok:
            raise TypeError(f"{where} must be {self.kind.__name__}, got {value!r}")
        if self.kind is str and self.choices is not None and value not in self.choices:
            raise ValueError(f"{where} must be one of {list(self.choices)}, got {value!r}")
        if self.kind in (int, float):
            try:
                self.check(value)
            except ValueError as e:
                raise ValueError(f"{where} {e}, got {value!r}") from None


@functools.cache
def field_docs(cls: type) -> dict[str, str]:
    """{field: its documentation} from the ``Attributes:`` section of ``cls``'s docstring
    (Google style: ``name: text`` with indented continuation lines; ``a, b: text`` documents
    both), whitespace joined to one line."""
    lines = (cls.__doc__ or "").expandtabs().splitlines()
    docs: dict[str, list[str]] = {}
    inside, indent, names = False, None, []
    for line in lines:
        text = line.strip()
        if text == "Attributes:":
            inside, indent = True, None
            continue
        if not inside:
            continue
        if not text:
            continue
        width = len(line) - len(line.lstrip())
        if indent is None:
            indent = width
        if width < indent:                           # the section ended
            break
        head, sep, rest = text.partition(":")
        if width == indent and sep:
            names = [n.strip() for n in head.split(",")]
            for n in names:
                docs[n] = [rest.strip()]
        else:
            for n in names:
                docs[n].append(text)
    return {n: " ".join(" ".join(parts).split()) for n, parts in docs.items()}


def _unwrap(hint) -> tuple[object, bool]:
    """(the type, optional) of an annotation ``X`` or ``X | None``."""
    if typing.get_origin(hint) in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(hint) if a is not type(None)]
        if len(args) == 1:
            return args[0], len(args) < len(typing.get_args(hint))
    return hint, False


def _leaves(cls: type, prefix: str = "") -> Iterable[tuple[str, dataclasses.Field, object,
                                                            bool, type]]:
    """(path, field, type, optional, owner class) of every leaf field of the dataclass
    ``cls``, nested dataclasses walked."""
    hints = typing.get_type_hints(cls)
    for f in dataclasses.fields(cls):
        kind, optional = _unwrap(hints[f.name])
        if dataclasses.is_dataclass(kind):
            yield from _leaves(kind, f"{prefix}{f.name}.")
        else:
            yield f"{prefix}{f.name}", f, kind, optional, cls


def field_paths(cls: type) -> list[str]:
    """The dotted path of every leaf field of the settings dataclass ``cls``."""
    return [path for path, *_ in _leaves(cls)]


def derive(cls: type, paths: Iterable[str] | None = None,
           names: dict[str, str] | None = None) -> list[FieldFlag]:
    """The flags of the fields ``paths`` of ``cls`` (default: every leaf field), in that
    order; ``names`` gives a path another option string (the vocabulary's), which the
    field's own name then stays as a hidden alias of (``SettingsFlags``).

    Raises:
        ValueError: a path that is no leaf field of ``cls``.
        TypeError: a field whose annotation no flag can take (a tuple, a dict).
    """
    leaves = {path: rest for path, *rest in _leaves(cls)}
    paths = list(leaves) if paths is None else list(paths)
    unknown = [p for p in paths if p not in leaves]
    if unknown:
        raise ValueError(f"{cls.__name__} has no field {unknown}; its fields: "
                         f"{', '.join(leaves)}")
    tails = [p.rsplit(".", 1)[-1] for p in paths]
    flags = []
    for path, tail in zip(paths, tails, strict=True):
        f, kind, optional, owner = leaves[path]
        args = typing.get_args(kind)
        choices = f.metadata.get("choices")
        if typing.get_origin(kind) is typing.Literal:
            kind, choices = str, args
        if kind not in (int, float, str, bool):
            raise TypeError(f"{cls.__name__}.{path}: no flag takes a {kind!r}")
        bound = next(((f.metadata[k], k == "above") for k in BOUND_KEYS if k in f.metadata),
                     (None, False))
        name = tail if tails.count(tail) == 1 else path.replace(".", "-")
        flags.append(FieldFlag(path, f"--{name.replace('_', '-')}", kind, optional,
                               None if choices is None else tuple(choices), bound[0],
                               bound[1], field_docs(owner).get(f.name, ""),
                               f.metadata.get("at_most")))
    return flags


def apply(settings, changes: dict):
    """``settings`` (a frozen dataclass) with ``changes`` ({dotted path: value}) made, nested
    dataclasses replaced (an unset optional one, None, built from its defaults and the
    changes); the settings' own checks run (TypeError / ValueError)."""
    groups: dict[str, dict] = {}
    own = {}
    for path, value in changes.items():
        head, dot, rest = path.partition(".")
        if dot:
            groups.setdefault(head, {})[rest] = value
        else:
            own[head] = value
    hints = typing.get_type_hints(type(settings))
    for head, sub in groups.items():
        current = getattr(settings, head)
        if current is None:
            current = _unwrap(hints[head])[0]()
        own[head] = apply(current, sub)
    return dataclasses.replace(settings, **own) if own else settings


def _flatten(d: dict, prefix: str = "") -> dict:
    out = {}
    for k, v in d.items():
        if isinstance(v, dict):
            out.update(_flatten(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = v
    return out


def common_settings(tables: dict) -> dict:
    """The settings a summary records once per row or size ({name: settings table}): the
    (dotted) fields whose value is the same in every table, as one flat table."""
    flat = [_flatten(t) for t in tables.values() if isinstance(t, dict)]
    if not flat:
        return {}
    return {k: v for k, v in flat[0].items() if all(k in f and f[k] == v for f in flat[1:])}


def summary_settings(data: dict) -> dict:
    """The settings table of a run's summary.json: its ``"settings"``; where that holds one
    table per row or size (every value a table), the values common to them
    (``common_settings``)."""
    settings = data["settings"]
    if settings and all(isinstance(v, dict) for v in settings.values()):
        return common_settings(settings)
    return settings


def is_summary(data) -> bool:
    """Whether a settings file's content is a run's summary.json (it has "provenance")."""
    return isinstance(data, dict) and "provenance" in data


def read_config(path: Path, cls: type,
                summary: Callable[[dict], dict] | None = None,
                record: Callable[[str, object], tuple[str, object]] | None = None) -> dict:
    """{dotted path: value} of the settings file ``path`` (TOML by its ``.toml`` suffix, else
    JSON; a run's summary.json gives its settings: ``summary(data)``, default
    ``summary_settings``), each key a field of ``cls`` and each value of its type. ``record``:
    (a key, its value) -> (the dotted path, the value) where a file may name a field otherwise
    (a flat name: ``clock`` for ``timing.clock``); a key it does not know comes back as it
    is. Raises ValueError (one line naming the file and the key as the file wrote it, or a
    field given twice) otherwise."""
    import tomllib

    path = Path(path)
    try:
        text = path.read_text()
        data = tomllib.loads(text) if path.suffix == ".toml" else json.loads(text)
    except (OSError, ValueError) as e:
        raise ValueError(f"{path}: {' '.join(str(e).split())}") from None
    if not isinstance(data, dict):
        raise ValueError(f"{path}: a settings file holds a table of settings, not "
                         f"{type(data).__name__}")
    if is_summary(data) and (summary is not None or isinstance(data.get("settings"), dict)):
        try:
            data = (summary or summary_settings)(data)
        except (KeyError, TypeError, ValueError) as e:
            raise ValueError(f"{path}: a summary without the settings of {cls.__name__} "
                             f"({type(e).__name__}: {e})") from None
    flags = {f.path: f for f in derive(cls)}
    nested = {p.split(".", 1)[0] for p in flags if "." in p}
    values: dict = {}
    for key, value in _flatten(data).items():
        if key in nested and value is None:          # an unset optional group (drag: null)
            continue
        field, value = record(key, value) if record is not None else (key, value)
        if field not in flags:
            raise ValueError(f"{path}: unknown setting {key!r} of {cls.__name__} (its "
                             f"settings: {', '.join(flags)})")
        if field in values:
            raise ValueError(f"{path}: setting {key!r} is {field!r}, given twice")
        try:
            flags[field].check_value(value, f"setting {key!r}")
        except (TypeError, ValueError) as e:
            raise ValueError(f"{path}: {e}") from None
        values[field] = value
    return values


#: the words a switch (a ``bool`` field's flag) takes after it
SWITCH_WORDS = {"on": True, "off": False, "true": True, "false": False, "yes": True,
                "no": False}


def switch_word(text: str) -> bool:
    """The argparse ``type=`` of a switch's value: ``on``/``off`` (``SWITCH_WORDS``)."""
    try:
        return SWITCH_WORDS[text.lower()]
    except KeyError:
        raise argparse.ArgumentTypeError(f"{text!r} is not on or off") from None


class _Switch(argparse.Action):
    """A ``bool`` field's flag: ``--x`` (True) or ``--x on|off``; its ``--no-x`` (False) is
    a second action, ``nargs=0``."""

    def __init__(self, option_strings, dest, off: bool = False, **kwargs):
        if off:
            kwargs["nargs"] = 0
        else:
            kwargs.update(nargs="?", type=switch_word)
        super().__init__(option_strings, dest, **kwargs)
        self.off = off

    def __call__(self, parser, namespace, values, option_string=None):
        setattr(namespace, self.dest, False if self.off else values is None or values)


class _Alias(argparse.Action):
    """A hidden old spelling: stores under the new flag's dest, with a note on stderr."""

    def __init__(self, option_strings, dest, new: str = "", store_true: bool = False,
                 **kwargs):
        if store_true:
            kwargs["nargs"] = 0
        super().__init__(option_strings, dest, **kwargs)
        self.new, self.store_true = new, store_true

    def __call__(self, parser, namespace, values, option_string=None):
        print(f"{shown_name(parser.prog)}: note: {option_string} is now {self.new}",
              file=sys.stderr)
        setattr(namespace, self.dest, True if self.store_true else values)


def add_alias(ap: argparse.ArgumentParser, old: str, new: str) -> None:
    """``old`` as a hidden spelling of the flag ``new`` (added before): the same dest, type
    and choices, no line in --help, a one-line note on stderr when used, so that a recorded
    command with the old spelling still runs."""
    action = ap._option_string_actions[new]
    ap.add_argument(old, action=_Alias, new=new, dest=action.dest, type=action.type,
                    choices=action.choices,
                    store_true=isinstance(action, argparse._StoreTrueAction),
                    default=argparse.SUPPRESS, help=argparse.SUPPRESS)


def default_text(values: dict[str, dict[str, object]],
                 show: Callable[[object], str] = str) -> str | None:
    """The default of a settings field in its flag's help, from its value per preset and case
    ({preset: {case (a goal, a task): value}}): "32; 16 reflective, underneath" (the commonest
    value, then the others with their cases), per preset ("--preset paper: ...") where the
    presets differ; None where a preset leaves it unset in every case (the field's
    documentation says what unset means). ``show`` spells a value."""
    texts = {}
    for preset, cases in values.items():
        if all(v is None for v in cases.values()):
            return None
        listed = list(cases.values())
        common = max(listed, key=listed.count)
        rest: dict = {}
        for case, v in cases.items():
            if v != common:
                rest.setdefault(show(v), []).append(case)
        texts[preset] = "; ".join([show(common)] + [f"{v} {', '.join(cs)}"
                                                    for v, cs in rest.items()])
    if len(set(texts.values())) == 1:
        return next(iter(texts.values()))
    return "; ".join(f"--preset {p}: {t}" for p, t in texts.items())


class SettingsFlags:
    """The flags of some fields of a settings dataclass (``derive``), with ``--config``.

    Args:
        cls: the settings dataclass.
        paths: the fields (dotted paths) that get a flag.
        names: {path: option string} where the vocabulary names a field otherwise; the
            field's own name stays a hidden alias.
        defaults: path -> the text of its default ("32; 16 reflective, underneath"), or None
            for none in the help.
        summary: how a run's summary.json gives the settings (``read_config``).
        record: the other names a settings file may give a field by (``read_config``).
    """

    def __init__(self, cls: type, paths: Iterable[str], names: dict[str, str] | None = None,
                 defaults: Callable[[str], str | None] | None = None,
                 summary: Callable[[dict], dict] | None = None,
                 record: Callable[[str, object], tuple[str, object]] | None = None):
        self.cls, self.names, self.summary = cls, dict(names or {}), summary
        self.record = record
        self.flags = [dataclasses.replace(f, flag=self.names.get(f.path, f.flag))
                      for f in derive(cls, paths)]
        self.own = {f.path: f.flag for f in derive(cls, paths)}
        self.defaults = defaults or (lambda path: None)

    def add_to(self, ap: argparse.ArgumentParser, config: bool = True) -> None:
        """Add the flags (each default None: the preset's or the config's value) and, with
        ``config``, ``--config FILE``."""
        for f in self.flags:
            default = self.defaults(f.path)
            text = f.doc.rstrip(".") + (f" (default {default})" if default else "")
            if f.kind is bool:
                ap.add_argument(f.flag, dest=f.dest, action=_Switch, default=None,
                                metavar="on|off", help=f"{text}; --no-{f.flag[2:]}: off")
                ap.add_argument(f"--no-{f.flag[2:]}", dest=f.dest, action=_Switch, off=True,
                                default=argparse.SUPPRESS, help=argparse.SUPPRESS)
                continue
            metavar = None if f.choices is None else "{" + ",".join(f.choices) + "}"
            ap.add_argument(f.flag, dest=f.dest, type=f.parse, default=None, help=text,
                            metavar=metavar or f.dest.upper())
            if self.own[f.path] != f.flag:
                add_alias(ap, self.own[f.path], f.flag)
        if config:
            ap.add_argument("--config", type=Path, default=None, metavar="FILE",
                            help=f"a settings file (TOML or JSON, or a run's summary.json): "
                                 f"{self.cls.__name__} field names and values (nested "
                                 f"settings as tables or dotted names), between the preset "
                                 f"and the flags (preset < config < flags)")

    def overrides(self, args: argparse.Namespace) -> dict:
        """{path: value} of the flags given."""
        return {f.path: getattr(args, f.dest) for f in self.flags
                if getattr(args, f.dest, None) is not None}

    def config(self, ap: argparse.ArgumentParser, args: argparse.Namespace) -> dict:
        """{path: value} of ``--config`` (empty without it); a usage error on a bad file."""
        if getattr(args, "config", None) is None:
            return {}
        try:
            return read_config(args.config, self.cls, self.summary, self.record)
        except ValueError as e:
            ap.error(f"argument --config: {e}")

    def resolve(self, ap: argparse.ArgumentParser, args: argparse.Namespace, preset,
                config: dict | None = None):
        """``preset`` with the config's values (``config``, default ``--config``'s), then the
        flags' over them; a usage error naming the flag (or --config) the settings refuse."""
        config = self.config(ap, args) if config is None else config
        settings = preset
        for what, changes in (("--config", config), (None, self.overrides(args))):
            try:
                settings = apply(settings, changes)
            except (TypeError, ValueError) as e:
                flag = what or next((f.flag for f in self.flags
                                     if f.path in changes and f.path.split(".")[-1] in str(e)),
                                    "/".join(f.flag for f in self.flags if f.path in changes))
                ap.error(f"argument {flag}: {e}")
        return settings
