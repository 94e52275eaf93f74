"""An interrupt that lands inside an atomic write (a pool worker's SIGTERM while its trial
saves a checkpoint) propagates as itself: the file holds the old or the new text whole, no
temporary file is left, and the sweep counts the trial as stopped with its checkpoint, not
as failed."""

import json
import os

import pytest

from dopt import jsonio, trialpack
from dopt.provenance import COMMIT_ENV
from dopt.sweep import CHECKPOINT_DIR, Trial, run_sweep
from dopt.sweep_exec import TrialInterrupted
from tests.dopt.sweep_trials import count


class Landed(BaseException):
    """Stands for the interrupt (a BaseException, as TrialInterrupted and KeyboardInterrupt)."""


def replace_then_raise(real):
    def replace(src, dst):
        real(src, dst)
        raise Landed
    return replace


def replace_raising_before(src, dst):
    raise Landed


@pytest.mark.parametrize("replace, expect", [
    (replace_then_raise(os.replace), {"v": "new"}),     # after the rename: the new text
    (replace_raising_before, {"v": "old"}),             # before it: the old text
])
def test_an_interrupt_inside_the_write_propagates_and_leaves_one_whole_file(
        tmp_path, monkeypatch, replace, expect):
    path = tmp_path / "a.json"
    jsonio.write_atomic(path, {"v": "old"})
    monkeypatch.setattr(jsonio.os, "replace", replace)
    with pytest.raises(Landed):
        jsonio.write_atomic(path, {"v": "new"})
    assert json.loads(path.read_text()) == expect
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.json"]


@pytest.mark.parametrize("replace, expect", [
    (replace_then_raise(os.replace), {"k": '{"key": "k", "v": "new"}'}),
    (replace_raising_before, {"k": '{"key": "k", "v": "old"}'}),
])
def test_an_interrupt_inside_a_pack_write_leaves_one_whole_pack(
        tmp_path, monkeypatch, replace, expect):
    trialpack.write_pack(tmp_path, {"k": '{"key": "k", "v": "old"}'})
    monkeypatch.setattr(jsonio.os, "replace", replace)
    with pytest.raises(Landed):
        trialpack.write_pack(tmp_path, {"k": '{"key": "k", "v": "new"}'})
    assert {k: t.text for k, t in trialpack.read_pack(tmp_path).items()} == expect
    assert sorted(p.name for p in tmp_path.iterdir()) == [trialpack.PACK_NAME]


def test_a_trial_interrupted_as_its_checkpoint_lands_is_stopped_with_it(tmp_path, monkeypatch):
    monkeypatch.setenv(COMMIT_ENV, "c0ffee")
    real, saves = os.replace, []

    def replace(src, dst):                  # the third checkpoint lands, then the interrupt
        real(src, dst)
        if CHECKPOINT_DIR in str(dst):
            saves.append(dst)
            if len(saves) == 3:
                raise TrialInterrupted("stopped by SIGTERM")

    monkeypatch.setattr(jsonio.os, "replace", replace)
    res = run_sweep(count, [Trial("c", {"n": 5})], tmp_path)
    assert res.failed == {} and res.interrupted == {"c": "stopped by SIGTERM"}
    monkeypatch.setattr(jsonio.os, "replace", real)
    again = run_sweep(count, [Trial("c", {"n": 5})], tmp_path)
    assert again.resumed == ["c"] and again.failed == {}
    result = again.records["c"]["result"]
    assert (result["i"], result["runs"]) == (5, 2)      # resumed from step 3, not restarted
