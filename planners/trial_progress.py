"""Reading the progress a pick-and-place trial saves (``planners.pick_place.run_problem``
gives it to its checkpoint): standard library only, so that ``experiments/report.py`` reads it
without torch or MuJoCo.

The progress is a dict: "trial" (method, seed, settings identity), "stages" (one
``StagePlan.to_dict()`` per finished stage), "stage" (the unfinished stage's progress, its
CEM's under "cem", or None), "planner" (the generators' state), "segments" and "wall_s".
"""

from __future__ import annotations

#: settings fields that say how a trial runs, not what it computes (the simulation threads):
#: left out of its identity (``PickPlaceSettings.identity``, the sweep's key), so trials
#: differing only in them are the same trial, and the report groups them together
RUN_ONLY_SETTINGS = ("threads",)
#: keys every pick-and-place trial result holds (``PickPlaceResult.to_dict``): what the
#: summary, the curves, the renders and the report read; a stored result without one of them
#: is not reused (``dopt.lab.sweep.Schema``)
RESULT_FIELDS = ("method", "seed", "final_cost", "cost_history", "stage_of_iteration",
                 "stage_costs", "n_candidates", "s_per_iteration", "actions", "final_state",
                 "wall_s", "unstable", "unstable_reason", "n_rollouts",
                 "n_unstable_rollouts")
#: keys every saved progress holds (the module docstring); a checkpoint without one of them
#: is not resumed
PROGRESS_FIELDS = ("trial", "stages", "stage", "planner")


def progress_problem(progress: dict) -> str | None:
    """Why ``progress`` (holding ``PROGRESS_FIELDS``) is not a trial's saved progress, or
    None: its stages must be a list of objects with a ``cost_history`` list, its unfinished
    stage None or an object whose CEM iteration is an int >= 0 (``iterations_done`` reads
    them)."""
    stages, stage = progress["stages"], progress["stage"]
    if not isinstance(stages, list) or not all(
            isinstance(p, dict) and isinstance(p.get("cost_history"), list) for p in stages):
        return "its finished stages are not a list of stage plans"
    if stage is not None:
        it = (stage.get("cem") or {}).get("iteration") if isinstance(stage, dict) else None
        if not isinstance(it, int) or isinstance(it, bool) or it < 0:
            return "its unfinished stage has no CEM iteration count"
    return None


def result_problem(result: dict) -> str | None:
    """Why ``result`` (holding ``RESULT_FIELDS``) cannot be a trial's result, or None: its
    cost history must be a list of numbers as long as its ``stage_of_iteration`` (the curves
    and the summary read them pairwise), its final cost a number (NaN, stored null, for an
    unstable trial)."""
    history, stages = result["cost_history"], result["stage_of_iteration"]
    if not (isinstance(history, list) and isinstance(stages, list)):
        return "its cost history or its stage of each iteration is not a list"
    if len(history) != len(stages):
        return (f"its cost history holds {len(history)} iterations, its stage of each "
                f"iteration {len(stages)} (a shortened history)")
    if not all(_is_number(c) for c in [*history, result["final_cost"]]):
        return "its cost history or final cost holds something that is not a number"
    return None


def _is_number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def iterations_done(progress: dict) -> int:
    """The CEM iterations a saved progress holds: those of its finished stages (one per entry
    of their ``cost_history``) and those of the stage it stopped in.

    Raises:
        KeyError, TypeError: ``progress`` is not a trial's saved progress.
    """
    stage = progress["stage"]
    return (sum(len(p["cost_history"]) for p in progress["stages"])
            + (int(stage["cem"]["iteration"]) if stage is not None else 0))
