"""Stored trials judged by their content, not only their form: a record whose params are
another trial's (a record of another goal copied under this trial's name), a result whose
numbers are not finite, a checkpoint of another trial's params: each is named, moved to
OUT/trials/corrupt/ with its reason written beside it, and its trial recomputed."""

import json
import logging
import math

import pytest

from dopt.lab.provenance import COMMIT_ENV
from dopt.lab.sweep import Checkpoint, Schema, Trial, is_finished, run_sweep
from tests.dopt.lab.sweep_trials import count, square

COMMIT = "c0ffee"


@pytest.fixture(autouse=True)
def code(monkeypatch):
    monkeypatch.setenv(COMMIT_ENV, COMMIT)


def _store(tmp_path, key, params, result):
    path = tmp_path / "trials" / f"{key}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    rec = {"key": key, "params": params, "result": result,
           "code": {"version": "1", "commit": COMMIT}}
    path.write_text(json.dumps(rec))
    return path, rec


def _without_threads(params):
    """An experiment's identity: the params less a field that does not change the result."""
    return {k: v for k, v in params.items() if k != "threads"}


def test_a_record_of_another_trial_under_this_name_is_moved_aside_and_recomputed(
        tmp_path, caplog):
    """Its params name another trial (x 5 under the name of x 1): before, it was reused as
    trial x1's result (the summary then read a record of another goal: KeyError)."""
    path, rec = _store(tmp_path, "x1", {"x": 5}, {"y": 25})
    with caplog.at_level(logging.WARNING, logger="dopt.lab.sweep"):
        res = run_sweep(square, [Trial("x1", {"x": 1})], tmp_path,
                        schema=Schema(identity=dict))
    assert res.ran == ["x1"] and res.records["x1"]["result"]["y"] == 1
    assert "another trial's" in res.recomputed["x1"] and "'x'" in res.recomputed["x1"]
    moved = tmp_path / "trials" / "corrupt" / "x1.json"
    assert json.loads(moved.read_text()) == rec
    reason = (tmp_path / "trials" / "corrupt" / "x1.reason.txt").read_text()
    assert "another trial's" in reason and str(path) in reason
    assert str(path) in caplog.text and "another trial's" in caplog.text


def test_identity_decides_which_params_name_a_trial(tmp_path):
    """With the experiment's identity a record that differs only in a field left out of it
    (threads) is reused; one that differs in a field it holds is not; ``dict`` compares all
    the params, and without an identity params are not compared."""
    _store(tmp_path, "a", {"x": 2, "threads": 4}, {"y": -1})
    _store(tmp_path, "b", {"x": 3, "threads": 4}, {"y": -1})
    schema = Schema(identity=_without_threads)
    trials = [Trial("a", {"x": 2, "threads": 1}), Trial("b", {"x": 2, "threads": 1})]
    assert is_finished(tmp_path, "a", schema=schema, params=trials[0].params)
    assert not is_finished(tmp_path, "b", schema=schema, params=trials[1].params)
    res = run_sweep(square, trials, tmp_path, schema=schema)
    assert res.skipped == ["a"] and res.ran == ["b"]
    assert res.records["a"]["result"]["y"] == -1 and res.records["b"]["result"]["y"] == 4
    _store(tmp_path, "c", {"x": 2, "threads": 4}, {"y": -1})
    _store(tmp_path, "d", {"x": 2, "threads": 4}, {"y": -1})
    res = run_sweep(square, [Trial("c", {"x": 2, "threads": 1})], tmp_path,
                    schema=Schema(identity=dict))
    assert res.ran == ["c"]                                 # every param counts
    res = run_sweep(square, [Trial("d", {"x": 3})], tmp_path)
    assert res.skipped == ["d"]                              # none is compared


def test_params_read_back_from_json_are_the_same_trial(tmp_path):
    """Tuples come back as lists and keys in another order: still the same trial."""
    _store(tmp_path, "t", {"b": [1, 2], "a": {"z": 1.5, "y": None}}, {"y": 7})
    res = run_sweep(square, [Trial("t", {"a": {"y": None, "z": 1.5}, "b": (1, 2)})], tmp_path,
                    schema=Schema(identity=dict))
    assert res.skipped == ["t"] and res.recomputed == {}


def _raising_identity(params):
    return params["settings"]["goal"]


def test_params_the_identity_cannot_read_are_not_this_trial(tmp_path):
    _store(tmp_path, "g", {"x": 3}, {"y": 9})
    schema = Schema(identity=_raising_identity)
    res = run_sweep(_goal_square, [Trial("g", {"x": 3, "settings": {"goal": "side"}})],
                    tmp_path, schema=schema)
    assert res.ran == ["g"] and "cannot be read" in res.recomputed["g"]


def _goal_square(params):
    return square(params)


@pytest.mark.parametrize("value, word", [(math.inf, "inf"), (math.nan, "nan"),
                                         ("12", "not a number"), (None, "not a number"),
                                         ([1.0, math.nan], "not a number")])
def test_a_result_whose_number_is_not_finite_is_moved_aside_and_recomputed(
        tmp_path, value, word):
    """A stored "y" of inf (an MPC cost of +inf, written null with its reason) once reached
    the summary and failed every rerun there."""
    path = tmp_path / "trials" / "x3.json"
    path.parent.mkdir(parents=True)
    from dopt.lab import jsonio
    jsonio.write_atomic(path, {"key": "x3", "params": {"x": 3}, "result": {"y": value},
                               "code": {"version": "1", "commit": COMMIT}})
    schema = Schema(result=("y",), finite=("y",))
    res = run_sweep(square, [Trial("x3", {"x": 3})], tmp_path, schema=schema)
    assert res.ran == ["x3"] and res.records["x3"]["result"]["y"] == 9
    assert "'y'" in res.corrupt["x3.json"] and word in res.corrupt["x3.json"]
    assert (tmp_path / "trials" / "corrupt" / "x3.json").exists()


def test_a_trial_whose_own_result_is_not_finite_fails_and_writes_nothing(tmp_path):
    res = run_sweep(_inf, [Trial("i", {"x": 1})], tmp_path,
                    schema=Schema(result=("y",), finite=("y",)))
    assert list(res.failed) == ["i"] and "'y'" in res.failed["i"]
    assert not (tmp_path / "trials" / "i.json").exists()


def _inf(params):
    return {"y": math.inf}


def test_schema_finite_must_name_keys():
    with pytest.raises(TypeError, match="finite"):
        Schema(finite="y")
    with pytest.raises(TypeError, match="identity"):
        Schema(identity=3)


def test_a_checkpoint_of_another_trials_params_is_moved_aside_and_the_trial_starts_afresh(
        tmp_path, caplog):
    """A checkpoint saved by trial x (n 5) under the name of a trial with other params once
    resumed as if it were that trial's."""
    schema = Schema(identity=dict)
    Checkpoint(tmp_path, "c", params={"n": 5, "stop_at": None}).save({"i": 4, "runs": 1})
    with caplog.at_level(logging.WARNING, logger="dopt.lab.sweep"):
        res = run_sweep(count, [Trial("c", {"n": 3})], tmp_path, schema=schema)
    assert res.resumed == [] and res.records["c"]["result"]["runs"] == 1
    assert res.records["c"]["result"]["i"] == 3
    folder = tmp_path / "trials" / "checkpoints" / "corrupt"
    assert (folder / "c.json").exists() and "another trial's" in (
        folder / "c.reason.txt").read_text()
    # its own checkpoint (the same params) resumes
    Checkpoint(tmp_path, "d", params={"n": 3}).save({"i": 2, "runs": 1})
    res = run_sweep(count, [Trial("d", {"n": 3})], tmp_path, schema=schema)
    assert res.resumed == ["d"] and res.records["d"]["result"]["runs"] == 2
