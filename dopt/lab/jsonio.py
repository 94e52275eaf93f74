"""Strict JSON for every file the project writes: no bare ``NaN`` or ``Infinity``.

Python's ``json`` writes ``NaN``, ``Infinity`` and ``-Infinity``, which JSON does not have
(strict parsers, ``jq``, browsers and most other languages reject the file). Here a number
that is not finite is written as ``null`` with the reason beside it, under the member name
with ``UNDEFINED_SUFFIX`` appended (one convention for every writer)::

    {"mpc_cost_normalised_ci90": null,
     "mpc_cost_normalised_ci90_undefined": "NaN: a confidence interval needs two or more values"}

Inside a list, the entries become ``null`` and the note beside the list maps each entry's
index path ("3", or "3.1" in a list of lists) to its reason. Every note starts with the value
it stands for ("NaN", "+inf" or "-inf"), so that ``loads`` can give back exactly the numbers
that were written (``restore``); any other reader sees a strict file with its reasons.

``dumps``/``write_atomic`` write (``replace_atomic`` writes any bytes atomically), ``loads``
reads (rejecting bare NaN/Infinity: such a file is not one of ours). Standard library only
(with ``dopt.atomic``).
"""

from __future__ import annotations

import json
import math
import os  # noqa: F401  (jsonio.os: the tests patch os.replace through it)
from collections.abc import Callable, Mapping
from pathlib import Path

from dopt import atomic

#: what is appended to a member's name for the note of its undefined value(s)
UNDEFINED_SUFFIX = "_undefined"
#: the value each note starts with -> the float it restores
KINDS = {"NaN": math.nan, "+inf": math.inf, "-inf": -math.inf}
#: the reason of a non-finite value by the end of its member's name (first match), and the
#: reason of any other
REASONS = (("ci90", "a confidence interval needs two or more values"),
           ("ci95", "a confidence interval needs two or more values"),
           ("ci", "a confidence interval needs two or more values"),
           ("ratio", "no baseline value to divide by (or none to divide)"),
           ("mean", "no finite value to average"),
           ("median", "no finite value to take the median of"))
DEFAULT_REASON = "not a finite number"


def reason_for(name: str) -> str:
    """The default reason of a non-finite value of the member ``name`` (``REASONS``)."""
    low = name.lower()
    for end, why in REASONS:
        if low.endswith(end):
            return why
    return DEFAULT_REASON


def _kind(x: float) -> str:
    return "NaN" if math.isnan(x) else "+inf" if x > 0 else "-inf"


def _is_bad(x) -> bool:
    return isinstance(x, float) and not math.isfinite(x)


def strict(obj, reasons: Mapping[str, str] | Callable[[str], str] | None = None):
    """A copy of the JSON-able ``obj`` whose non-finite floats are ``null`` with their notes
    (the module docstring). ``reasons``: {member name: reason} or a function of the name
    (default ``reason_for``). Numpy scalars are plain numbers to ``json`` only when they
    subclass float; anything else is left to ``json.dumps`` to refuse.

    Raises:
        ValueError: a member would need a note where its object already has that name.
    """
    def why(name: str) -> str:
        if callable(reasons):
            return reasons(name)
        if reasons is not None and name in reasons:
            return reasons[name]
        return reason_for(name)

    def in_list(items, path, notes, name):
        out = []
        for i, v in enumerate(items):
            where = f"{path}{i}"
            if _is_bad(v):
                notes[where] = f"{_kind(v)}: {why(name)}"
                out.append(None)
            elif isinstance(v, (list, tuple)):
                out.append(in_list(v, f"{where}.", notes, name))
            else:
                out.append(walk(v))
        return out

    def walk(x):
        if isinstance(x, Mapping):
            out = {}
            for k, v in x.items():
                note = None
                if _is_bad(v):
                    out[k], note = None, f"{_kind(v)}: {why(str(k))}"
                elif isinstance(v, (list, tuple)):
                    notes: dict = {}
                    out[k] = in_list(v, "", notes, str(k))
                    note = notes or None
                else:
                    out[k] = walk(v)
                if note is not None:
                    side = f"{k}{UNDEFINED_SUFFIX}"
                    if side in x:
                        raise ValueError(f"cannot note the undefined value of {k!r}: the "
                                         f"object already has a member {side!r}")
                    out[side] = note
            return out
        if isinstance(x, (list, tuple)):
            return [None if _is_bad(v) else walk(v) for v in x]
        return None if _is_bad(x) else x
    return walk(obj)


def _note_value(note) -> float | None:
    if isinstance(note, str):
        head = note.split(":", 1)[0].strip()
        if head in KINDS:
            return KINDS[head]
    return None


def _restore_list(items: list, notes: dict) -> bool:
    """Put the values ``notes`` ({index path: note}) stand for back into ``items``; False
    (nothing changed) if a note is not one of ours."""
    places = []
    for path, note in notes.items():
        value = _note_value(note)
        try:
            idx = [int(p) for p in str(path).split(".")]
            target = items
            for i in idx[:-1]:
                target = target[i]
            if value is None or target[idx[-1]] is not None:
                return False
        except (ValueError, IndexError, TypeError):
            return False
        places.append((target, idx[-1], value))
    for target, i, value in places:
        target[i] = value
    return True


def restore(obj):
    """Inverse of ``strict`` in place: each ``null`` with a note of ours becomes the number
    the note names and the note is removed. Returns ``obj``."""
    if isinstance(obj, dict):
        for side in [k for k in obj if isinstance(k, str) and k.endswith(UNDEFINED_SUFFIX)]:
            name = side[:-len(UNDEFINED_SUFFIX)]
            if name not in obj:
                continue
            note, value = obj[side], obj[name]
            if value is None and _note_value(note) is not None:
                obj[name] = _note_value(note)
                del obj[side]
            elif isinstance(value, list) and isinstance(note, dict) and \
                    _restore_list(value, note):
                del obj[side]
        for v in obj.values():
            restore(v)
    elif isinstance(obj, list):
        for v in obj:
            restore(v)
    return obj


def _refuse(constant: str):
    raise ValueError(f"{constant} is not JSON (a strict file writes null with a reason)")


def dumps(obj, *, indent: int | None = None, reasons=None) -> str:
    """``strict(obj, reasons)`` as JSON text (``allow_nan=False``: never a bare NaN)."""
    return json.dumps(strict(obj, reasons), indent=indent, allow_nan=False)


def loads(text: str | bytes, *, restore_values: bool = True, strict_numbers: bool = True):
    """Parse JSON and, with ``restore_values``, give back the numbers its notes stand for
    (``restore``). ``strict_numbers``: a bare NaN, Infinity or -Infinity is a ValueError (False:
    read as Python reads them, for files written before this module, by their own reader)."""
    obj = json.loads(text, parse_constant=_refuse if strict_numbers else None)
    return restore(obj) if restore_values else obj


def replace_atomic(path: Path | str, data: bytes, *, suffix: str = "", fsync: bool = True
                   ) -> None:
    """Write the bytes ``data`` to ``path`` atomically (``dopt.atomic.replace_atomic``: a
    temporary file in its folder, flushed and ``os.fsync``-ed unless ``fsync`` is False, then
    renamed over ``path``), so a reader, a killed writer or a full disk never sees half a
    file; an OSError names ``path``. The folder is created. An exception raised into it (a
    trial's interrupt) propagates as itself: the file then holds the old or the new bytes,
    and no temporary file is left."""
    atomic.replace_atomic(path, data, suffix=suffix, fsync=fsync)


def write_atomic(path: Path | str, obj, *, indent: int | None = None, reasons=None,
                 fsync: bool = True) -> None:
    """Write ``dumps(obj)`` (UTF-8) to ``path`` atomically (``replace_atomic``; ``fsync``:
    synced to the disk before the rename, as every result must be). The folder is created.
    TypeError/ValueError (nothing written) for what is not JSON-able. An exception raised
    into it (a trial's interrupt) propagates as itself: the file then holds the old or the
    new text, and no temporary file is left."""
    replace_atomic(path, dumps(obj, indent=indent, reasons=reasons).encode("utf-8"),
                   suffix=".json", fsync=fsync)
