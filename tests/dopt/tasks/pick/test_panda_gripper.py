"""The Panda with a parallel gripper executing picker plans (dopt.tasks.pick.panda_gripper):
a one-action plan ends within 2 cm of the floating picker's result, the pinch reaches the
particle, the carry tracks the picker's path, and bad inputs are named."""

import mujoco
import numpy as np
import pytest

from dopt.rollout import RolloutConfig, RolloutService
from dopt.tasks.pick.cloth_scene import ClothSceneConfig, make_cloth
from dopt.tasks.pick.panda_gripper import SNAPSHOT_SPEC, PandaConfig, PandaExecutor
from dopt.tasks.pick.picker import NONE, PickerConfig
from dopt.tasks.pick.scene import PickPlaceTask, mean_distance

N = 8


@pytest.fixture(scope="module")
def cloth():
    # the soft sheet at 20 ms the Panda's tracking bounds below were measured on
    soft = ClothSceneConfig(n=N, young=5e4, timestep=0.02, triangulation="mujoco")
    return make_cloth(soft, PickerConfig(bound=(0.3,) * 3))


@pytest.fixture(scope="module")
def arm(cloth):
    return PandaExecutor(cloth)


def _picker_final(cloth, particles, disp):
    task = PickPlaceTask(cloth, cloth.positions(cloth.initial_state),
                         rollout=RolloutService(cloth.scene, RolloutConfig(threads=1)))
    return cloth.positions(task.execute(particles, disp).state)


@pytest.mark.parametrize("particle, d", [(N * N - 1, (-0.1, -0.05, 0.02)),
                                         (0, (0.1, 0.1, 0.05)), (N - 1, (0.2, -0.1, 0.1))])
def test_a_one_action_plan_ends_within_2_cm_of_the_pickers(cloth, arm, particle, d):
    disp = np.array([d])
    done = arm.execute(cloth.initial_state, [particle], disp)
    assert done.grasp_distance[0] < arm.config.grasp_tolerance and done.missed == []
    assert done.carry_error[0] < 0.02
    assert mean_distance(done.positions, _picker_final(cloth, [particle], disp)) < 0.02


def test_the_pinch_carries_the_particle_along_the_displacement(cloth, arm):
    """While held (the snapshot right after the carry) the particle sits at p0 + d."""
    d = np.array([[-0.08, 0.05, 0.06]])
    corner = N * N - 1
    p0 = cloth.positions(cloth.initial_state)[corner]
    done = arm.execute(cloth.initial_state, [corner], d, snapshots=True)
    assert len(done.snapshots) == 4             # start, grasped, carried, released
    mujoco.mj_setState(arm.model, arm.data, done.snapshots[2], SNAPSHOT_SPEC)
    mujoco.mj_forward(arm.model, arm.data)
    assert np.linalg.norm(arm.positions()[corner] - (p0 + d[0])) < 0.01


def test_none_action_leaves_the_cloth_and_an_unknown_particle_is_named(cloth):
    arm = PandaExecutor(cloth, pickable=[0, 5])
    done = arm.execute(cloth.initial_state, [NONE], np.zeros((1, 3)))
    assert mean_distance(done.positions, cloth.positions(cloth.initial_state)) < 1e-3
    with pytest.raises(ValueError, match=r"particles \[7\]"):
        arm.execute(cloth.initial_state, [7], np.zeros((1, 3)))
    with pytest.raises(ValueError, match="displacements"):
        arm.execute(cloth.initial_state, [0, 5], np.zeros((1, 3)))


def test_bad_configs_raise(cloth):
    with pytest.raises(ValueError, match="approach"):
        PandaConfig(approach=0.0)
    with pytest.raises(TypeError, match="PandaConfig"):
        PandaExecutor(cloth, config={"base": (0, 0, 0)})
    with pytest.raises(TypeError, match="DeformableScene"):
        PandaExecutor("cloth")


def test_a_particle_out_of_reach_is_skipped_not_grasped(cloth):
    """The arm placed 1.5 m away cannot bring its pinch to the far corner: the action is
    listed as missed and the cloth stays where it was."""
    far = PandaExecutor(cloth, PandaConfig(base=(-1.5, 0.0, 0.0)))
    done = far.execute(cloth.initial_state, [N * N - 1], np.array([[-0.1, 0.0, 0.05]]))
    assert done.missed == [0] and done.grasp_distance[0] > far.config.grasp_tolerance
    assert mean_distance(done.positions, cloth.positions(cloth.initial_state)) < 2e-3


def test_the_replay_is_judged_by_the_scenes_stability_bounds(cloth):
    """A gentle plan passes the verdict; with a speed bound below what the cloth reaches while
    carried, the same replay is flagged with the bound's reason."""
    from dataclasses import replace

    d = np.array([[-0.1, -0.05, 0.02]])
    calm = PandaExecutor(cloth).execute(cloth.initial_state, [N * N - 1], d)
    assert not calm.unstable and calm.stability.max_speed[0] > 0.01
    strict = PandaExecutor(cloth)
    strict.monitor = type(strict.monitor)(strict.model, replace(cloth.scene.stability,
                                                               max_speed=0.01))
    done = strict.execute(cloth.initial_state, [N * N - 1], d)
    assert done.unstable and done.stability.reason[0].startswith("speed")


def test_a_flagged_replay_is_captured_and_opens_at_the_flagged_step(cloth, tmp_path):
    """With a speed bound the carried cloth breaks, the replay writes a blow-up capture of the
    combined model at the verdict's step, which the viewer opens there with the body the
    reason names marked; the same replay within the bounds writes none."""
    import json
    from dataclasses import replace

    from dopt.blowup import KEEP
    from dopt.view.episode import load_blowup

    d = np.array([[-0.1, -0.05, 0.02]])
    calm = PandaExecutor(cloth).execute(cloth.initial_state, [N * N - 1], d,
                                        blowup_out=tmp_path / "calm")
    assert not calm.unstable and calm.blowups == [] and not (tmp_path / "calm").exists()
    strict = PandaExecutor(cloth)
    strict.monitor = type(strict.monitor)(strict.model, replace(cloth.scene.stability,
                                                               max_speed=0.01))
    done = strict.execute(cloth.initial_state, [N * N - 1], d, blowup_out=tmp_path,
                          blowup_label="cloth seed 0")
    step = int(done.stability.step[0])
    assert done.unstable and done.blowups == [str(tmp_path / "blowups" / "cloth-seed-0")]
    meta = json.loads((tmp_path / "blowups" / "cloth-seed-0" / "blowup.json").read_text())
    assert meta["step"] == step and meta["reason"] == done.stability.reason[0]
    assert f"(body {meta['body']})" in meta["reason"]
    assert meta["rows"] == min(step + 2, KEEP) and meta["first_row"] == step + 2 - meta["rows"]
    ep = load_blowup(tmp_path / "blowups" / "cloth-seed-0")
    assert ep.start_frame == ep.n_frames - 1 and "flagged" in ep.captions[ep.start_frame]
    assert ep.marked_body == strict.model.body(meta["body"]).id


def test_a_carry_into_the_floor_stops_at_the_floor_as_the_pickers(cloth):
    """d with dz < 0 from a particle on the floor: the pinch stays at one particle radius or
    above (the picker's floor stop), so the held particle is not pressed into the floor."""
    corner = N * N - 1
    done = PandaExecutor(cloth).execute(cloth.initial_state, [corner], np.array([[-0.1, 0.0,
                                                                                  -0.1]]))
    assert not done.unstable
    assert done.stability.max_penetration[0] < 0.005
