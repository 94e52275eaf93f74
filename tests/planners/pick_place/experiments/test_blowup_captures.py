"""A pick-and-place run (rope.py, the fig7 experiment) whose executed plan the verdict flags
lists its blow-up captures in its trial file and summary.json and names them on the console
(the captures themselves: tests/dopt/test_blowup_captures.py)."""

import json

import planners.pick_place.run as run
from planners.pick_place import capture_label, make_problem
from planners.pick_place.experiments import fig7
from tests.planners.pick_place.test_pick_place_blowup import slow


def test_a_pick_place_run_names_the_captures_of_its_flagged_plans(tmp_path, monkeypatch,
                                                                  capsys):
    """rope.py (fig7.rope): a trial whose executed plan the verdict flags (its scene
    judged by a speed bound no moved rope keeps) writes OUT/blowups/<trial key>-<stage>, lists
    it in its trial file and in summary.json's "blowups", and names it on the console."""
    monkeypatch.setattr(run, "make_problem", lambda s, seed: slow(make_problem(s, seed)))
    out = tmp_path / "rope"
    assert fig7.rope(["--quick", "--methods", "scripted", "--out", str(out),
                      "--no-render"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    (trial,) = [json.loads(f.read_text()) for f in (out / "trials").glob("*.json")]
    label = capture_label(trial["key"], "rope_straighten")
    assert trial["result"]["unstable"] and trial["result"]["blowups"] == [f"blowups/{label}"]
    (found,) = summary["blowups"]
    meta = json.loads((out / "blowups" / label / "blowup.json").read_text())
    assert found == {"trial": label, "path": f"blowups/{label}", "step": meta["step"],
                     "reason": meta["reason"], "body": meta["body"]}
    assert f"blow-up capture {out / 'blowups' / label}: trial {label}, step {meta['step']}" \
        in capsys.readouterr().out
