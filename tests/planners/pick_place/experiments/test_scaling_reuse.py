"""--reuse-from of the scaling sweep (``copy_finished``): a finished trial of another folder is
copied under the name it is stored under there, its key or its older name (``Schema.aliases``),
never renamed, and only where the folder has it under neither."""

import json

from planners.pick_place.experiments.scaling import copy_finished
from planners.pick_place.experiments.sweep import SCHEMA
from planners.pick_place.scaling import scaling_trials


def _store(folder, name, trial):
    path = folder / "trials" / f"{name}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps({"key": name, "params": trial.params, "result": {},
                                "code": {"version": "0", "commit": "c0ffee"}}))
    return path


def test_copies_keep_the_name_they_are_stored_under(tmp_path):
    old, new, absent = scaling_trials("diagonal", [10], [0], ["simple", "original", "random"])
    (legacy,) = SCHEMA.aliases_of(old.params)
    source, out = tmp_path / "source", tmp_path / "out"
    _store(source, legacy, old)
    _store(source, new.key, new)
    assert copy_finished([old, new, absent], source, out) == 2
    assert sorted(p.stem for p in (out / "trials").glob("*.json")) == sorted([legacy, new.key])
    assert json.loads((out / "trials" / f"{legacy}.json").read_text())["key"] == legacy
    assert copy_finished([old, new, absent], source, out) == 0       # held: nothing again
