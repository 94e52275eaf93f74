"""The shipped Panda: datasheet numbers, kinematics against the DH-generated URDF, IK, holding
still."""

import mujoco
import numpy as np
import pytest
import torch

from dopt.tasks import panda


@pytest.fixture(scope="module")
def arm():
    model = panda.arm_model()
    return model, mujoco.MjData(model)


def test_sizes_names_and_datasheet_limits(arm):
    model, _ = arm
    assert (model.nq, model.nv, model.nu) == (7, 7, 7)
    assert tuple(model.joint(i).name for i in range(model.njnt)) == panda.JOINT_NAMES
    np.testing.assert_array_equal(model.jnt_range[:, 0], panda.Q_LOWER)
    np.testing.assert_array_equal(model.jnt_range[:, 1], panda.Q_UPPER)
    assert model.jnt_limited.all()
    np.testing.assert_array_equal(model.jnt_range[3], [-3.0718, -0.0698])
    np.testing.assert_array_equal(model.jnt_range[5], [-0.0175, 3.7525])


def test_actuators_are_torque_motors_with_datasheet_limits(arm):
    model, _ = arm
    assert tuple(model.actuator(i).name for i in range(model.nu)) == panda.ACTUATOR_NAMES
    np.testing.assert_array_equal(model.actuator_trnid[:, 0], np.arange(7))
    np.testing.assert_array_equal(model.actuator_ctrlrange,
                                  np.stack([-panda.TAU_MAX, panda.TAU_MAX], axis=1))
    assert model.actuator_ctrllimited.all()
    np.testing.assert_array_equal(model.actuator_gainprm[:, 0], 1.0)
    assert (model.actuator_biastype == mujoco.mjtBias.mjBIAS_NONE).all()
    np.testing.assert_array_equal(model.actuator_gear[:, 0], 1.0)


def test_moving_bodies_are_gravity_compensated_and_damped(arm):
    model, _ = arm
    moving = [model.body(name).id for name in panda.BODY_NAMES[1:]]
    np.testing.assert_array_equal(model.body_gravcomp[moving], 1.0)
    assert (model.dof_damping > 0).all() and (model.dof_armature > 0).all()
    assert 16.0 < model.body_mass.sum() < 18.5  # identified link masses + 0.3 kg pusher


def test_zero_pose_matches_published_flange_height(arm):
    """At q = 0 the Panda stands straight: flange at (0.088, 0, 0.333 + 0.316 + 0.384 - 0.107)."""
    model, data = arm
    data.qpos[:] = 0.0
    mujoco.mj_kinematics(model, data)
    np.testing.assert_allclose(data.body("panda_pusher").xpos, [0.088, 0.0, 0.926], atol=1e-12)
    np.testing.assert_allclose(data.site(panda.EE_SITE).xpos,
                               [0.088, 0.0, 0.926 - panda.TOOL_LENGTH], atol=1e-12)


def test_shipped_urdf_is_generated_from_the_dh_table():
    assert panda.PANDA_URDF.read_text() == panda.panda_urdf()


@pytest.mark.parametrize("batch", [1, 32])
def test_torch_fk_agrees_with_mujoco(arm, batch):
    model, data = arm
    q = np.random.default_rng(batch).uniform(panda.Q_LOWER, panda.Q_UPPER, size=(batch, 7))
    chain = panda.ee_chain(dtype=torch.float64)
    assert chain.get_joint_parameter_names() == list(panda.JOINT_NAMES)
    frames = chain.forward_kinematics(torch.from_numpy(q), end_only=False)
    for b in range(batch):
        data.qpos[:] = q[b]
        mujoco.mj_kinematics(model, data)
        for link in panda.BODY_NAMES:
            pose = frames[link].get_matrix()[b].numpy()
            np.testing.assert_allclose(pose[:3, 3], data.body(link).xpos, atol=1e-6)
            np.testing.assert_allclose(pose[:3, :3], data.body(link).xmat.reshape(3, 3), atol=1e-6)
        ee = frames[panda.EE_LINK].get_matrix()[b].numpy()
        np.testing.assert_allclose(ee[:3, 3], data.site(panda.EE_SITE).xpos, atol=1e-6)
        np.testing.assert_allclose(ee[:3, :3], data.site(panda.EE_SITE).xmat.reshape(3, 3),
                                   atol=1e-6)


def test_ee_chain_honours_dtype():
    chain = panda.ee_chain(dtype=torch.float32)
    pose = chain.forward_kinematics(torch.zeros(3, 7, dtype=torch.float32)).get_matrix()
    assert pose.dtype == torch.float32 and pose.shape == (3, 4, 4)


@pytest.mark.parametrize("target", [(0.35, 0.0, 0.04), (0.45, -0.25, 0.04), (0.7, 0.2, 0.04),
                                    (0.5, 0.1, 0.3)])
def test_ik_reaches_target_with_tool_down_inside_limits(arm, target):
    model, data = arm
    q = panda.ik_pointing_down(np.array(target))
    assert np.all(q > panda.Q_LOWER) and np.all(q < panda.Q_UPPER)
    data.qpos[:] = q
    mujoco.mj_forward(model, data)
    np.testing.assert_allclose(data.site(panda.EE_SITE).xpos, target, atol=1e-5)
    np.testing.assert_allclose(data.site(panda.EE_SITE).xmat.reshape(3, 3)[:, 2], [0, 0, -1],
                               atol=1e-5)
    assert data.ncon == 0  # no self-collision in the pushing poses


def test_ik_rejects_bad_and_unreachable_targets():
    with pytest.raises(ValueError, match="finite"):
        panda.ik_pointing_down(np.array([0.4, 0.0]))
    with pytest.raises(ValueError, match="finite"):
        panda.ik_pointing_down(np.array([np.nan, 0.0, 0.1]))
    with pytest.raises(RuntimeError, match="did not reach"):
        panda.ik_pointing_down(np.array([1.5, 0.0, 0.04]))


def test_zero_torque_holds_the_arm_still(arm):
    """Gravity compensation: from rest, zero torque keeps a collision-free pose for 200 steps."""
    model, _ = arm
    data = mujoco.MjData(model)
    data.qpos[:] = panda.ik_pointing_down(np.array([0.5, 0.1, 0.2]))
    start = data.qpos.copy()
    for _ in range(200):
        mujoco.mj_step(model, data)
    np.testing.assert_allclose(data.qpos, start, atol=1e-9)


def test_table_scene_spec_rejects_bad_timestep():
    with pytest.raises(ValueError, match="timestep"):
        panda.table_scene_spec(0.0, mujoco.mjtIntegrator.mjINT_EULER)
