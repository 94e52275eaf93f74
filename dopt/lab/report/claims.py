"""The papers' claims, each judged on the recorded result files (the per-paper pages).

A ``Claim`` names what a paper says (in words, where it says it) and how our result files
judge it: ``judge(results)`` gives a ``Finding`` (the verdict, one sentence of what we measured
with every number read from the files, and the files it read), or None where no file bears on
it yet. Verdicts (``VERDICTS``): "holds", "partly holds" (some of its cases hold), "does not
hold", "not shown" (the test finds no effect either way) and "not judged" (a demonstration or a
case no file can decide). The registered experiments give the claims (``Experiment.claims``,
in registration order: the order their pages give them); ``claim_of(title)`` finds one by its
title, which is also its heading on the page (the README map links there).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from dopt.lab.experiment import registered
from dopt.lab.report.base import Result

VERDICTS = ("holds", "partly holds", "does not hold", "not shown", "not judged")


@dataclass(frozen=True)
class Finding:
    """A claim judged: ``verdict`` (one of ``VERDICTS``), ``measured`` (a sentence, every
    number from ``files``) and the result files it read."""

    verdict: str
    measured: str
    files: tuple[Result, ...]

    def __post_init__(self):
        if self.verdict not in VERDICTS:
            raise ValueError(f"verdict must be one of {VERDICTS}, got {self.verdict!r}")


@dataclass(frozen=True)
class Claim:
    """What ``paper`` says at ``where`` (``says``, in words), how ``judge`` reads it from the
    result files, and the RESULTS.md section (``details``) that holds the tables behind it;
    ``hidden_until_recorded``: its page leaves it out while no file bears on it (in place of
    "not recorded yet")."""

    paper: str
    title: str
    where: str
    says: str
    details: str
    judge: Callable[[list[Result]], Finding | None]
    hidden_until_recorded: bool = False


def share(k: int, n: int) -> str:
    """The verdict of a claim that holds in ``k`` of its ``n`` cases."""
    if n == 0:
        return "not judged"
    return "holds" if k == n else "does not hold" if k == 0 else "partly holds"


def newest(files: list[Result]) -> Result | None:
    return max(files, key=lambda r: str(r.origin.get("date", ""))) if files else None


def all_claims() -> list[Claim]:
    """Every registered experiment's claims, in registration order."""
    return [c for e in registered() for c in e.claims()]


def claim_of(title: str) -> Claim:
    """The claim of ``title`` (ValueError naming it if there is none)."""
    for c in all_claims():
        if c.title == title:
            return c
    raise ValueError(f"no claim titled {title!r}; claims: {[c.title for c in all_claims()]}")
