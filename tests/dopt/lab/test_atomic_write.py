"""An interrupt that lands inside an atomic write (a pool worker's SIGTERM while its trial
saves a checkpoint) propagates as itself: the file holds the old or the new text whole, no
temporary file is left, and the sweep counts the trial as stopped with its checkpoint, not
as failed. A write that fails (a full disk, a file-size limit) leaves the old file whole and
names the file in its error."""

import contextlib
import errno
import hashlib
import json
import os
import resource
import stat

import pytest

from dopt import atomic
from dopt.lab import jsonio, trialpack
from dopt.lab.provenance import COMMIT_ENV
from dopt.lab.sweep import CHECKPOINT_DIR, Trial, run_sweep
from dopt.lab.sweep_exec import TrialInterrupted
from tests.dopt.lab.sweep_trials import count


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
    trialpack.append_pack(tmp_path, {"k": '{"key": "k", "v": "old"}'})
    monkeypatch.setattr(jsonio.os, "replace", replace)
    with pytest.raises(Landed):
        trialpack.append_pack(tmp_path, {"k": '{"key": "k", "v": "new"}'})
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


# ------------------------------------------------------------------------------ a full disk
@contextlib.contextmanager
def file_size_limit(nbytes: int):
    """No file of this process may grow past ``nbytes`` while the block runs (RLIMIT_FSIZE:
    a write past it fails with EFBIG, as a full disk fails with ENOSPC)."""
    soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
    resource.setrlimit(resource.RLIMIT_FSIZE, (nbytes, hard))
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))


#: a result of some 40 kB (a pack is not compressed; the hashes would not compress anyway)
BIG = {"rows": [{"i": i, "hash": hashlib.sha256(bytes(i)).hexdigest(), "cost": i / 7}
                for i in range(400)]}


def write_json(path, obj):
    jsonio.write_atomic(path, obj, indent=1)


def write_pack(path, obj):
    trialpack.append_pack(path.parent, {"k": json.dumps({"key": "k", **obj})})


def write_in_pieces(path, obj):
    """A writer that wants a file name and writes in pieces (as savefig does)."""
    with atomic.writing(path) as tmp, open(tmp, "w") as f:
        for row in obj.get("rows", [obj]):
            f.write(json.dumps(row) + "\n")


def read_back(path):
    if path.name == trialpack.PACK_NAME:
        return json.loads(trialpack.read_pack(path.parent)["k"].text)
    text = path.read_text()
    return json.loads(text) if path.suffix == ".json" else [json.loads(x) for x in
                                                           text.splitlines()]


@pytest.mark.parametrize("name, write", [
    ("summary.json", write_json), (trialpack.PACK_NAME, write_pack),
    ("curves.jsonl", write_in_pieces)])
def test_a_write_past_a_file_size_limit_keeps_the_old_file_and_names_it(tmp_path, name, write):
    path = tmp_path / name
    write(path, {"old": True})
    old = read_back(path)
    with file_size_limit(4096), pytest.raises(OSError) as exc:
        write(path, BIG)
    print(exc.value)
    assert exc.value.errno == errno.EFBIG and str(path) in str(exc.value)
    assert read_back(path) == old                         # the old file, whole
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]     # no temporary file left
    write(path, BIG)                                      # room again: the new file
    assert read_back(path) != old


def test_a_failed_fsync_keeps_the_old_file_and_names_it(tmp_path, monkeypatch):
    """The bytes reach the disk before the rename: fsync is called, and its error (a full
    disk may only show there) leaves the old file."""
    path = tmp_path / "a.json"
    jsonio.write_atomic(path, {"v": "old"})

    def full(fd):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(atomic.os, "fsync", full)
    with pytest.raises(OSError, match="No space left on device") as exc:
        jsonio.write_atomic(path, {"v": "new"})
    assert exc.value.errno == errno.ENOSPC and exc.value.filename == str(path)
    assert json.loads(path.read_text()) == {"v": "old"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.json"]


def test_a_new_file_gets_the_usual_permissions_and_a_replaced_one_keeps_its_own(tmp_path):
    mask = os.umask(0o022)
    os.umask(mask)
    path = tmp_path / "a.json"
    jsonio.write_atomic(path, {"v": 1})
    assert stat.S_IMODE(path.stat().st_mode) == 0o666 & ~mask     # not mkstemp's 0600
    path.chmod(0o640)
    jsonio.write_atomic(path, {"v": 2})
    assert stat.S_IMODE(path.stat().st_mode) == 0o640
