"""Blow-up captures of pick-and-place's executed plans (``run_problem(..., blowup_out=OUT)``):
an executed plan that the stability verdict flags (here a speed bound no moved rope or cloth
keeps, on the executed scene only, so that CEM still plans) is written to
OUT/blowups/<label>-<stage> at the step the verdict flagged in that rollout, and the viewer
opens it there with the offending body marked; CEM's samples and stable plans write none; a
rerun of a trial retires its old captures, a resumed one keeps those of its finished stages."""

import json
from dataclasses import replace

import mujoco
import numpy as np
import pytest

from dopt.rollout import RolloutConfig, RolloutService
from dopt.tasks import DeformableScene, PickPlaceTask
from dopt.tasks.pick.picker import CONTROL_SPEC
from planners.pick_place import (
    PickPlaceSettings,
    capture_label,
    make_planner,
    make_problem,
    run_problem,
    trial_key,
)
from tests.planners.checkpoints import MemoryCheckpoint, Stop

#: m/s: a particle the picker snaps onto or carries moves faster (the defaults' bound is 5)
SLOW = 0.01


def small(task: str, goal: str) -> PickPlaceSettings:
    s = PickPlaceSettings.preset(task, goal, quick=True)
    return replace(s, threads=1, cem=replace(s.cem, population=4, elites=2, iterations=1))


@pytest.fixture(scope="module")
def settings():
    return small("rope", "straighten")


@pytest.fixture(scope="module")
def problem(settings):
    return make_problem(settings, 0)


def slow_scene(scene: DeformableScene, max_speed: float = SLOW) -> DeformableScene:
    """The scene's model (the same MJCF) judged with a speed bound of ``max_speed``."""
    bounds = replace(scene.scene.stability, max_speed=max_speed)
    return DeformableScene(mujoco.MjModel.from_xml_string(scene.xml), scene.flex,
                           scene.picker.config, settle=0.0, stability=bounds, xml=scene.xml)


def slow(problem, max_speed: float = SLOW):
    """The problem with its executed scene judged by ``max_speed``; CEM plans on the
    original."""
    return replace(problem, scene=slow_scene(problem.scene, max_speed),
                   planning_scene=problem.scene)


def rerun(scene: DeformableScene, start: np.ndarray, action: dict):
    """The executed rollout of a stage's recorded action, re-run from ``start`` (ns,): its
    verdict and every state row (T + 1, ns), the start first."""
    spec = scene.scene.layout.spec
    U = scene.picker.encode(np.array(action["particles"])[None],
                            np.array(action["displacements"])[None])
    svc = RolloutService(scene.scene, RolloutConfig(threads=1))
    try:
        res = svc.rollout(start, U, control_spec=CONTROL_SPEC, record=(spec,))
    finally:
        svc.close()
    return res.stability, np.concatenate([start[None], res.records[spec][0]])


@pytest.mark.parametrize("method", ["scripted", "simple"])
def test_a_flagged_executed_plan_is_captured_at_its_flagged_step(problem, settings, tmp_path,
                                                                 method):
    from dopt.view.episode import collect

    run = slow(problem)
    res = run_problem(run, make_planner(method, settings, 0), method=method, seed=0,
                      blowup_out=tmp_path)
    stage = problem.stages[0].name
    assert res.unstable and res.blowups == [f"blowups/{method}-seed0-{stage}"]
    # the scripted policy stops at its first action, CEM's plan is executed whole: either
    # way the executed rollout starts from the problem's start
    assert method != "scripted" or len(res.actions[0]["particles"]) == 1
    verdict, states = rerun(run.scene, problem.start_state, res.actions[0])
    step = int(verdict.step[0])
    assert verdict.unstable[0] and step > 0
    capture = tmp_path / res.blowups[0]
    meta = json.loads((capture / "blowup.json").read_text())
    assert (meta["step"], meta["reason"]) == (step, verdict.reason[0])
    assert meta["label"] == f"{method}-seed0-{stage}"
    # the capture's rows are the executed rollout's, up to the state after the flagged step
    rows = np.load(capture / "states.npy")
    assert meta["first_row"] == max(0, step + 2 - len(rows)) and len(rows) <= 100
    np.testing.assert_array_equal(rows, states[meta["first_row"]:step + 2])
    model = run.scene.model
    assert f"(body {meta['body']})" in meta["reason"]
    assert meta["body_id"] in model.flex_vertbodyid                   # a rope particle
    assert (capture / "model.mjb").is_file() and (capture / "model.xml").is_file()
    # the viewer finds it in the run folder and opens it at the flagged step, body marked
    source, path = collect(tmp_path)[capture.name]
    ep = source.load(path)
    np.testing.assert_array_equal(ep.states[ep.start_frame], states[step + 1])
    assert "flagged" in ep.captions[ep.start_frame]
    assert ep.marked_body == meta["body_id"] == model.body(meta["body"]).id


def test_only_executed_sequences_are_captured(problem, tmp_path):
    """CEM's samples (``evaluate``) are flagged but never captured; an executed sequence is,
    and only where its verdict flags it."""
    stage = problem.stages[0]
    particles = np.full((3, 2), stage.keys[0])
    moves = np.tile([0.05, 0.0, 0.03], (3, 2, 1))
    for scene, flagged in ((slow_scene(problem.scene), True), (problem.scene, False)):
        svc = RolloutService(scene.scene, RolloutConfig(threads=1))
        try:
            task = PickPlaceTask(scene, stage.goal, problem.start_state, svc,
                                 blowup_out=tmp_path / str(flagged), blowup_label="rope")
            costs = task.evaluate(particles, moves)
            assert task.n_unstable == (3 if flagged else 0) and task.blowups == []
            assert np.isinf(costs).all() == flagged
            assert not (tmp_path / str(flagged)).exists()
            assert task.execute(particles[0], moves[0]).unstable == flagged
        finally:
            svc.close()
        assert task.blowups == ([str(tmp_path / "True" / "blowups" / "rope")] if flagged
                                else [])
    assert not (tmp_path / "False").exists()


def test_a_trial_names_its_captures_by_its_key_and_a_rerun_retires_them(settings, problem,
                                                                        tmp_path, monkeypatch):
    """run_trial (the sweep's) with blowup_out: a stable trial writes no capture; a flagged
    one lists OUT/blowups/<trial key>-<stage> relative to OUT; running it again moves the old
    capture to OUT/blowups/outdated/."""
    import planners.pick_place.run as run

    params = {"settings": settings.to_dict(), "method": "scripted", "seed": 0}
    calm = run.run_trial(params, blowup_out=str(tmp_path))
    assert not calm["unstable"] and calm["blowups"] == []
    assert not (tmp_path / "blowups").exists()
    assert run.run_trial(params)["blowups"] == []                        # none asked: none
    monkeypatch.setattr(run, "make_problem", lambda s, seed: slow(make_problem(s, seed)))
    label = capture_label(trial_key("scripted", 0, settings), problem.stages[0].name)
    res = run.run_trial(params, blowup_out=str(tmp_path))
    assert res["unstable"] and res["blowups"] == [f"blowups/{label}"]
    assert json.loads((tmp_path / "blowups" / label / "blowup.json").read_text())[
        "label"] == label
    assert run.run_trial(params, blowup_out=str(tmp_path))["blowups"] == [f"blowups/{label}"]
    assert (tmp_path / "blowups" / "outdated" / label / "blowup.json").is_file()
    json.dumps(res)


def test_a_resumed_trial_keeps_the_captures_of_its_finished_stages(tmp_path):
    """Stopped after its first stage (saves: the stage's iteration, its end), a two-stage
    fold resumes to the captures of the unstopped trial: the first stage's stays where it was
    written, only the stages still to run are retired."""
    s = small("cloth", "reflective")
    run = slow(make_problem(s, 0), SLOW / 10)          # flags every stage's plan
    whole = run_problem(run, make_planner("simple", s, 0), method="simple", seed=0,
                        blowup_out=tmp_path / "whole")
    names = [st.name for st in run.stages]
    assert whole.blowups == [f"blowups/simple-seed0-{n}" for n in names]
    checkpoint = MemoryCheckpoint(stop_after=2)
    with pytest.raises(Stop):
        run_problem(run, make_planner("simple", s, 0), method="simple", seed=0,
                    checkpoint=checkpoint, blowup_out=tmp_path / "stopped")
    resumed = run_problem(run, make_planner("simple", s, 0), method="simple", seed=0,
                          checkpoint=checkpoint, blowup_out=tmp_path / "stopped")
    assert resumed.segments == 2 and resumed.blowups == whole.blowups
    assert all((tmp_path / "stopped" / b / "blowup.json").is_file() for b in resumed.blowups)
    assert not (tmp_path / "stopped" / "blowups" / "outdated").exists()
    for b in whole.blowups:
        a, c = (json.loads((tmp_path / d / b / "blowup.json").read_text())
                for d in ("whole", "stopped"))
        assert (a["step"], a["reason"]) == (c["step"], c["reason"])
