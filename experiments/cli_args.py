"""Command-line helpers shared by the experiment scripts (standard library only, so the
MuJoCo-free key-particle experiment can use them without importing torch or MuJoCo).

The ``*_int`` / ``*_float`` functions are argparse ``type=`` callables: a bad value becomes an
argparse usage error (exit 2) naming the flag, before anything runs.
"""
from __future__ import annotations

import argparse
import math
from collections.abc import Sequence


def choices_list(text: str, choices: Sequence[str], what: str) -> list[str]:
    """Comma-separated names -> list, each one of ``choices``.

    Raises:
        ValueError: an unknown name, or none at all (the message names ``what`` and lists
            ``choices``).
    """
    names = [name.strip() for name in text.split(",") if name.strip()]
    bad = [name for name in names if name not in choices]
    if bad or not names:
        raise ValueError(f"unknown {what} {bad}; choose from {', '.join(choices)}")
    return names


def _number(kind, low: float, strict: bool):
    def parse(text: str):
        try:
            v = kind(text)
        except ValueError:
            what = "an integer" if kind is int else "a number"
            raise argparse.ArgumentTypeError(f"{text!r} is not {what}") from None
        if not math.isfinite(v) or (v <= low if strict else v < low):
            least = f">= {low + 1:g}" if strict and kind is int else \
                f"{'>' if strict else '>='} {low:g}"
            raise argparse.ArgumentTypeError(f"must be {least}, got {text}")
        return v
    return parse


#: an int >= 1
positive_int = _number(int, 0, strict=True)
#: an int >= 0
nonneg_int = _number(int, 0, strict=False)
#: a finite float > 0
positive_float = _number(float, 0.0, strict=True)
#: a finite float >= 0
nonneg_float = _number(float, 0.0, strict=False)
