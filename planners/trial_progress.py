"""Reading the progress a pick-and-place trial saves (``planners.pick_place.run_problem``
gives it to its checkpoint): standard library only, so that ``experiments/report.py`` reads it
without torch or MuJoCo.

The progress is a dict: "trial" (method, seed, settings identity), "stages" (one
``StagePlan.to_dict()`` per finished stage), "stage" (the unfinished stage's progress, its
CEM's under "cem", or None), "planner" (the generators' state), "segments" and "wall_s".
"""

from __future__ import annotations


def iterations_done(progress: dict) -> int:
    """The CEM iterations a saved progress holds: those of its finished stages (one per entry
    of their ``cost_history``) and those of the stage it stopped in.

    Raises:
        KeyError, TypeError: ``progress`` is not a trial's saved progress.
    """
    stage = progress["stage"]
    return (sum(len(p["cost_history"]) for p in progress["stages"])
            + (int(stage["cem"]["iteration"]) if stage is not None else 0))
