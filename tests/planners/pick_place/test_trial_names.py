"""A pick-and-place trial's name (``planners.pick_place.trial_names``): the one identity
against a fixed reference that no preset moves, and the committed trials still found under the
names they were written under (``legacy_trial_key``, ``Schema.aliases``), never renamed."""

import json
from dataclasses import replace
from pathlib import Path

from dopt.lab.identity import trial_name
from dopt.lab.sweep import is_finished
from dopt.lab.trialpack import stored_trials
from planners.pick_place import PickPlaceSettings, legacy_trial_key, trial_key
from planners.pick_place.experiments import panda_execute
from planners.pick_place.experiments.sweep import SCHEMA
from planners.pick_place.trial_names import reference, trial_aliases

RUNS = Path(__file__).resolve().parents[3] / "docs" / "results" / "runs"


def committed():
    """(folder, record) of every committed pick-and-place trial (loose or packed)."""
    for folder in sorted(RUNS.glob("**/trials")):
        for t in stored_trials(folder):
            record = json.loads(t.read_text())
            if "rho" not in record["params"]:
                yield folder.parent, record


def test_committed_trials_keep_their_keys_and_the_new_names_tell_them_apart():
    """Each committed trial's key is its params' name: the new one (``trial_key``; a trial
    written since the one identity) or its older name (Fig. 7, the scaling and encoding
    sweeps: ``legacy_trial_key``; the Panda's: one of ``panda_execute.trial_aliases``); the
    new names of two different trials (another identity) differ and take no older key."""
    names, older, n = {}, set(), 0
    for _, record in committed():
        p, key = record["params"], record["key"]
        settings = PickPlaceSettings.from_dict(p["settings"])
        if "goal" in p:
            name, identity = panda_execute.panda_key(p), panda_execute.trial_identity(p)
            assert key == name or key in panda_execute.trial_aliases(p)
        else:
            name = trial_key(p["method"], p["seed"], settings)
            identity = legacy_trial_key(p["method"], p["seed"], settings)
            assert key in (name, identity)
            assert trial_aliases(p) == (identity,)
        names.setdefault(name, set()).add(json.dumps(identity, sort_keys=True))
        if key != name:
            older.add(key)
        n += 1
    assert n > 400, n
    assert all(len(v) == 1 for v in names.values())
    assert not names.keys() & older


def test_a_rerun_finds_the_committed_trials_under_their_older_names():
    """What a --reuse-any resume of a committed Fig. 7 folder sees: every trial it holds is
    finished under its new name (``is_finished`` with the params: through the alias)."""
    folder = RUNS / "fig7-cloth-diagonal"
    records = [r for f, r in committed() if f == folder]
    assert records
    for r in records:
        p = r["params"]
        key = trial_key(p["method"], p["seed"], PickPlaceSettings.from_dict(p["settings"]))
        assert key != r["key"]
        assert is_finished(folder, key, reuse="any", schema=SCHEMA, params=p)
        assert not is_finished(folder, key, reuse="any", schema=SCHEMA)


def test_the_reference_is_no_preset(monkeypatch):
    """Redefining a preset changes a trial's name (its physics changed) but not the
    reference it is named against; threads and an unset option's default spelling never
    change it."""
    from dopt.tasks.pick import cloth_scene
    from planners.pick_place import presets

    before = reference("cloth")
    s = PickPlaceSettings.preset("cloth", "diagonal", protocol="paper")
    key = trial_key("simple", 0, s)
    monkeypatch.setitem(cloth_scene.PHYSICS_PRESETS, "default", {"young": 1e5})
    monkeypatch.setitem(presets.PRESETS, ("cloth", "diagonal"),
                        replace(presets.PRESETS["cloth", "diagonal"], n=9))
    assert reference("cloth") == before
    assert trial_key("simple", 0, s) != key
    monkeypatch.undo()
    assert trial_key("simple", 0, replace(s, threads=5, picker_move="fixed")) == key
    assert trial_key("original", 0, s) != key and trial_key("simple", 1, s) != key
    assert trial_key("simple", 0, replace(s, side=0.31)) != key
    assert key.startswith("simple-seed0-") and len(key.rsplit("-", 1)[1]) == 8


def test_a_setting_at_its_class_default_is_not_in_the_hash():
    """A field the settings hold at its dataclass default adds nothing: the name is that of
    the settings as a trial written before the field existed would read them."""
    s = PickPlaceSettings.preset("cloth", "side", protocol="paper")
    ident = s.identity()
    assert ident["side"] == reference("cloth")["side"]
    trimmed = {k: v for k, v in ident.items() if k not in ("side", "scripted", "length")}
    assert trial_name("simple", 0, trimmed, reference("cloth")) == trial_key("simple", 0, s)
