"""The trial pack's format (dopt.lab.trialpack): ``pack.jsonl`` is append-only (a second pack
leaves the first file's bytes as its prefix, whatever the sequence of packs), a later line
replaces an earlier one of its key; the earlier ``pack.jsonl.gz`` files, the committed ones
included, are still read and never written; for one key a loose file overrides ``pack.jsonl``,
which overrides ``pack.jsonl.gz``; a cut last line is refused with a message that says how to
repair it, and ``pack --repair`` keeps the whole lines."""

import gzip
import json
import tempfile
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dopt.lab.sweep import PackError, load_finished, pack_trials
from dopt.lab.sweep import main as sweep_main
from dopt.lab.trialpack import (
    GZIP_PACK_NAME,
    PACK_NAME,
    CutPackError,
    pack_path,
    read_pack,
    read_trial_text,
    stored_trials,
)

ROOT = Path(__file__).resolve().parents[3]
CODE = {"version": "0", "commit": "c0ffee"}


def record(key: str, y) -> dict:
    return {"key": key, "params": {"k": key}, "result": {"y": y}, "code": CODE}


def write_loose(out: Path, records: dict) -> None:
    """Loose trial files {key: y} under out/trials/, written as a sweep would (one per key)."""
    (out / "trials").mkdir(parents=True, exist_ok=True)
    for key, y in records.items():
        (out / "trials" / f"{key}.json").write_text(json.dumps(record(key, y)))


def packed_ys(out: Path) -> dict:
    """{key: y} of every trial the folder holds, read through the one reader."""
    return {t.stem: json.loads(t.read_text())["result"]["y"]
            for t in stored_trials(out / "trials")}


def write_gzip_pack(folder: Path, records: dict) -> bytes:
    """An earlier-format pack of {key: y} (one line a record, sorted, gzip), written by hand."""
    text = "".join(json.dumps(record(k, records[k])) + "\n" for k in sorted(records))
    data = gzip.compress(text.encode(), mtime=0)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / GZIP_PACK_NAME).write_bytes(data)
    return data


#: a sweep's new loose files {key: y}: keys from a small set, so that keys recur across packs
#: (recomputed trials, or a packed record repeated unchanged)
BATCH = st.dictionaries(st.sampled_from([f"t{i}" for i in range(6)]),
                        st.one_of(st.integers(-3, 3), st.none(), st.text(max_size=3)),
                        min_size=1)


@settings(max_examples=40, deadline=None)
@given(st.lists(BATCH, min_size=1, max_size=5))
def test_every_pack_appends_and_the_last_record_of_a_key_counts(sweeps):
    with tempfile.TemporaryDirectory() as tmp:
        out, expect, before = Path(tmp), {}, b""
        for batch in sweeps:
            write_loose(out, batch)
            changed = {k for k, y in batch.items()
                       if k not in expect or json.dumps(expect[k]) != json.dumps(y)}
            replaced = {k for k in changed if k in expect}
            res = pack_trials(out)
            expect.update(batch)
            after = pack_path(out / "trials").read_bytes()
            assert after.startswith(before)                       # the old bytes, untouched
            new = [json.loads(x) for x in after[len(before):].splitlines()]
            assert [r["key"] for r in new] == sorted(changed)     # only what changed, in order
            assert sorted(res.added) == sorted(batch) and res.left == {}
            assert set(res.replaced) == replaced
            assert list((out / "trials").glob("*.json")) == []
            assert packed_ys(out) == expect and res.n == len(expect)
            before = after


def test_a_loose_file_overrides_pack_jsonl_which_overrides_the_gzip_pack(tmp_path):
    folder = tmp_path / "trials"
    gz = write_gzip_pack(folder, {"a": 1, "b": 1, "c": 1})
    (folder / PACK_NAME).write_text("".join(json.dumps(record(k, 2)) + "\n" for k in "bc"))
    write_loose(tmp_path, {"c": 3})
    assert packed_ys(tmp_path) == {"a": 1, "b": 2, "c": 3}
    packs = read_pack(folder)
    assert {k: (t.pack.name, t.line) for k, t in packs.items()} == {
        "a": (GZIP_PACK_NAME, 1), "b": (PACK_NAME, 1), "c": (PACK_NAME, 2)}
    assert json.loads(read_trial_text(folder / "a.json"))["result"]["y"] == 1
    assert read_pack(folder, names={GZIP_PACK_NAME})["c"].text == json.dumps(record("c", 1))
    jsonl = (folder / PACK_NAME).read_bytes()
    res = pack_trials(tmp_path)
    assert res.replaced == {"c": f"{folder / PACK_NAME} line 2"}
    assert (folder / GZIP_PACK_NAME).read_bytes() == gz                   # never written
    assert (folder / PACK_NAME).read_bytes() == jsonl + json.dumps(record("c", 3)).encode() + b"\n"
    assert packed_ys(tmp_path) == {"a": 1, "b": 2, "c": 3}


def test_packing_beside_a_gzip_pack_leaves_it_and_appends_only_new_records(tmp_path):
    folder = tmp_path / "trials"
    gz = write_gzip_pack(folder, {"a": 1, "b": 1})
    write_loose(tmp_path, {"a": 1, "b": 5, "d": 4})      # "a": the record the gzip pack holds
    res = pack_trials(tmp_path)
    assert res.added == ["a", "b", "d"]
    assert res.replaced == {"b": f"{folder / GZIP_PACK_NAME} line 2"}
    assert (folder / GZIP_PACK_NAME).read_bytes() == gz
    assert [json.loads(x)["key"] for x in (folder / PACK_NAME).read_text().splitlines()] == [
        "b", "d"]
    assert packed_ys(tmp_path) == {"a": 1, "b": 5, "d": 4}
    assert sorted(p.name for p in folder.iterdir()) == [PACK_NAME, GZIP_PACK_NAME]
    nothing = tmp_path / "only-gzip"
    write_gzip_pack(nothing / "trials", {"a": 1})
    res = pack_trials(nothing)                            # nothing new: no pack.jsonl made
    assert res.pack is None and res.n == 1 and not pack_path(nothing / "trials").exists()


def committed_gzip_packs(n: int) -> list[Path]:
    """The ``n`` smallest gzip packs committed under docs/results/runs/."""
    packs = sorted((ROOT / "docs" / "results" / "runs").rglob(GZIP_PACK_NAME),
                   key=lambda p: p.stat().st_size)
    if not packs:
        pytest.skip("no committed gzip pack in this checkout")
    return packs[:n]


def test_the_committed_gzip_packs_are_still_read_line_for_line():
    for pack in committed_gzip_packs(3):
        lines = gzip.decompress(pack.read_bytes()).decode().splitlines()
        got = read_pack(pack.parent)
        if (pack.parent / PACK_NAME).exists():             # a later pack overrides some keys
            got = read_pack(pack.parent, names={GZIP_PACK_NAME})
        assert {k: t.text for k, t in got.items()} == {json.loads(x)["key"]: x for x in lines}
        assert [t.line for t in got.values()] == list(range(1, len(lines) + 1))


def test_a_cut_last_line_is_refused_until_pack_repair_moves_it_aside(tmp_path, capsys):
    write_loose(tmp_path, {"a": 1, "b": 2})
    pack_trials(tmp_path)
    pack = pack_path(tmp_path / "trials")
    whole = pack.read_bytes()
    cut = json.dumps(record("c", 3)).encode()[:17]          # an append that stopped midway
    pack.write_bytes(whole + cut)
    write_loose(tmp_path, {"d": 4})
    with pytest.raises(CutPackError, match=r"line 3 is cut short.*2 lines before it are whole"):
        load_finished(tmp_path)
    assert sweep_main(["pack", str(tmp_path)]) == 1
    assert "pack --repair" in capsys.readouterr().err
    assert pack.read_bytes() == whole + cut and (tmp_path / "trials" / "d.json").is_file()
    assert sweep_main(["pack", "--repair", str(tmp_path)]) == 0
    assert "cut last line repaired" in capsys.readouterr().out
    assert pack.read_bytes().startswith(whole)
    assert (tmp_path / "trials" / "corrupt" / f"{PACK_NAME}.cut").read_bytes() == cut
    assert packed_ys(tmp_path) == {"a": 1, "b": 2, "d": 4}


def test_a_last_line_missing_only_its_newline_is_kept_by_the_repair(tmp_path):
    write_loose(tmp_path, {"a": 1, "b": 2})
    pack_trials(tmp_path)
    pack = pack_path(tmp_path / "trials")
    pack.write_bytes(pack.read_bytes()[:-1])
    with pytest.raises(CutPackError, match="line 2 is cut short"):
        stored_trials(tmp_path / "trials")
    res = pack_trials(tmp_path, repair=True)
    assert res.repaired == pack and packed_ys(tmp_path) == {"a": 1, "b": 2}
    assert not (tmp_path / "trials" / "corrupt").exists()


def test_the_repair_refuses_a_pack_with_a_bad_line_before_the_cut_one(tmp_path):
    folder = tmp_path / "trials"
    folder.mkdir()
    data = b'{"key": "a"}\n[2]\n{"key": "c'
    (folder / PACK_NAME).write_bytes(data)
    with pytest.raises(PackError, match="line 2: not a trial record"):
        pack_trials(tmp_path, repair=True)
    assert (folder / PACK_NAME).read_bytes() == data and not (folder / "corrupt").exists()
