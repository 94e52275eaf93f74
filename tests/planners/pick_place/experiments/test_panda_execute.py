"""experiments/panda_execute.py: the quick run plans, replays with the arm, summarises,
renders, resumes; bad flags are usage errors."""

import json

import pytest

from planners.pick_place.experiments import panda_execute


def test_quick_run_writes_both_goals_and_resumes(tmp_path, capsys):
    out = tmp_path / "panda"
    assert panda_execute.main(["--quick", "--out", str(out)]) == 0
    said = capsys.readouterr()
    # the console: a bar of CEM iterations, each trial's costs as it finishes, and at the end
    # the pictures
    assert "CEM iterations" in said.err and "finished diagonal-seed0" in said.out
    assert "mm, Panda " in said.out
    assert said.out.strip().splitlines()[-1] == \
        f"pictures: {out / 'panda_diagonal.png'} {out / 'panda_side.png'}"
    s = json.loads((out / "summary.json").read_text())
    assert s["experiment"] == "panda_execute" and set(s["goals"]) == {"diagonal", "side"}
    assert s["blowups"] == [] and not (out / "blowups").exists()      # stable replays
    # the settings in full: every field, and what the presets resolved to (the stale check's)
    for goal in ("diagonal", "side"):
        assert s["settings"][goal]["physics"] == "default"
        assert {"young", "timestep"} <= set(s["physics"][goal]["scene"])
        assert "max_energy_gain" in s["physics"][goal]["stability"]
    for e in s["goals"].values():
        assert e["n"] == 1 and e["picker_final_cost_ci95"] is None     # one seed: no interval
        assert e["grasp_distance_max"] < 0.01                             # the grasp tolerance
        assert e["difference_mean"] == pytest.approx(
            e["panda_final_cost_mean"] - e["picker_final_cost_mean"])
    assert (out / "panda_diagonal.png").stat().st_size > 0
    stamp = {p.name: p.stat().st_mtime_ns for p in (out / "trials").glob("*.json")}
    assert panda_execute.main(["--quick", "--out", str(out), "--no-render"]) == 0
    assert {p.name: p.stat().st_mtime_ns for p in (out / "trials").glob("*.json")} == stamp


@pytest.mark.parametrize("argv", [["--goals", "reflective"], ["--seeds", "0"],
                                  ["--seed", "-1"]])
def test_bad_flags_exit_2(tmp_path, argv, capsys):
    with pytest.raises(SystemExit) as e:
        panda_execute.main(argv + ["--out", str(tmp_path / "o")])
    assert e.value.code == 2
