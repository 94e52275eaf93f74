"""Input checks shared by dopt, planners and deformables (pure Python and numpy: importing it
loads neither MuJoCo nor torch): typed fields of frozen config dataclasses, numeric arrays,
index arrays and scalars.

Every check raises TypeError (wrong type or dtype) or ValueError (wrong value or shape, NaN/inf,
out of range) with a message that starts with the name of the argument or field.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import os
from collections.abc import Iterable, Mapping

import numpy as np


def is_int(x) -> bool:
    """An integer that is not a bool (Python or numpy)."""
    return isinstance(x, numbers.Integral) and not isinstance(x, (bool, np.bool_))


def is_real(x) -> bool:
    """A real number that is not a bool (Python or numpy; ints count)."""
    return isinstance(x, numbers.Real) and not isinstance(x, (bool, np.bool_))


# ---------------------------------------------------------------------------- configs
def check_config(config, *, positive: Iterable[str] = (), minimum: Mapping | None = None,
                 maximum: Mapping | None = None, choices: Mapping | None = None) -> None:
    """Check every field of the dataclass ``config`` against its annotation, then bounds.

    Annotations understood: ``bool`` (a bool, not 0/1), ``int`` (an integer, not a bool nor
    3.0), ``float`` (a finite real number, ints accepted), ``str``, ``X | None`` and
    ``tuple[X, ...]`` / ``tuple[X, X, X]`` (a tuple, list or 1-D array of that length, each
    entry checked). Then: ``positive`` fields must be > 0 (every entry of a tuple), ``minimum``
    / ``maximum`` map a field to its inclusive bound, ``choices`` a field to its allowed values.
    A field's metadata adds its own: ``"above"`` (> it), ``"at_least"`` (>= it), ``"at_most"``
    (<= it), ``"choices"``
    (one of them, None aside); the flags derived from the field read the same
    (``dopt.lab.flags``). Call it from ``__post_init__``; messages name ``Class.field``.
    """
    cls = type(config).__name__
    above = dict.fromkeys(positive, 0)
    minimum, maximum, choices = dict(minimum or {}), dict(maximum or {}), dict(choices or {})
    for f in dataclasses.fields(config):
        kind = f.type if isinstance(f.type, str) else getattr(f.type, "__name__", str(f.type))
        _check_value(getattr(config, f.name), kind.replace(" ", ""), f"{cls}.{f.name}")
        if "above" in f.metadata:
            above[f.name] = f.metadata["above"]
        if "at_least" in f.metadata:
            minimum[f.name] = f.metadata["at_least"]
        if "at_most" in f.metadata:
            maximum[f.name] = f.metadata["at_most"]
        if "choices" in f.metadata and getattr(config, f.name) is not None:
            choices[f.name] = tuple(f.metadata["choices"])

    def entries(name):
        value = getattr(config, name)
        if value is None:
            return []
        return list(value) if isinstance(value, (tuple, list, np.ndarray)) else [value]

    for name, lo in above.items():
        if any(not v > lo for v in entries(name)):
            raise ValueError(f"{cls}.{name} must be > {lo}, got {getattr(config, name)!r}")
    for name, lo in minimum.items():
        if any(not v >= lo for v in entries(name)):
            raise ValueError(f"{cls}.{name} must be >= {lo}, got {getattr(config, name)!r}")
    for name, hi in maximum.items():
        if any(not v <= hi for v in entries(name)):
            raise ValueError(f"{cls}.{name} must be <= {hi}, got {getattr(config, name)!r}")
    for name, allowed in choices.items():
        if getattr(config, name) not in allowed:
            raise ValueError(f"{cls}.{name} must be one of {sorted(allowed)}, "
                             f"got {getattr(config, name)!r}")


def _check_value(value, kind: str, name: str) -> None:
    if kind.endswith("|None") or kind.startswith("None|"):
        if value is None:
            return
        kind = kind[:-5] if kind.endswith("|None") else kind[5:]
    if kind.startswith("tuple[") and kind.endswith("]"):
        inner = kind[len("tuple["):-1].split(",")
        if not isinstance(value, (tuple, list, np.ndarray)) or np.ndim(value) != 1:
            raise TypeError(f"{name} must be a tuple, got {value!r}")
        if inner[-1] != "..." and len(value) != len(inner):
            raise ValueError(f"{name} must have {len(inner)} entries, got {len(value)}: "
                             f"{value!r}")
        for i, v in enumerate(value):
            _check_value(v, inner[0] if inner[-1] == "..." else inner[i], f"{name}[{i}]")
    elif kind == "bool":
        if not isinstance(value, (bool, np.bool_)):
            raise TypeError(f"{name} must be a bool, got {value!r}")
    elif kind == "int":
        if not is_int(value):
            raise TypeError(f"{name} must be an int, got {value!r}")
    elif kind == "float":
        if not is_real(value):
            raise TypeError(f"{name} must be a number, got {value!r}")
        if not math.isfinite(value):
            raise ValueError(f"{name} must be finite, got {value!r}")
    elif kind == "str":
        if not isinstance(value, str):
            raise TypeError(f"{name} must be a str, got {value!r}")


# ---------------------------------------------------------------------------- scalars
def check_int(value, name: str, minimum: int | None = None) -> int:
    """``value`` as an int (not a bool, not 3.0), >= ``minimum`` if given."""
    if not is_int(value):
        raise TypeError(f"{name} must be an int, got {value!r}")
    if minimum is not None and value < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {value!r}")
    return int(value)


def check_real(value, name: str, *, positive: bool = False, minimum: float | None = None,
               maximum: float | None = None) -> float:
    """``value`` as a finite float (not a bool); > 0 if ``positive``, within the inclusive
    ``minimum`` / ``maximum`` if given."""
    if not is_real(value):
        raise TypeError(f"{name} must be a number, got {value!r}")
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value!r}")
    if positive and not value > 0:
        raise ValueError(f"{name} must be > 0, got {value!r}")
    if minimum is not None and value < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {value!r}")
    if maximum is not None and value > maximum:
        raise ValueError(f"{name} must be <= {maximum}, got {value!r}")
    return float(value)


# ----------------------------------------------------------------------------- memory
#: set to a number of bytes to plan sizes for less (or more) than this machine's memory
MEMORY_ENV = "DOPT_MEMORY_BYTES"


def memory_bytes() -> int:
    """The bytes a size check plans for: this machine's physical memory (``MEMORY_ENV``
    overrides it; 1 TiB where the system does not say)."""
    env = os.environ.get(MEMORY_ENV, "").strip()
    if env:
        return int(float(env))
    try:
        return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        return 2 ** 40


def size_text(nbytes: float) -> str:
    """Bytes as text in binary units: "2.52 TiB"."""
    value = float(nbytes)
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if abs(value) < 1024 or unit == "PiB":
            return f"{value:.3g} {unit}"
        value /= 1024
    return f"{value:.3g} EiB"


def check_memory(nbytes: float, what: str) -> None:
    """ValueError "``what`` needs about X, more than this machine's memory (Y)" when
    ``nbytes`` exceed ``memory_bytes()``: the check a size that a setting implies gets before
    anything of that size is allocated (``what`` names the setting and the size)."""
    limit = memory_bytes()
    if not nbytes <= limit:
        raise ValueError(f"{what} needs about {size_text(nbytes)}, more than this machine's "
                         f"memory ({size_text(limit)}; {MEMORY_ENV} sets another bound)")


# ----------------------------------------------------------------------------- arrays
def as_array(x, name: str) -> np.ndarray:
    """``np.asarray(x)``; ValueError naming ``name`` for ragged nesting and the like."""
    try:
        return np.asarray(x)
    except (ValueError, TypeError) as e:          # ragged nesting, unconvertible objects
        raise ValueError(f"{name} is not a rectangular array: {e}") from None


def _shape_ok(shape: tuple, want: tuple) -> bool:
    return len(shape) == len(want) and all(w is None or s == w
                                           for s, w in zip(shape, want, strict=True))


def _shape_text(want: tuple) -> str:
    inner = ", ".join("." if w is None else str(w) for w in want)
    return f"({inner},)" if len(want) == 1 else f"({inner})"


def float_array(x, name: str, shape: tuple | None = None, *, ndim: int | tuple | None = None,
                finite: bool = True, nonnegative: bool = False) -> np.ndarray:
    """``x`` as a C-contiguous float64 array, checked.

    dtype: float or integer (bool, complex, str and object arrays raise TypeError). ``shape``:
    the required shape, None entries free (e.g. ``(None, 3)``); ``ndim``: allowed number(s) of
    dimensions. ``finite``: NaN/inf raise ValueError; ``nonnegative``: negative entries do.
    """
    arr = as_array(x, name)
    if arr.dtype.kind not in "fiu":
        raise TypeError(f"{name} must be a float array, got dtype {arr.dtype}")
    if shape is not None and not _shape_ok(arr.shape, tuple(shape)):
        raise ValueError(f"{name} must have shape {_shape_text(tuple(shape))}, got {arr.shape}")
    if ndim is not None and arr.ndim not in ((ndim,) if isinstance(ndim, int) else ndim):
        raise ValueError(f"{name} must have {ndim} dimensions, got shape {arr.shape}")
    if finite and arr.dtype.kind == "f" and not np.isfinite(arr).all():
        at = np.argwhere(~np.isfinite(arr))[0]
        raise ValueError(f"{name} contains NaN/inf (first at index {tuple(at.tolist())})")
    if nonnegative and np.any(arr < 0):
        raise ValueError(f"{name} must be non-negative")
    return np.ascontiguousarray(arr, dtype=np.float64)


def index_array(x, name: str, size: int, *, allow_empty: bool = False) -> np.ndarray:
    """``x`` (an int, or an array of ints of any shape) as a flat int64 array of indices into
    a sequence of length ``size``, in the given order.

    Floats (even 3.0), bools, NaN and strings raise TypeError; negative or >= size entries
    raise ValueError naming them (no Python-style wrap-around).
    """
    arr = as_array(x, name)
    if arr.dtype == object and arr.size and all(is_int(v) for v in arr.ravel()):
        arr = arr.astype(np.int64)
    if arr.size and arr.dtype.kind not in "iu":
        raise TypeError(f"{name} must be integers, got dtype {arr.dtype}"
                        + (f" ({arr.ravel()[:5].tolist()})" if arr.dtype.kind in "fb" else ""))
    arr = arr.astype(np.int64).ravel()
    if not arr.size and not allow_empty:
        raise ValueError(f"{name} is empty")
    bad = (arr < 0) | (arr >= size)
    if bad.any():
        raise ValueError(f"{name}: index out of range [0, {size}): {arr[bad][:5].tolist()}")
    return arr
