"""The CEM-iteration bar of a sweep run in one process starts at what the sweep holds already:
every iteration of a finished trial, those of a checkpoint it resumes, none of a checkpoint it
cannot resume."""

from pick_place_cli import _iterations_held

from dopt.sweep import Checkpoint, Trial, run_sweep


def _finish(params):
    return {"done": True}


def test_the_bar_starts_at_the_iterations_the_sweep_holds(tmp_path):
    trials = [Trial(k, {"method": "simple", "seed": i})
              for i, k in enumerate(["done", "half", "none", "bad"])]
    run_sweep(_finish, trials[:1], tmp_path)                        # a finished trial
    # stopped in its second stage: 4 iterations of the first, 3 of the second
    Checkpoint(tmp_path, "half").save({"stages": [{"cost_history": [0.3, 0.2, 0.2, 0.1]}],
                                       "stage": {"cem": {"iteration": 3}}})
    Checkpoint(tmp_path, "bad").save({"no": "progress"})           # refused by the run
    assert _iterations_held(trials, 12, tmp_path) == 12 + 4 + 3
    # between stages (no stage part-way), and a fresh folder
    Checkpoint(tmp_path, "half").save({"stages": [{"cost_history": [0.3] * 6}], "stage": None})
    assert _iterations_held(trials, 12, tmp_path) == 12 + 6
    assert _iterations_held(trials, 12, tmp_path / "empty") == 0
