"""Small helpers on nested JSON-like dicts (standard library only, so that the report scripts,
which run without torch or MuJoCo, can use them)."""

from __future__ import annotations


def flatten(d: dict, prefix: str = "") -> dict:
    """{"a.b": value} of a nested dict's leaves (a dict value is descended into, any other
    value is a leaf)."""
    out = {}
    for k, v in d.items():
        if isinstance(v, dict):
            out.update(flatten(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = v
    return out
