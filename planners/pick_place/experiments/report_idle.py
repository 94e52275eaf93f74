"""Plans that pick nothing, in RESULTS.md's Fig. 7 tables: trials whose executed plan chose
CEM's None (``planners.cem.NONE``) for every action, so the start only settles. From a prepared
start such a trial's final cost is the prepared fold's own cost to the goal, the mark a plan has
to beat; the sentence says how many trials of each method stopped there and how many beat it.
"""

from __future__ import annotations

import json
from collections.abc import Iterable

from dopt.lab.report.base import _finite, mm
from dopt.lab.trialpack import StoredTrial
from planners.cem import NONE
from planners.pick_place.experiments.report_paper import _in_label_order, _label

#: a trial "beats" the settled start when it ends closer by more than this (m): half the
#: 0.1 mm the tables print, so a cost shown equal to the start's never counts as beating it
BEAT_MARGIN = 0.05e-3


def picks_nothing(result: dict) -> bool:
    """Whether a trial's executed plan (its result's "actions", each with "particles": the
    particle picked at each step) picks no particle: every one is NONE. False when the result
    holds no actions or no particles (it says nothing about the plan)."""
    actions = result.get("actions") if isinstance(result, dict) else None
    if not isinstance(actions, list):
        return False
    try:
        picked = [int(p) for a in actions for p in a["particles"]]
    except (KeyError, TypeError, ValueError):
        return False
    return bool(picked) and all(p == NONE for p in picked)


def trial_records(files: Iterable[StoredTrial]) -> list[tuple[str, dict]]:
    """(method, result) of each readable trial file (its params' "method", its "result");
    unreadable files are left out."""
    out = []
    for f in files:
        try:
            d = json.loads(f.read_text())
            out.append((str(d["params"]["method"]), d["result"]))
        except (OSError, ValueError, KeyError, TypeError):
            continue
    return out


def idle_counts(records: Iterable[tuple[str, dict]]) -> dict[str, tuple[int, int]]:
    """records: (method, trial result) pairs. {method: (trials whose plan picks nothing,
    trials)}, the methods in the figures' order."""
    records = [(m, r) for m, r in records if isinstance(r, dict)]
    return {m: (sum(picks_nothing(r) for k, r in records if k == m),
                sum(k == m for k, _ in records))
            for m in _in_label_order(m for m, _ in records)}


def idle_share(counts: dict[str, tuple[int, int]]) -> str:
    """"CEM(Simple) 4 of 10, ..." from ``counts`` (``idle_counts``)."""
    return ", ".join(f"{_label(m)} {i} of {n}" for m, (i, n) in counts.items())


def idle_plans_line(records: Iterable[tuple[str, dict]]) -> str:
    """records: (method, trial result) pairs. The sentence naming, per method, how many
    trials' plans pick nothing (``idle_counts``) and how many end closer than those do (by
    more than ``BEAT_MARGIN``); "" when no plan picks nothing. The settled start's cost is the
    idle trials' final cost (a range when they differ)."""
    records = [(m, r) for m, r in records if isinstance(r, dict)]
    idle = [r["final_cost"] for _, r in records
            if picks_nothing(r) and _finite(r.get("final_cost"))]
    if not idle:
        return ""
    low, high = min(idle), max(idle)
    start = mm(low) if mm(low) == mm(high) else f"{mm(low)}-{mm(high)}"
    closer = [k for k, r in records
              if _finite(c := r.get("final_cost")) and c < low - BEAT_MARGIN]
    counts = idle_counts(records)
    beats = [f"{_label(m)} {closer.count(m)}" for m in counts]
    return (f"Plans that pick nothing (CEM's None at every action, so the start only "
            f"settles, to {start} mm from this goal): {idle_share(counts)}. Trials that end "
            f"closer than that: {', '.join(beats)}.")
