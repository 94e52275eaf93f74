"""Resumable sweeps: inline, process pool, Ray, a killed sweep that resumes, bad trial files
(named, moved aside, recomputed) and the code rule of a resume (here with the commit named by
DOPT_GIT_COMMIT; tests/dopt/lab/test_reuse_rule.py asks a real temporary git repository)."""

import json
import logging
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

import dopt
from dopt.lab.provenance import COMMIT_ENV, code_version
from dopt.lab.sweep import (
    Checkpoint,
    Trial,
    check_record,
    is_finished,
    load_finished,
    run_sweep,
    takes_checkpoint,
)
from tests.dopt.lab.sweep_trials import count, square


def not_json(params):
    return {"y": object()}

HERE = Path(__file__).parent


def trials(xs, **extra):
    return [Trial(f"x{x}", dict(x=x, **extra)) for x in xs]


def test_inline_and_skip(tmp_path):
    seen = []
    res = run_sweep(square, trials([1, 2, -1]), tmp_path, progress=lambda k, r: seen.append(k))
    assert sorted(res.ran) == ["x1", "x2"] and list(res.failed) == ["x-1"]
    assert res.records["x2"]["result"]["y"] == 4 and sorted(seen) == ["x-1", "x1", "x2"]
    again = run_sweep(square, trials([1, 2, 3]), tmp_path)
    assert again.ran == ["x3"] and sorted(again.skipped) == ["x1", "x2"]
    assert sorted(load_finished(tmp_path)) == ["x1", "x2", "x3"]


def test_process_pool(tmp_path):
    res = run_sweep(square, trials(range(4)), tmp_path, workers=2)
    assert {k: r["result"]["y"] for k, r in res.records.items()} == {
        "x0": 0, "x1": 1, "x2": 4, "x3": 9}
    assert all(r["result"]["pid"] != os.getpid() for r in res.records.values())


def test_killed_sweep_resumes_without_redoing_finished_trials(tmp_path):
    calls = tmp_path / "calls"
    calls.mkdir()
    out = tmp_path / "out"
    script = textwrap.dedent(f"""
        from dopt.lab.sweep import Trial, run_sweep
        from sweep_trials import square
        run_sweep(square, [Trial(f"x{{x}}", dict(x=x, calls={str(calls)!r}, sleep=0.4))
                           for x in range(6)], {str(out)!r})
    """)
    # sweep_trials is imported from its folder, given to the child on its PYTHONPATH
    env = {**os.environ,
           "PYTHONPATH": os.pathsep.join(filter(None, [str(HERE), os.environ.get("PYTHONPATH")]))}
    proc = subprocess.Popen([sys.executable, "-c", script], env=env)
    deadline = time.time() + 60
    while len(list((out / "trials").glob("x*.json"))) < 2 and time.time() < deadline:
        time.sleep(0.05)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    finished = {p.stem for p in (out / "trials").glob("x*.json")}
    assert 2 <= len(finished) < 6
    res = run_sweep(square, trials(range(6), calls=str(calls)), out)
    assert set(res.skipped) == finished and len(res.records) == 6
    for key in finished:   # each trial finished before the kill ran exactly once
        assert len([c for c in os.listdir(calls) if c.startswith(key[1:] + "-")]) == 1


def test_ray_local(tmp_path):
    ray = pytest.importorskip("ray")
    try:
        res = run_sweep(square, trials([2, 3]), tmp_path, ray_address="local")
    finally:
        ray.shutdown()
    assert {k: r["result"]["y"] for k, r in res.records.items()} == {"x2": 4, "x3": 9}
    assert all(r["machine"]["cpus"] >= 1 for r in res.records.values())   # the worker's


def test_bad_input(tmp_path):
    with pytest.raises(ValueError, match="unique"):
        run_sweep(square, trials([1, 1]), tmp_path)
    with pytest.raises(ValueError, match="workers"):
        run_sweep(square, trials([1]), tmp_path, workers=0)
    with pytest.raises(ValueError, match="file name"):
        Trial("a/b", {})


# ------------------------------------------------------------------ trial files on resume
COMMIT = "c0ffee"
UNKNOWN = "feedface" * 5            # a commit no repository holds
CODE = {"version": dopt.__version__, "commit": COMMIT}


@pytest.fixture
def code(monkeypatch):
    """This process's code, fixed: DOPT_GIT_COMMIT names a clean commit (as a copied tree's
    copier would), so that nothing is asked of the checkout's git."""
    monkeypatch.setenv(COMMIT_ENV, COMMIT)
    return CODE


def test_records_store_the_code_version(tmp_path, code):
    res = run_sweep(square, trials([1, 2]), tmp_path)
    assert res.commits == {"c0ffee": 2} and res.recomputed == {} and res.corrupt == {}
    rec = json.loads((tmp_path / "trials" / "x1.json").read_text())
    assert rec["code"] == CODE and rec["result"]["y"] == 1


@pytest.mark.parametrize("workers", [1, 2])
def test_records_name_the_machine_their_trial_ran_on(tmp_path, workers):
    """A CPU-time clock runs at the speed of the trial's machine: its record says which."""
    import platform
    import re
    run_sweep(square, trials([1, 2]), tmp_path, workers=workers)
    try:
        found = re.search(r"^model name\s*:\s*(.*)$", Path("/proc/cpuinfo").read_text(),
                          re.MULTILINE)
    except OSError:
        found = None
    for x in (1, 2):
        where = json.loads((tmp_path / "trials" / f"x{x}.json").read_text())["machine"]
        assert where["platform"] == platform.platform()
        assert where["cpu"] == (found.group(1).strip() if found else platform.processor())
        assert 1 <= where["cpus"] <= os.cpu_count()


def test_real_code_version_names_dopt_and_its_commit():
    v = code_version()
    assert set(v) == {"version", "commit"} and v["version"] and v["commit"]


def test_code_version_is_the_sources_not_stale_install_metadata(monkeypatch):
    """An editable install keeps the metadata version it was installed with; a sweep must
    label its trials with the version of the code that ran (dopt.__version__)."""
    import importlib.metadata

    import dopt
    from dopt.lab import provenance
    monkeypatch.setattr(importlib.metadata, "version", lambda name: "0.0.stale")
    assert code_version()["version"] == dopt.__version__ != "0.0.stale"
    assert provenance.versions()["dopt"] == dopt.__version__


@pytest.mark.parametrize("name, text, reason", [
    ("x1.json", '{"key": "x1", "params": {"x": 1}, "res', "not valid JSON"),
    ("x1.json", "", "not valid JSON"),
    ("x1.json", "[1, 2]", "a JSON list, not an object"),
    ("x1.json", '{"key": "x1", "params": {"x": 1}}', "no 'result'"),
    ("x1.json", '{"key": "x2", "params": {"x": 2}, "result": {"y": 4}}', "is not its file name"),
    ("x1.json", '{"key": "x1", "params": 3, "result": {"y": 1}}', "params are not an object"),
    ("x1.json", b'\xff\xfe{"key"', "unreadable"),
    ("notes.json", '{"a": 1}', "no 'key', 'params', 'result'"),
])
def test_a_bad_trial_file_is_named_moved_aside_and_recomputed(tmp_path, code, caplog, name,
                                                              text, reason):
    folder = tmp_path / "trials"
    folder.mkdir()
    if isinstance(text, bytes):
        (folder / name).write_bytes(text)
    else:
        (folder / name).write_text(text)
    (folder / ".tmp-abc.json").write_text('{"trunc')     # a write that was killed: left alone
    with caplog.at_level(logging.WARNING, logger="dopt.lab.sweep"):
        res = run_sweep(square, trials([1, 2]), tmp_path)
    assert list(res.corrupt) == [name] and reason in res.corrupt[name]
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warnings) == 1 and str(folder / name) in warnings[0] and reason in warnings[0]
    assert (folder / "corrupt" / name).read_bytes() == (
        text if isinstance(text, bytes) else text.encode())        # moved, not deleted
    assert sorted(res.ran) == ["x1", "x2"] and res.failed == {}
    if name == "x1.json":
        assert res.recomputed == {"x1": f"corrupt trial file: {res.corrupt[name]}"}
    assert check_record(folder / "x1.json")[1] is None             # the recomputed record
    assert (folder / ".tmp-abc.json").exists() and not (folder / "notes.json").exists()
    # a second corrupt file of the same name does not overwrite the first one moved aside
    (folder / "x1.json").write_text("{")
    assert load_finished(tmp_path).keys() == {"x2"}
    assert (folder / "corrupt" / "x1.1.json").exists() or name != "x1.json"


def test_load_finished_never_raises_on_garbage(tmp_path, code):
    folder = tmp_path / "trials"
    folder.mkdir()
    for i, text in enumerate(["{", "null", "42", '"s"', '{"key": 1}', "\x00\x01"]):
        (folder / f"g{i}.json").write_text(text)
    (folder / "sub.json").mkdir()                      # a folder named like a trial file
    assert load_finished(tmp_path) == {}
    assert len(list((folder / "corrupt").glob("*.json"))) == 6       # each with its reason
    assert len(list((folder / "corrupt").glob("*.reason.txt"))) == 6


def _record(tmp_path, key, x, code=None):
    rec = {"key": key, "params": {"x": x}, "result": {"y": -1}}
    if code is not None:
        rec["code"] = code
    path = tmp_path / "trials" / f"{key}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(rec))
    return path


def test_resume_reuses_only_what_git_says_is_the_same_code(tmp_path, code, caplog):
    """The dopt version decides nothing; a commit git does not know and a "-dirty" record are
    recomputed (moved aside unchanged), this commit's reused; a record without the code stamp
    (an older format) is not a record: moved to corrupt/ and recomputed."""
    _record(tmp_path, "x1", 1, {"version": "0.9.0", "commit": COMMIT})      # another version
    _record(tmp_path, "x2", 2, {"version": "1.0.0", "commit": UNKNOWN})    # unknown commit
    _record(tmp_path, "x3", 3)                                               # before "code"
    _record(tmp_path, "x4", 4, {"version": "1.0.0", "commit": COMMIT + "-dirty",
                                "tree": "0123"})                             # uncommitted
    with caplog.at_level(logging.WARNING, logger="dopt.lab.sweep"):
        res = run_sweep(square, trials([1, 2, 3, 4, 5]), tmp_path)
    assert sorted(res.ran) == ["x2", "x3", "x4", "x5"] and res.skipped == ["x1"]
    assert res.recomputed == {
        "x2": "its commit feedfacefeed is unknown to git here",
        "x3": "corrupt trial file: not a trial record of this format (no 'code' stamp: "
              "written before records named the code that wrote them)",
        "x4": "written from uncommitted code (c0ffee-dirty)"}
    assert list(res.corrupt) == ["x3.json"]
    assert "x2" in caplog.text and "unknown to git" in caplog.text
    assert res.records["x1"]["result"]["y"] == -1 and res.records["x2"]["result"]["y"] == 4
    assert res.commits == {COMMIT: 5} and res.reused_across == {}
    old = json.loads((tmp_path / "trials" / "outdated" / "x4.json").read_text())
    assert old["code"] == {"version": "1.0.0", "commit": "c0ffee-dirty", "tree": "0123"}


def test_reuse_any_reuses_every_valid_record_and_lists_it(tmp_path, code, caplog):
    from dopt.lab.sweep import take_deliberate_reuse
    take_deliberate_reuse()
    _record(tmp_path, "x1", 1, {"version": "1.0.0", "commit": "beef-dirty"})
    _record(tmp_path, "x2", 2, CODE)
    with caplog.at_level(logging.WARNING, logger="dopt.lab.sweep"):
        res = run_sweep(square, trials([1, 2, 3]), tmp_path, reuse="any")
    assert res.ran == ["x3"] and sorted(res.skipped) == ["x1", "x2"]
    assert res.reused_across == {"x1": "written from uncommitted code (beef-dirty)"}
    assert res.commits == {"beef-dirty": 1, COMMIT: 2} and "reused deliberately" in caplog.text
    assert take_deliberate_reuse() == res.reused_across and take_deliberate_reuse() == {}
    assert is_finished(tmp_path, "x1", reuse="any") and not is_finished(tmp_path, "x1")
    with pytest.raises(ValueError, match="reuse must be one of same-code, any"):
        run_sweep(square, trials([1]), tmp_path, reuse="always")


def test_a_sound_record_without_a_wanted_field_is_outdated_not_corrupt(tmp_path, code, caplog):
    """A record that fits the experiment but lacks what this run wants (Schema.wanted) is
    recomputed, even when reusing across code changes, and kept under trials/outdated/."""
    from dopt.lab.sweep import Schema

    run_sweep(square, trials([1, 2]), tmp_path)
    wants = Schema(result=("y",), wanted=("pid", "z"))
    assert not is_finished(tmp_path, "x1", schema=wants)
    assert is_finished(tmp_path, "x1", schema=Schema(result=("y",), wanted=("pid",)))
    with caplog.at_level(logging.WARNING, logger="dopt.lab.sweep"):
        res = run_sweep(square, trials([1, 2]), tmp_path, schema=wants, reuse="any")
    assert sorted(res.ran) == ["x1", "x2"] and res.corrupt == {} and res.reused_across == {}
    assert res.recomputed["x1"] == "it lacks 'z' (written by a run that did not ask for them)"
    assert sorted(p.name for p in (tmp_path / "trials" / "outdated").iterdir()) == [
        "x1.json", "x2.json"]
    assert not (tmp_path / "trials" / "corrupt").exists()
    with pytest.raises(TypeError, match="Schema.wanted"):
        Schema(wanted="z")


def test_is_finished_names_the_trials_a_sweep_skips_and_reads_only(tmp_path, code):
    _record(tmp_path, "x1", 1, {"version": "0.9.0", "commit": COMMIT})    # another version
    _record(tmp_path, "x2", 2, {"version": "1.0.0", "commit": UNKNOWN})  # unknown commit
    _record(tmp_path, "x3", 3)                                             # before "code"
    (tmp_path / "trials" / "x5.json").write_text("{")                      # corrupt
    keys = [t.key for t in trials([1, 2, 3, 4, 5])]
    before = {p.name: p.read_text() for p in (tmp_path / "trials").iterdir()}
    finished = {k for k in keys if is_finished(tmp_path, k)}
    assert {p.name: p.read_text() for p in (tmp_path / "trials").iterdir()} == before
    assert finished == {"x1"}
    assert finished == set(run_sweep(square, trials([1, 2, 3, 4, 5]), tmp_path).skipped)


def test_fresh_recomputes_everything(tmp_path, code):
    run_sweep(square, trials([1, 2]), tmp_path)
    _record(tmp_path, "x2", 2, CODE)                          # a stale result of this version
    res = run_sweep(square, trials([1, 2]), tmp_path, fresh=True)
    assert sorted(res.ran) == ["x1", "x2"] and res.skipped == []
    assert res.recomputed == {"x1": "fresh sweep", "x2": "fresh sweep"}
    assert res.records["x2"]["result"]["y"] == 4
    assert sorted(p.name for p in (tmp_path / "trials" / "outdated").iterdir()) == [
        "x1.json", "x2.json"]


def test_a_failed_recompute_leaves_no_old_result(tmp_path, code):
    _record(tmp_path, "x-1", -1, {"version": "0.9.0", "commit": "old"})   # unknown commit
    res = run_sweep(square, trials([-1]), tmp_path)
    assert list(res.failed) == ["x-1"] and res.records == {}
    assert load_finished(tmp_path) == {}            # the next resume runs it again


def test_a_result_that_is_not_json_is_a_failure(tmp_path, code):
    res = run_sweep(not_json, trials([1]), tmp_path)
    assert res.records == {} and "not JSON-able" in res.failed["x1"]
    assert not (tmp_path / "trials" / "x1.json").exists()
    assert not [p for p in (tmp_path / "trials").iterdir() if p.name.startswith(".tmp")]


@pytest.mark.parametrize("workers", [1, 2])
def test_a_stopped_trial_resumes_from_its_checkpoint(tmp_path, workers):
    first = run_sweep(count, [Trial("c", {"n": 5, "stop_at": 2}), Trial("d", {"n": 1})],
                      tmp_path, workers=workers)
    assert list(first.failed) == ["c"] and first.records["d"]["result"]["runs"] == 1
    where = tmp_path / "trials" / "checkpoints" / "c.json"
    assert json.loads(where.read_text())["progress"] == {"i": 2, "runs": 1}
    assert not (tmp_path / "trials" / "checkpoints" / "d.json").exists()   # cleared when done
    res = run_sweep(count, [Trial("c", {"n": 5})], tmp_path, workers=workers)
    assert res.records["c"]["result"]["i"] == 5 and res.records["c"]["result"]["runs"] == 2
    assert not where.exists()


def test_fresh_moves_checkpoints_aside(tmp_path):
    run_sweep(count, [Trial("c", {"n": 5, "stop_at": 3})], tmp_path)
    res = run_sweep(count, [Trial("c", {"n": 5})], tmp_path, fresh=True)
    assert res.records["c"]["result"]["runs"] == 1          # started afresh
    kept = json.loads((tmp_path / "trials" / "checkpoints" / "outdated" / "c.json").read_text())
    assert kept["progress"]["i"] == 3


@pytest.mark.parametrize("text, folder, reason", [
    ("{not json", "corrupt", "not a checkpoint"),
    (json.dumps({"key": "other", "code": CODE, "progress": {}}), "corrupt",
     "the checkpoint of 'other'"),
    (json.dumps({"key": "c", "code": {"version": "0.9.0"}, "progress": {}}), "outdated",
     "written by code of no known commit (none recorded)"),
    (json.dumps({"key": "c", "code": {"version": "0.9.0", "commit": "c0ffee-dirty"},
                 "progress": {}}), "outdated", "written from uncommitted code (c0ffee-dirty)"),
    (json.dumps({"key": "c", "code": CODE, "progress": [1]}), "corrupt",
     "progress is not an object"),
])
def test_a_checkpoint_that_cannot_be_resumed_is_named_and_moved_aside(tmp_path, code, caplog,
                                                                    text, folder, reason):
    c = Checkpoint(tmp_path, "c")
    c.path.parent.mkdir(parents=True)
    c.path.write_text(text)
    with caplog.at_level(logging.WARNING, logger="dopt.lab.sweep"):
        assert c.peek() is None                      # reads only: nothing moved or logged
        assert c.path.read_text() == text and not caplog.text
        assert c.load() is None
    assert reason in caplog.text
    assert (c.path.parent / folder / "c.json").read_text() == text and not c.path.exists()
    c.save({"i": 1})
    assert c.peek() == c.load() == {"i": 1}


def test_only_functions_with_a_checkpoint_parameter_get_one(tmp_path):
    assert takes_checkpoint(count) and not takes_checkpoint(square)
    assert not takes_checkpoint(len)
    with pytest.raises(ValueError, match="not a valid file name"):
        Checkpoint(tmp_path, "../c")
