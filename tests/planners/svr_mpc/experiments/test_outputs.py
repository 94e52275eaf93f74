"""The pictures of Table 1 say what they show (``outputs``): the push picture's goal-object
tilt against a rotation made with MuJoCo's own quaternion functions."""
import mujoco
import numpy as np
import pytest

from planners.svr_mpc.experiments import outputs


@pytest.mark.parametrize("degrees", [0.0, 20.0, 90.0, 150.0])
def test_goal_tilt_is_the_angle_of_a_rotation_about_a_horizontal_axis(degrees):
    from dopt.scene import Scene
    from planners.svr_mpc import SVRMPCSettings, trial_params

    params = trial_params(SVRMPCSettings.from_params(
        {"task": "clutter", "method": "baseline", "timeout": 5}), 0)
    settings, seed, _ = outputs.split_params(params)
    task = settings.build_task(seed)
    m = task.model
    d = mujoco.MjData(m)
    spec = Scene(m).layout.spec
    mujoco.mj_setState(m, d, task.initial_state, spec)
    joint = m.body(task.goal_object).jntadr[0]
    adr = m.jnt_qposadr[joint]
    quat = np.empty(4)
    axis = np.array([np.cos(0.7), np.sin(0.7), 0.0])          # any horizontal axis
    mujoco.mju_axisAngle2Quat(quat, axis, np.radians(degrees))
    d.qpos[adr + 3:adr + 7] = quat
    state = np.empty(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(m, d, state, spec)
    assert outputs.goal_tilt(params, state) == pytest.approx(degrees, abs=1e-6)
