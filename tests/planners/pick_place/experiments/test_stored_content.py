"""The experiments' stored trials judged by content (each experiment's ``Schema``; the SVR
ones' in tests/planners/svr_mpc/experiments/test_stored_content.py): a record of another goal
stored under a trial's name, a shortened cost history and a checkpoint whose CEM probabilities
are negative are moved aside and recomputed (each once failed every rerun: KeyError
'matching_distance', a zip() ValueError, the trial's own ValueError); and the flags that
could only make such content are refused at parse time."""

import json
import logging
import math

import pytest
import torch

from dopt.lab.provenance import COMMIT_ENV
from dopt.lab.sweep import Checkpoint
from planners.pick_place.experiments import fig7
from planners.pick_place.experiments import sweep as pick_sweep

QUICK_ROPE = ["--quick", "--no-render"]


@pytest.fixture(autouse=True)
def fixed_code(monkeypatch):
    monkeypatch.setenv(COMMIT_ENV, "c0ffee")


def _only_record(out):
    (path,) = (out / "trials").glob("*.json")
    return path, json.loads(path.read_text())


# ----------------------------------------------------------------------- pick-and-place
def test_a_record_of_another_goal_under_a_trials_name_is_recomputed(tmp_path, caplog):
    """The fold record copied under the straighten trial's name (its key edited to match)
    was reused as the straighten trial's: its summary then failed on a metric the fold
    result does not have."""
    fold, straight = tmp_path / "fold", tmp_path / "straighten"
    base = [*QUICK_ROPE, "--methods", "scripted"]
    assert fig7.rope([*base, "--goal", "fold", "--out", str(fold)]) == 0
    assert fig7.rope([*base, "--goal", "straighten", "--out", str(straight)]) == 0
    path, mine = _only_record(straight)
    _, theirs = _only_record(fold)
    path.write_text(json.dumps({**theirs, "key": mine["key"]}))
    with caplog.at_level(logging.WARNING, logger="dopt.lab.sweep"):
        assert fig7.rope([*base, "--goal", "straighten", "--out", str(straight)]) == 0
    assert "its params are another trial's" in caplog.text
    assert "'settings.goal': stored \"fold\", this trial's \"straighten\"" in caplog.text
    assert (straight / "trials" / "corrupt" / path.name).exists()
    reason = (straight / "trials" / "corrupt" / f"{path.stem}.reason.txt").read_text()
    assert "another trial's" in reason
    again = json.loads(path.read_text())["result"]                          # recomputed
    assert {k: v for k, v in again.items() if k != "wall_s"} == {
        k: v for k, v in mine["result"].items() if k != "wall_s"}


def test_the_pick_identity_leaves_out_the_threads_only():
    """A trial rerun with other threads is the same trial; one of another goal or seed
    is not."""
    from planners.pick_place import PickPlaceSettings

    def params(goal="fold", seed=0, threads=1):
        s = PickPlaceSettings.preset("rope", goal, quick=True)
        return json.loads(json.dumps({"settings": {**s.to_dict(), "threads": threads},
                                      "method": "simple", "seed": seed}))
    schema = pick_sweep.SCHEMA
    assert schema.params_problem(params(threads=4), params(threads=1)) is None
    assert "another trial's" in schema.params_problem(params("straighten"), params())
    assert "another trial's" in schema.params_problem(params(seed=1), params())
    assert "cannot be read" in schema.params_problem({"settings": {"n": 3}}, params())


def test_a_shortened_cost_history_is_moved_aside_and_recomputed(tmp_path, caplog):
    """A cost history one entry short of its stages gave zip()'s ValueError in the curves."""
    out = tmp_path / "rope"
    argv = [*QUICK_ROPE, "--methods", "scripted", "--out", str(out)]
    assert fig7.rope(argv) == 0
    path, rec = _only_record(out)
    rec["result"]["cost_history"].pop()
    path.write_text(json.dumps(rec))
    with caplog.at_level(logging.WARNING, logger="dopt.lab.sweep"):
        assert fig7.rope(argv) == 0
    assert "cost history" in caplog.text and (out / "trials" / "corrupt" / path.name).exists()
    again = json.loads(path.read_text())["result"]
    assert len(again["cost_history"]) == len(again["stage_of_iteration"])


def _cem_progress(probs):
    """A CEM progress record of one action over one candidate (and None), as
    ``CEMProgress.to_dict`` writes it, with the categorical ``probs``."""
    zeros = [[[0.0] * 3] * 2]
    return {"iteration": 1, "dist": {"probs": [probs], "mean": zeros, "std": zeros},
            "best": [[0], [0], [[0.0, 0.0, 0.0]]], "best_cost": 0.5, "cost_history": [0.5],
            "elite_history": [0.5], "seconds": [0.1], "n_nonfinite": 0,
            "generator_state": torch.Generator().get_state().tolist()}


def _progress(probs):
    return {"trial": {}, "stages": [], "planner": {},
            "stage": {"candidates": [0], "cem": _cem_progress(probs),
                      "task": {"n_evaluated": 0, "n_unstable": 0, "n_infeasible": 0}}}


def test_the_pick_schema_reads_a_checkpoints_cem_progress():
    schema = pick_sweep.SCHEMA
    assert schema.progress_problem(_progress([0.25, 0.75])) is None
    assert "probabilities" in schema.progress_problem(_progress([1.25, -0.25]))
    assert "probabilities" in schema.progress_problem(_progress([0.5, math.nan]))


def test_a_checkpoint_with_a_negative_cem_probability_is_moved_aside(tmp_path, caplog):
    """It failed its trial on every rerun (CEMProgress.from_dict's ValueError inside the
    trial) and stayed where it was."""
    out = tmp_path / "rope"
    argv = [*QUICK_ROPE, "--methods", "random", "--out", str(out)]
    assert fig7.rope(argv) == 0
    path, rec = _only_record(out)
    path.unlink()
    Checkpoint(out, path.stem).save(_progress([1.25, -0.25]))
    with caplog.at_level(logging.WARNING, logger="dopt.lab.sweep"):
        assert fig7.rope(argv) == 0
    assert "is not resumed" in caplog.text and "probabilities" in caplog.text
    moved = out / "trials" / "checkpoints" / "corrupt"
    assert (moved / path.name).exists() and (moved / f"{path.stem}.reason.txt").exists()
    assert json.loads(path.read_text())["result"]["cost_history"] == \
        rec["result"]["cost_history"]
