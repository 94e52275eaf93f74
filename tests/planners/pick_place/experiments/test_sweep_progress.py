"""The CEM-iteration bar of a sweep starts at what the sweep holds already: every iteration of
a finished trial, those of a checkpoint it resumes, none of a checkpoint it cannot resume (not
a trial's progress: the pick-and-place schema refuses it)."""

from dopt.lab.sweep import Checkpoint, Trial, run_sweep
from planners.pick_place.experiments.sweep import SCHEMA
from planners.pick_place.experiments.sweep import iterations_held as _iterations_held
from planners.trial_progress import RESULT_FIELDS


def _finish(params):
    return {**dict.fromkeys(RESULT_FIELDS, 0), "cost_history": [0.1], "stage_of_iteration": [0],
            "final_cost": 0.1}


def _progress(stages, stage):
    return {"trial": {}, "planner": {}, "stages": stages, "stage": stage}


def _stage(history):
    """A finished stage's plan as ``StagePlan.to_dict`` writes it, with the cost history."""
    return {"particles": [0], "displacements": [[0.0, 0.0, 0.1]], "final_state": [0.0],
            "cost": history[-1], "cost_history": history, "n_candidates": 1}


def _cem(iteration):
    """A CEM progress record (``CEMProgress.to_dict``) after ``iteration`` iterations."""
    import torch
    zeros = [[[0.0] * 3] * 2]
    return {"iteration": iteration, "dist": {"probs": [[0.5, 0.5]], "mean": zeros,
                                             "std": zeros},
            "best": [[0], [0], [[0.0, 0.0, 0.0]]], "best_cost": 0.2,
            "cost_history": [0.2] * iteration, "elite_history": [0.2] * iteration,
            "seconds": [0.1] * iteration, "n_nonfinite": 0,
            "generator_state": torch.Generator().get_state().tolist()}


def test_the_bar_starts_at_the_iterations_the_sweep_holds(tmp_path):
    from planners.pick_place import PickPlaceSettings
    settings = PickPlaceSettings.preset("rope", "fold", quick=True).to_dict()
    trials = [Trial(k, {"settings": settings, "method": "simple", "seed": i})
              for i, k in enumerate(["done", "half", "none", "bad", "other"])]
    run_sweep(_finish, trials[:1], tmp_path, schema=SCHEMA)        # a finished trial
    # stopped in its second stage: 4 iterations of the first, 3 of the second
    Checkpoint(tmp_path, "half").save(_progress([_stage([0.3, 0.2, 0.2, 0.1])],
                                                {"cem": _cem(3)}))
    Checkpoint(tmp_path, "bad").save({"no": "progress"})           # refused by the run
    Checkpoint(tmp_path, "other").save(_progress([], {"cem": {}}))  # no iteration count
    assert _iterations_held(trials, 12, tmp_path) == 12 + 4 + 3
    # between stages (no stage part-way), and a fresh folder
    Checkpoint(tmp_path, "half").save(_progress([_stage([0.3] * 6)], None))
    assert _iterations_held(trials, 12, tmp_path) == 12 + 6
    assert _iterations_held(trials, 12, tmp_path / "empty") == 0
