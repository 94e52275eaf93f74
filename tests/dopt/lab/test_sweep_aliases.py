"""Trials stored under an older name (``Schema.aliases``): a sweep that names its trials by the
one identity (``dopt.lab.identity``) finds a trial a folder holds under its legacy key, loose
or packed, and reuses it as stored (never renamed, never rewritten, never recomputed); a
record under the alias whose params are another trial's is not taken (and left where it is);
a checkpoint under the alias resumes."""

import json
import logging
import os
from pathlib import Path

import pytest

import dopt
from dopt.lab.identity import trial_name
from dopt.lab.provenance import COMMIT_ENV
from dopt.lab.sweep import (
    PACK_NAME,
    Schema,
    Trial,
    is_finished,
    pack_trials,
    run_sweep,
    stored_record,
)
from tests.dopt.lab.sweep_trials import count, square

COMMIT = "c0ffee"
CODE = {"version": dopt.__version__, "commit": COMMIT}
DEFAULTS = {"sleep": 0.0, "scale": 1}


def legacy(params: dict) -> tuple[str, ...]:
    """The fake experiment's older name: x<x> (what its trials were stored under before)."""
    return (f"x{params['x']}",)


def identity(params: dict) -> dict:
    return {"x": params["x"], "n": params.get("n")}


SCHEMA = Schema(result=("y",), identity=identity, aliases=legacy)


def trials(xs, calls: Path) -> list[Trial]:
    """The sweep named by the one identity (label "sq")."""
    return [Trial(trial_name("sq", x, {"x": x}, DEFAULTS), {"x": x, "calls": str(calls)})
            for x in xs]


def calls_of(folder: Path) -> list[int]:
    return sorted(int(p.name.split("-")[0]) for p in folder.iterdir())


@pytest.fixture
def code(monkeypatch):
    monkeypatch.setenv(COMMIT_ENV, COMMIT)
    return CODE


def store_legacy(out: Path, x: int, calls: Path, code: dict, y: int = -1) -> Path:
    """A record of trial x stored under its older name, as a committed one is."""
    rec = {"key": f"x{x}", "params": {"x": x, "calls": str(calls)}, "result": {"y": y},
           "code": code}
    path = out / "trials" / f"x{x}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(rec))
    return path


@pytest.mark.parametrize("packed", [False, True])
def test_a_rerun_reuses_a_trial_stored_under_its_legacy_key(tmp_path, code, packed):
    out, calls = tmp_path / "out", tmp_path / "calls"
    calls.mkdir()
    store_legacy(out, 1, calls, code)
    if packed:
        pack_trials(out)
    before = {p.name: p.read_bytes() for p in (out / "trials").iterdir()}
    wanted = trials([1, 2], calls)
    new1, new2 = (t.key for t in wanted)
    assert is_finished(out, new1, schema=SCHEMA, params=wanted[0].params)
    assert not is_finished(out, new1, schema=SCHEMA)            # without params: no alias
    assert stored_record(out, new1, SCHEMA, wanted[0].params)[0]["key"] == "x1"

    res = run_sweep(square, wanted, out, schema=SCHEMA)
    assert calls_of(calls) == [2]                         # trial 1 not recomputed
    assert res.skipped == [new1] and res.ran == [new2] and res.recomputed == {}
    assert res.records[new1]["key"] == "x1" and res.records[new1]["result"] == {"y": -1}
    assert res.stored_key(new1) == "x1" and res.stored_key(new2) == new2
    for name, data in before.items():                    # never renamed nor rewritten
        assert (out / "trials" / name).read_bytes() == data
    assert not (out / "trials" / f"{new1}.json").exists()
    assert (out / "trials" / f"{new2}.json").is_file()
    assert (PACK_NAME in before) == packed


def test_reuse_any_reuses_a_legacy_trial_of_other_code(tmp_path, code, caplog):
    """--reuse-any on a folder of older trials (the committed sweeps' resume): reused, listed
    as reused across a code change, not recomputed."""
    out, calls = tmp_path / "out", tmp_path / "calls"
    calls.mkdir()
    store_legacy(out, 1, calls, {"version": "1.0.0", "commit": "feedface" * 5})
    wanted = trials([1], calls)
    with caplog.at_level(logging.WARNING, logger="dopt.lab.sweep"):
        res = run_sweep(square, wanted, out, schema=SCHEMA, reuse="any")
    assert calls_of(calls) == [] and res.skipped == [wanted[0].key]
    assert list(res.reused_across) == [wanted[0].key]
    # the same-code rule recomputes it, and leaves the record under the alias where it is
    with caplog.at_level(logging.WARNING, logger="dopt.lab.sweep"):
        res = run_sweep(square, wanted, out, schema=SCHEMA)
    assert calls_of(calls) == [1] and res.ran == [wanted[0].key]
    assert "its record under its older name x1 stays as it is" in caplog.text
    assert (out / "trials" / "x1.json").is_file() and not (out / "trials" / "outdated").exists()
    # the new record is found under its own key first from now on
    assert stored_record(out, wanted[0].key, SCHEMA, wanted[0].params)[0]["key"] == \
        wanted[0].key


def test_a_record_under_the_alias_of_another_trial_is_not_taken(tmp_path, code):
    out, calls = tmp_path / "out", tmp_path / "calls"
    calls.mkdir()
    path = store_legacy(out, 1, calls, code)
    rec = json.loads(path.read_text())
    path.write_text(json.dumps({**rec, "params": {**rec["params"], "n": 5}}))   # another's
    wanted = trials([1], calls)
    assert not is_finished(out, wanted[0].key, schema=SCHEMA, params=wanted[0].params)
    res = run_sweep(square, wanted, out, schema=SCHEMA)
    assert calls_of(calls) == [1] and res.ran == [wanted[0].key] and res.corrupt == {}
    assert path.is_file()                                  # left where it was


def test_a_checkpoint_under_the_alias_resumes(tmp_path, code):
    out = tmp_path / "out"
    params = {"x": 1, "n": 5, "stop_at": 2}
    key = trial_name("count", 1, {"n": 5}, {})
    schema = Schema(progress=("i", "runs"), aliases=legacy)
    res = run_sweep(count, [Trial("x1", params)], out, schema=schema)   # killed at 2
    assert "x1" in res.failed
    assert (out / "trials" / "checkpoints" / "x1.json").is_file()
    res = run_sweep(count, [Trial(key, {**params, "stop_at": None})], out, schema=schema)
    assert res.ran == [key] and res.records[key]["result"]["i"] == 5
    assert res.records[key]["result"]["runs"] == 2                       # resumed, not restarted
    assert not (out / "trials" / "checkpoints" / "x1.json").exists()


def test_aliases_must_be_a_function_of_keys():
    with pytest.raises(TypeError, match="Schema.aliases"):
        Schema(aliases="x1")
    with pytest.raises(TypeError, match="tuple of keys"):
        Schema(aliases=lambda p: "x1").aliases_of({})
    assert Schema().aliases_of({"x": 1}) == () and os.sep not in legacy({"x": 1})[0]
