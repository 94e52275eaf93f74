"""Command-line helpers shared by the experiment scripts (standard library only, so the
MuJoCo-free key-particle experiment can use them without importing torch or MuJoCo)."""
from __future__ import annotations

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
