"""The one trial identity of both papers: a trial's name is its label, its seed and a hash of
the settings that differ from a fixed reference of defaults.

``trial_name(label, seed, values, defaults)`` is ``<label>-seed<seed>-<8 hex>``, the hex the
first eight of the SHA-1 of the canonical JSON of ``changed_settings(values, defaults)``:

- nested dicts are flattened to dotted names ("cem.population"); any other value is a leaf
  (a list is one leaf);
- a leaf is kept when it differs from the default of its name or the defaults lack the name;
  a name the values lack counts as its default (so a setting added later with its default
  value, which older values lack, names the same trial as before it existed);
- leaves are written canonically before they are compared and hashed: numbers by value (1
  and 1.0 are the same; a bool stays a bool, never a number), tuples as lists, dict keys
  sorted.

The defaults must be a fixed reference (the dataclass field defaults of a settings class,
``field_defaults``), never a preset that may change: a preset's change would otherwise hand
an old trial's name to new settings. The names are short and readable; what guards against
two different trials under one name is the sweep's identity check
(``dopt.lab.sweep_store.Schema.identity``), which compares the stored params in full.
Trials written before this rule keep the names they were written under; a sweep finds them
through ``Schema.aliases``.

Standard library only.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import numbers

#: characters a name (a file-name stem) cannot hold
_BAD_CHARS = "/\\\0"


def canonical(value, name: str = "value"):
    """``value`` as canonical JSON-able data: a bool stays a bool, an integral number
    becomes an int (1.0 -> 1), another real number a float, a tuple or list a list, a dict a
    dict of its canonical values (str keys); None and str stay. TypeError naming ``name`` (the
    setting's dotted name) for anything else."""
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, numbers.Integral):
        return int(value)
    if isinstance(value, numbers.Real):
        x = float(value)
        return int(x) if math.isfinite(x) and x.is_integer() else x
    if isinstance(value, (list, tuple)):
        return [canonical(v, f"{name}[{i}]") for i, v in enumerate(value)]
    if isinstance(value, dict):
        for k in value:
            if not isinstance(k, str):
                raise TypeError(f"{name}: setting names must be str, got {k!r}")
        return {k: canonical(v, f"{name}.{k}") for k, v in value.items()}
    raise TypeError(f"{name}: a setting must be JSON-like (None, bool, number, str, list, "
                    f"dict), got {type(value).__name__}")


def _text(value) -> str:
    """The canonical JSON text of canonical data (keys sorted, no spaces)."""
    return json.dumps(value, sort_keys=True, separators=(",", ":"), allow_nan=True)


def _leaves(d: dict, what: str, prefix: str = "") -> dict:
    """{"a.b": canonical leaf} of a nested dict; ValueError for a name holding a dot (it
    would read as a nesting), TypeError for a key that is not a str."""
    if not isinstance(d, dict):
        raise TypeError(f"{what} must be a dict, got {type(d).__name__}")
    out = {}
    for k, v in d.items():
        if not isinstance(k, str):
            raise TypeError(f"{what}: setting names must be str, got {k!r}")
        if "." in k or not k:
            raise ValueError(f"{what}: setting name {prefix}{k!r} must be non-empty and "
                             f"hold no '.' (dots join nested names)")
        if isinstance(v, dict) and v:
            out.update(_leaves(v, what, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = canonical(v, f"{prefix}{k}")
    return out


def changed_settings(values: dict, defaults: dict) -> dict:
    """{dotted name: canonical value} of the leaves of ``values`` that differ from the leaf
    of the same name in ``defaults`` or that ``defaults`` lacks (a name ``values`` lacks is
    at its default and left out). Both are nested dicts of JSON-like leaves.

    Raises:
        TypeError: either is not a dict, or holds a value that is not JSON-like.
        ValueError: a setting name is empty or holds a dot.
    """
    mine, base = _leaves(values, "values"), _leaves(defaults, "defaults")
    return {k: v for k, v in sorted(mine.items())
            if k not in base or _text(v) != _text(base[k])}


def check_label(label) -> None:
    """TypeError / ValueError unless ``label`` can begin a trial's file name: a non-empty str
    without path separators or NUL that does not start with a dot."""
    if not isinstance(label, str):
        raise TypeError(f"label must be a str, got {type(label).__name__}")
    if not label or label.startswith(".") or any(ch in label for ch in _BAD_CHARS):
        raise ValueError(f"label {label!r} must be a non-empty file name (no '/', '\\' or "
                         f"NUL, not starting with '.')")


def trial_name(label: str, seed: int, values: dict, defaults: dict) -> str:
    """A trial's name, ``<label>-seed<seed>-<8 hex>``: the hex the first eight of the SHA-1 of
    the canonical JSON of ``changed_settings(values, defaults)``.

    Args:
        label: what a reader sees first (a method, a goal, a task and a table row).
        seed: the trial's seed, an int >= 0 (not a bool).
        values: the trial's settings that name it (nested dicts of JSON-like leaves; leave
            out what does not change its result, such as thread counts).
        defaults: the fixed reference they are compared with (``field_defaults``).

    Raises:
        TypeError, ValueError: naming the bad argument.
    """
    check_label(label)
    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral):
        raise TypeError(f"seed must be an int, got {type(seed).__name__}")
    if seed < 0:
        raise ValueError(f"seed must be >= 0, got {seed}")
    digest = hashlib.sha1(_text(changed_settings(values, defaults)).encode()).hexdigest()
    return f"{label}-seed{int(seed)}-{digest[:8]}"


def field_defaults(cls) -> dict:
    """{field: default} of the dataclass ``cls``'s fields that have a default (a default
    factory is called; a dataclass value becomes its ``asdict``); fields without one are left
    out. The fixed reference of ``trial_name``: it moves only when the class's code does.

    Raises:
        TypeError: ``cls`` is not a dataclass class.
    """
    if not (isinstance(cls, type) and dataclasses.is_dataclass(cls)):
        raise TypeError(f"field_defaults needs a dataclass class, got {cls!r}")
    out = {}
    for f in dataclasses.fields(cls):
        if f.default is not dataclasses.MISSING:
            value = f.default
        elif f.default_factory is not dataclasses.MISSING:
            value = f.default_factory()
        else:
            continue
        out[f.name] = (dataclasses.asdict(value) if dataclasses.is_dataclass(value)
                       and not isinstance(value, type) else value)
    return out


__all__ = ["canonical", "changed_settings", "check_label", "field_defaults", "trial_name"]
