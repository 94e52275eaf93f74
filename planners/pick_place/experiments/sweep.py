"""The sweep of the key-particle experiments (``fig7``, ``scaling``, ``encoding``): their trials
run through ``dopt.lab.sweep`` with the sweep's console (``dopt.lab.console``), their schema
(what a stored result and checkpoint must hold to be reused or resumed) and the CEM iterations
a folder already holds. The trials write their blow-up captures under the sweep's folder
(``planners.pick_place.run_trial``'s ``blowup_out``)."""

from __future__ import annotations

import functools
from pathlib import Path

from dopt.lab.console import run_with_console
from dopt.lab.sweep import Checkpoint, Schema, SweepResult, Trial, checkpoint_of, is_finished
from planners.pick_place import run_trial
from planners.pick_place.run import checkpoint_problem
from planners.pick_place.trial_names import trial_aliases, trial_identity
from planners.trial_progress import (
    PROGRESS_FIELDS,
    RESULT_FIELDS,
    iterations_done,
    result_problem,
)

#: what a stored trial and its checkpoint must hold to be reused or resumed (``dopt.lab.sweep``):
#: their fields, a cost history as long as its stages' list, a CEM progress that can resume,
#: and params that name the trial they are stored for (``trial_identity``); a trial written
#: before the one identity is found under its older name (``trial_aliases``)
SCHEMA = Schema(result=RESULT_FIELDS, progress=PROGRESS_FIELDS, check_result=result_problem,
                check_progress=checkpoint_problem, identity=trial_identity,
                aliases=trial_aliases)


def run_trials(trials: list[Trial], iterations_per_trial: int, out: Path,
               fresh: bool = False, workers: int = 1,
               reuse: str = "same-code") -> tuple[list, SweepResult]:
    """Every trial not finished yet under ``out`` (all of them when ``fresh``), inline or on a
    pool of ``workers`` processes, with the sweep's console (a bar of the CEM iterations of
    every trial, the running ones of the pool included). Returns the records ({"params",
    "result"}, what ``summarize`` takes) of the given trials and the sweep's result
    (``failed``: {key: error}, ``commits``: the code versions of the results); a trial's
    blow-up captures go to ``out``/blowups. ``reuse``: the sweep's
    (``dopt.lab.sweep.run_sweep``; "any" with --reuse-any)."""
    cem = {t.key for t in trials if t.params["method"] != "scripted"}
    res = run_with_console(
        functools.partial(cem_trial, blowup_out=str(out)), trials, out, unit="it",
        desc="CEM iterations", workers=workers,
        fresh=fresh, schema=SCHEMA, reuse=reuse,
        steps=lambda t: iterations_per_trial if t.key in cem else 0,
        held=lambda t: iterations_held([t], iterations_per_trial, out) if t.key in cem else 0,
        describe=describe_result)
    keys = {t.key for t in trials}
    return [r for k, r in res.records.items() if k in keys], res


def describe_result(record: dict) -> str:
    """A finished pick-and-place trial in a few words (its finished line): its final cost."""
    return f"final cost {record['result']['final_cost'] * 1e3:.1f} mm"


def cem_trial(params: dict, checkpoint: Checkpoint | None = None, report=None,
              blowup_out: str | None = None) -> dict:
    """``run_trial`` for the sweep (inline or in a pool's worker): each CEM iteration is
    given to ``report`` (the sweep's bar counts them), progress saved to ``checkpoint``,
    blow-up captures written under ``blowup_out``."""
    tick = None if report is None else (lambda i, best: report())
    return run_trial(params, on_iteration=tick, checkpoint=checkpoint, blowup_out=blowup_out)


def iterations_held(trials: list[Trial], iterations_per_trial: int, out: Path) -> int:
    """The CEM iterations of ``trials`` that a (not fresh) sweep under ``out`` holds already:
    all of a finished trial's, those of a checkpoint it resumes."""
    held = 0
    for t in trials:
        if is_finished(out, t.key, schema=SCHEMA, params=t.params):
            held += iterations_per_trial
        elif (progress := checkpoint_of(out, t, SCHEMA).peek()) is not None:
            held += iterations_done(progress)
    return held

