"""dopt.blowup.captures_of and dopt.lab.console.print_captures: the blow-up captures of a run's
trials, listed for its summary and named on the console; dopt.blowup.retire_captures moves a
rerun trial's old ones aside (a pick-and-place run listing the captures of its flagged plans:
tests/planners/pick_place/experiments/test_blowup_captures.py)."""

import json

import mujoco
import numpy as np

from dopt.blowup import capture_dir, captures_of, list_captures, retire_captures, save_blowup
from dopt.lab.console import print_captures

BALL = ("<mujoco><worldbody><body name='ball'><freejoint/><geom size='.1'/></body>"
        "</worldbody></mujoco>")


def capture(out, label, step=3):
    model = mujoco.MjModel.from_xml_string(BALL)
    ns = mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_INTEGRATION)
    return save_blowup(capture_dir(out, label), model, np.zeros((2, ns)), step,
                       "speed 9 m/s > 5 m/s (body ball)", label=label)


def test_the_run_names_its_trials_captures_and_a_rerun_retires_them(tmp_path, capsys):
    capture(tmp_path, "clutter-seed0")
    capture(tmp_path, "clutter-seed0", step=7)           # a second failure: its own folder
    capture(tmp_path, "another-run")
    (tmp_path / "blowups" / "broken").mkdir()
    (tmp_path / "blowups" / "broken" / "blowup.json").write_text("{")
    found = print_captures(tmp_path, captures_of(tmp_path, ["clutter-seed0", "clutter-seed1"]))
    assert found == [
        {"trial": "clutter-seed0", "path": "blowups/clutter-seed0", "step": 3,
         "reason": "speed 9 m/s > 5 m/s (body ball)", "body": "ball"},
        {"trial": "clutter-seed0", "path": "blowups/clutter-seed0-2", "step": 7,
         "reason": "speed 9 m/s > 5 m/s (body ball)", "body": "ball"}]
    json.dumps(found)
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 2 and lines[0].startswith(
        f"blow-up capture {tmp_path / 'blowups' / 'clutter-seed0'}: trial clutter-seed0, "
        "step 3, speed 9 m/s")
    moved = retire_captures(tmp_path, ["clutter-seed0"])
    assert moved == [tmp_path / "blowups" / "outdated" / n
                     for n in ("clutter-seed0", "clutter-seed0-2")]
    assert [c["label"] for c in list_captures(tmp_path)] == ["another-run"]
    assert sorted(p.name for p in (tmp_path / "blowups" / "outdated").iterdir()) == [
        "clutter-seed0", "clutter-seed0-2"]
    assert captures_of(tmp_path, ["clutter-seed0"]) == []
    capture(tmp_path, "clutter-seed0")                   # run again and failed again
    assert retire_captures(tmp_path, ["clutter-seed0"]) == [
        tmp_path / "blowups" / "outdated" / "clutter-seed0-3"]         # none overwritten
