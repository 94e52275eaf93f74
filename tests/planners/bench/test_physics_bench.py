"""python -m planners.bench cloth|rope at a toy size: each row says which physics it measured
(a preset row its resolved fields), and its counts are consistent with the actions run."""
from dataclasses import replace

import mujoco
import pytest

from dopt.tasks.pick.cloth_scene import PHYSICS_PRESETS
from planners.bench.physics import SETTINGS, _config, bench_physics, scripted_problem
from planners.pick_place.settings import PickPlaceSettings


def test_rows_name_their_physics_and_count_the_actions():
    out = bench_physics("cloth", [4], ["preset:fast", "preset:default"], actions=8,
                        threads=1, seed=0, scripted=False)
    fast, plain = out["rows"]
    assert fast["fields"] == PHYSICS_PRESETS["fast"]
    assert plain["fields"] == {}                     # the class defaults
    for row in out["rows"]:
        assert row["actions"] == 8 and 0 <= row["unstable_per_1000_actions"] <= 1000
        assert sum(row["reasons"].values()) == row["unstable_per_1000_actions"] * 8 / 1000
        assert 0 <= row["strain_p50"] <= row["strain_p90"] <= row["strain_max"]
    # the same seconds per action at a quarter of the step (the picker's phases round to
    # whole steps): close to four times the steps
    ratio = plain["steps_per_action"] / fast["steps_per_action"]
    assert ratio == pytest.approx(PHYSICS_PRESETS["fast"]["timestep"] / 0.005, rel=0.1)


def test_unknown_setting_is_named():
    with pytest.raises(ValueError, match="unknown cloth settings"):
        bench_physics("cloth", [4], ["E9 nothing"], actions=4, threads=1, seed=0)


def test_picker_speeds_give_a_row_each_with_the_moves_steps():
    """--picker-speeds: one row per speed, each naming it; the move phase's steps go with
    the inverse speed (ceil(|bound| sqrt 3 / speed / dt)), the other phases stay."""
    import math

    out = bench_physics("cloth", [4], ["preset:default"], actions=4, threads=1, seed=0,
                        scripted=False, picker_speeds=[None, 1.0])
    slow, fast = out["rows"]
    assert (slow["picker_speed"], fast["picker_speed"]) == (0.5, 1.0)
    move = {v: math.ceil(0.3 * math.sqrt(3) / v / 0.005) for v in (0.5, 1.0)}
    assert slow["steps_per_action"] - fast["steps_per_action"] == move[0.5] - move[1.0]


def test_a_solver_row_on_a_preset_keeps_the_presets_fields():
    """"accurate Newton": the accurate preset's fields with the solver changed, so the row
    differs from "preset:accurate" in the solver alone (and steps alike)."""
    out = bench_physics("cloth", [4], ["preset:accurate", "accurate Newton"], actions=4,
                        threads=1, seed=0, scripted=False)
    cg, newton = out["rows"]
    assert newton["fields"] == {**cg["fields"], "solver": "Newton"}
    assert cg["fields"] == PHYSICS_PRESETS["accurate"]
    assert newton["steps_per_action"] == cg["steps_per_action"]


@pytest.mark.parametrize("name", ["fast Newton", "accurate Newton", "preset:fast"])
def test_the_scripted_folds_run_the_rows_physics(name):
    """The scripted folds of a row simulate the physics its random actions do: the preset its
    "physics" key names, with its overrides (the solver) on top."""
    config = _config("cloth", name, SETTINGS["cloth"][name], 4)
    settings = replace(PickPlaceSettings.preset("cloth", "diagonal"), n=4)
    opt = scripted_problem(settings, name, SETTINGS["cloth"][name]).scene.model.opt
    solver = mujoco.mjtSolver.mjSOL_NEWTON if config.solver == "Newton" \
        else mujoco.mjtSolver.mjSOL_CG
    assert opt.solver == solver
    assert opt.timestep == pytest.approx(config.timestep)
