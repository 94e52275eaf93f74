"""A cheaper planning model for CEM's samples (PickPlaceSettings.planning_physics): samples
run on it, executed plans and reported costs stay on the scene."""

from dataclasses import replace

import numpy as np
import pytest

from dopt.tasks.pick.cloth_scene import ClothSceneConfig, make_cloth
from dopt.tasks.pick.picker import PickerConfig
from dopt.tasks.pick.scene import PickPlaceTask
from planners.pick_place import (
    PickPlaceSettings,
    make_planner,
    make_problem,
    run_problem,
)


def cloths(n=6):
    picker = PickerConfig(bound=(0.1,) * 3)
    return (make_cloth(ClothSceneConfig.physics("default", n=n), picker),
            make_cloth(ClothSceneConfig.physics("fast", n=n), picker))


def test_evaluate_runs_on_the_planning_scene_and_execute_on_the_scene():
    scene, planning = cloths()
    goal = scene.positions(scene.initial_state)
    particles = np.array([[0], [5], [30]])
    disp = np.array([[[0.05, 0.0, 0.05]], [[0.0, 0.05, 0.02]], [[-0.05, 0.0, 0.05]]])
    both = PickPlaceTask(scene, goal, planning_scene=planning)
    alone = PickPlaceTask(planning, goal, scene.initial_state)
    own = PickPlaceTask(scene, goal)
    np.testing.assert_array_equal(both.evaluate(particles, disp), alone.evaluate(particles, disp))
    assert not np.allclose(both.evaluate(particles, disp), own.evaluate(particles, disp))
    np.testing.assert_array_equal(both.execute(particles[0], disp[0]).state,
                                  own.execute(particles[0], disp[0]).state)


def test_planning_scene_must_model_the_same_object():
    scene, _ = cloths(6)
    other, _ = cloths(7)
    with pytest.raises(ValueError, match="same object"):
        PickPlaceTask(scene, scene.positions(scene.initial_state), planning_scene=other)
    with pytest.raises(TypeError, match="planning_scene"):
        PickPlaceTask(scene, scene.positions(scene.initial_state), planning_scene="fast")
    with pytest.raises(ValueError, match="planning_physics"):
        replace(PickPlaceSettings.preset("cloth", "diagonal", quick=True),
                planning_physics="cheap")


def test_reported_costs_are_the_executed_plans_on_the_scene():
    s = replace(PickPlaceSettings.preset("cloth", "diagonal", quick=True),
                planning_physics="fast")
    problem = make_problem(s)
    assert problem.planning_scene is not None
    res = run_problem(problem, make_planner("simple", s, seed=0), method="simple")
    final = problem.scene.positions(res.final_state)
    assert res.metrics["final_cost"] == pytest.approx(
        float(np.linalg.norm(final - problem.final_goal, axis=1).mean()))
    assert res.stage_costs[-1] == pytest.approx(res.metrics["final_cost"])
    plain = make_problem(replace(s, planning_physics=None))
    assert plain.planning_scene is None
