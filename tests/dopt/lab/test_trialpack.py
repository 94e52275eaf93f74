"""Packed trials (dopt.lab.trialpack, dopt.lab.sweep.pack_trials): packing keeps every record as it
was and deletes each loose file only once its line reads back the same; the same records give
the same bytes; a loose file overrides its packed record, and re-packing appends the new one
after the old line; a resume reuses packed trials without running them; a pack that cannot be
read is named with its line; the viewer lists and opens packed trials. The format itself
(append-only, the earlier gzip packs, precedence, a cut last line): test_trialpack_format.py."""

import gzip
import json
import logging
import shutil

import pytest

import dopt
from dopt.lab.provenance import COMMIT_ENV
from dopt.lab.sweep import (
    PackError,
    Schema,
    Trial,
    check_trial_files,
    is_finished,
    load_finished,
    pack_trials,
    run_sweep,
)
from dopt.lab.sweep import main as sweep_main
from dopt.lab.trialpack import (
    GZIP_PACK_NAME,
    PACK_NAME,
    pack_bytes,
    pack_path,
    read_trial_text,
    stored_trials,
)
from tests.dopt.lab.sweep_trials import square

COMMIT = "c0ffee"
CODE = {"version": dopt.__version__, "commit": COMMIT}


@pytest.fixture(autouse=True)
def code(monkeypatch):
    """This process's code, fixed at a clean commit (tests/dopt/lab/test_sweep.py's fixture)."""
    monkeypatch.setenv(COMMIT_ENV, COMMIT)
    return CODE


def trials(xs):
    return [Trial(f"x{x}", {"x": x}) for x in xs]


def never(params):
    raise AssertionError(f"trial {params} was run again")


def swept(tmp_path, xs=(1, 2, 3)):
    """A finished sweep folder of ``xs`` (loose files), and {key: file text}."""
    run_sweep(square, trials(xs), tmp_path)
    return {p.stem: p.read_text() for p in (tmp_path / "trials").glob("*.json")}


def test_pack_then_load_gives_the_records_the_files_held(tmp_path):
    texts = swept(tmp_path)
    before = load_finished(tmp_path)
    res = pack_trials(tmp_path)
    assert sorted(res.added) == ["x1", "x2", "x3"] and res.n == 3 and res.left == {}
    assert sorted(p.name for p in (tmp_path / "trials").iterdir()) == [PACK_NAME]
    after = load_finished(tmp_path)
    assert json.dumps(after) == json.dumps(before)          # same records, same member order
    lines = pack_path(tmp_path / "trials").read_text().splitlines()
    assert lines == [texts[k] for k in sorted(texts)]        # each line is its file's text
    assert [t.name for t in stored_trials(tmp_path / "trials")] == ["x1.json", "x2.json",
                                                                    "x3.json"]
    assert read_trial_text(tmp_path / "trials" / "x2.json") == texts["x2"]
    with pytest.raises(FileNotFoundError, match="nor packed"):
        read_trial_text(tmp_path / "trials" / "x9.json")


def test_a_bare_nan_of_an_older_file_is_packed_as_its_note(tmp_path):
    path = tmp_path / "trials" / "x1.json"
    path.parent.mkdir(parents=True)
    path.write_text(json.dumps({"key": "x1", "params": {}, "result": {"y_mean": float("nan")},
                                "code": CODE}))
    pack_trials(tmp_path)
    (line,) = pack_path(path.parent).read_text().splitlines()
    assert "NaN" not in line.replace('"NaN:', "")            # strict JSON, a note beside
    y = load_finished(tmp_path)["x1"]["result"]["y_mean"]
    assert y != y                                              # read back as NaN


def test_repacking_the_same_records_gives_the_same_bytes(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    swept(a)
    shutil.copytree(a, b)
    pack_trials(a)
    first = pack_path(a / "trials").read_bytes()
    stat = pack_path(a / "trials").stat()
    assert pack_trials(a).added == []                              # nothing to add: kept as is
    assert pack_path(a / "trials").stat().st_mtime_ns == stat.st_mtime_ns
    pack_trials(b)                                             # the same records elsewhere
    assert pack_path(b / "trials").read_bytes() == first
    lines = {"k2": '{"key": "k2"}', "k1": '{"key": "k1"}'}
    assert pack_bytes(lines) == pack_bytes(dict(reversed(lines.items())))
    with pytest.raises(ValueError, match="not one line"):
        pack_bytes({"k": '{"key":\n"k"}'})


def test_a_loose_file_overrides_its_packed_record_and_repacking_keeps_the_old_one(tmp_path):
    swept(tmp_path)
    pack_trials(tmp_path)
    pack = pack_path(tmp_path / "trials")
    first = pack.read_bytes()
    newer = {"key": "x2", "params": {"x": 2}, "result": {"y": 40}, "code": CODE}
    (tmp_path / "trials" / "x2.json").write_text(json.dumps(newer))
    assert load_finished(tmp_path)["x2"]["result"]["y"] == 40
    assert [t.packed for t in stored_trials(tmp_path / "trials")] == [True, False, True]
    res = pack_trials(tmp_path)
    assert res.added == ["x2"] and res.replaced == {"x2": f"{pack} line 2"} and res.n == 3
    assert load_finished(tmp_path)["x2"]["result"]["y"] == 40
    data = pack.read_bytes()
    assert data.startswith(first)                              # the old line stays, never rewritten
    assert [json.loads(x)["result"]["y"] for x in data[len(first):].splitlines()] == [40]
    assert not (tmp_path / "trials" / "outdated").exists()


def test_a_resume_reuses_packed_trials_without_running_them(tmp_path):
    swept(tmp_path)
    pack_trials(tmp_path)
    assert all(is_finished(tmp_path, f"x{x}") for x in (1, 2, 3))
    res = run_sweep(never, trials([1, 2, 3]), tmp_path)
    assert res.ran == [] and sorted(res.skipped) == ["x1", "x2", "x3"] and res.failed == {}
    assert res.records["x3"]["result"]["y"] == 9
    res = run_sweep(square, trials([1, 2, 3, 4]), tmp_path)   # new trials are written loose
    assert res.ran == ["x4"] and (tmp_path / "trials" / "x4.json").is_file()


def test_a_packed_record_of_other_code_or_schema_is_recomputed_and_overridden(
        tmp_path, monkeypatch, caplog):
    swept(tmp_path)
    pack_trials(tmp_path)
    packed = pack_path(tmp_path / "trials").read_bytes()
    schema = Schema(result=("z",))
    assert not is_finished(tmp_path, "x1", schema=schema)
    with caplog.at_level(logging.WARNING, logger="dopt.lab.sweep"):
        res = run_sweep(square, trials([1]), tmp_path, schema=Schema(result=("y",)),
                        fresh=True)
    assert res.ran == ["x1"] and res.recomputed == {"x1": "fresh sweep"}
    assert pack_path(tmp_path / "trials").read_bytes() == packed  # the pack is never rewritten
    monkeypatch.setenv(COMMIT_ENV, "beef")                     # other code: recomputed
    assert not is_finished(tmp_path, "x2")
    records, corrupt = check_trial_files(tmp_path, schema)      # packed: stays in the pack
    assert records == {} and set(corrupt) == {"x1.json", "x2.json", "x3.json"}
    assert "packed in pack.jsonl line 2" in corrupt["x2.json"]
    assert pack_path(tmp_path / "trials").read_bytes() == packed


def test_a_corrupt_loose_file_over_a_packed_record_gives_way_to_it(tmp_path):
    swept(tmp_path)
    pack_trials(tmp_path)
    (tmp_path / "trials" / "x1.json").write_text("{")
    assert is_finished(tmp_path, "x1")                          # reads only
    res = run_sweep(never, trials([1]), tmp_path)
    assert res.skipped == ["x1"] and res.recomputed == {} and list(res.corrupt) == ["x1.json"]
    assert (tmp_path / "trials" / "corrupt" / "x1.json").read_text() == "{"


#: (the pack's name, raw bytes, gzip them?, cut bytes off the end, what the error names); gzip
#: with mtime 0, so that every pytest-xdist worker collects the same parameters. A key twice is
#: an error only in a gzip pack (in pack.jsonl the later line replaces the earlier one), and a
#: cut pack.jsonl is a CutPackError (test_trialpack_format.py repairs it).
BAD_PACKS = {
    "not-gzip": (GZIP_PACK_NAME, b"not gzip", False, 0, r"pack\.jsonl\.gz cannot be read"),
    "bad-json": (GZIP_PACK_NAME, b'{"key": "a"}\n{"key": "b"', True, 0,
                 r"pack\.jsonl\.gz line 2: not valid JSON"),
    "not-a-record": (GZIP_PACK_NAME, b'{"key": "a"}\n[1]\n', True, 0,
                     "line 2: not a trial record"),
    "bad-key": (GZIP_PACK_NAME, b'{"key": "a"}\n{"key": "../b"}\n', True, 0,
                "line 2: its key '../b' is not a valid"),
    "twice": (GZIP_PACK_NAME, b'{"key": "a"}\n{"key": "a"}\n', True, 0,
              "line 2: key 'a' is packed twice"),
    "truncated": (GZIP_PACK_NAME, b'{"key": "a"}\n{"key": "b"}\n', True, 6, "cannot be read"),
    "jsonl-bad-json": (PACK_NAME, b'{"key": "a"}\n{"key": "b"\n', False, 0,
                       r"pack\.jsonl line 2: not valid JSON"),
    "jsonl-not-a-record": (PACK_NAME, b'{"key": "a"}\n"b"\n', False, 0,
                           "line 2: not a trial record"),
    "jsonl-bad-key": (PACK_NAME, b'{"key": ""}\n', False, 0, "line 1: its key '' is not"),
    "jsonl-not-utf8": (PACK_NAME, b'{"key": "a\xff"}\n', False, 0, "cannot be read"),
    "jsonl-cut": (PACK_NAME, b'{"key": "a"}\n{"key": "b"}\n', False, 3,
                  r"pack\.jsonl line 2 is cut short .*pack --repair"),
}


@pytest.mark.parametrize("case", list(BAD_PACKS))
def test_a_pack_that_cannot_be_read_is_named_with_its_line(tmp_path, case):
    name, raw, packed, cut, match = BAD_PACKS[case]
    content = gzip.compress(raw, mtime=0) if packed else raw
    content = content[:len(content) - cut]
    swept(tmp_path, [1])
    (tmp_path / "trials" / name).write_bytes(content)
    for read in (lambda: load_finished(tmp_path), lambda: is_finished(tmp_path, "x1"),
                 lambda: run_sweep(never, trials([1]), tmp_path),
                 lambda: pack_trials(tmp_path)):
        with pytest.raises(PackError, match=match):
            read()
    assert (tmp_path / "trials" / "x1.json").is_file()          # nothing moved or deleted
    assert (tmp_path / "trials" / name).read_bytes() == content


def test_files_that_are_not_records_are_left_loose_and_the_command_fails(tmp_path, capsys):
    swept(tmp_path, [1])
    (tmp_path / "trials" / "notes.json").write_text('{"note": "not a trial"}')
    (tmp_path / "trials" / ".tmp-x.json").write_text("{")      # a killed write: left alone
    assert sweep_main(["pack", str(tmp_path)]) == 1
    out = capsys.readouterr().out
    assert "1 trials packed" in out and "notes.json: not a trial record" in out
    assert sorted(p.name for p in (tmp_path / "trials").iterdir()) == [
        ".tmp-x.json", "notes.json", PACK_NAME]
    (tmp_path / "trials" / "notes.json").unlink()
    assert sweep_main(["pack", str(tmp_path)]) == 0
    (tmp_path / "empty").mkdir()
    assert sweep_main(["pack", str(tmp_path / "empty")]) == 1      # no trials/ folder
    assert "has no trials/ folder" in capsys.readouterr().err
    with pytest.raises(SystemExit) as usage:                      # no such folder
        sweep_main(["pack", str(tmp_path / "nowhere")])
    assert usage.value.code == 2


def test_the_viewer_lists_and_opens_packed_trials(tmp_path):
    pytest.importorskip("mujoco")
    from dopt.view.episode import candidates, collect, read_record

    swept(tmp_path)
    pack_trials(tmp_path)
    (tmp_path / "trials" / "x3.json").write_text(json.dumps(
        {"key": "x3", "params": {"x": 3}, "result": {"y": 90}, "code": CODE}))

    class Source:
        name = "test"

        def claims(self, path, record):
            return isinstance((record or {}).get("result"), dict)

    found = collect(tmp_path, [Source()])
    assert list(found) == ["x1", "x2", "x3"]
    assert [p.name for p in candidates(tmp_path / "trials")] == ["x1.json", "x2.json",
                                                                 "x3.json"]
    assert read_record(found["x2"][1])["result"]["y"] == 4      # packed
    assert read_record(found["x3"][1])["result"]["y"] == 90     # the loose file overrides it
    one = collect(tmp_path / "trials" / "x1.json", [Source()])  # one packed trial by its path
    assert list(one) == ["x1"] and not (tmp_path / "trials" / "x1.json").exists()
    with pytest.raises(FileNotFoundError):
        collect(tmp_path / "trials" / "x7.json", [Source()])
