"""The pictures say what they show: the push picture's goal-object tilt against a rotation
made with MuJoCo's own quaternion functions, the Panda strip's panel labels against the
executor's snapshot order (start, then grasp, carry, release per executed action), and the
scaling plot's x ticks at the sizes run."""

import json
from pathlib import Path

import mujoco
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("degrees", [0.0, 20.0, 90.0, 150.0])
def test_goal_tilt_is_the_angle_of_a_rotation_about_a_horizontal_axis(degrees):
    import mpc_outputs

    from dopt.scene import Scene
    from planners.svr_mpc import SVRMPCSettings, trial_params

    params = trial_params(SVRMPCSettings(task="clutter", method="baseline", timeout=5), 0)
    settings, seed, _ = mpc_outputs.split_params(params)
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
    assert mpc_outputs.goal_tilt(params, state) == pytest.approx(degrees, abs=1e-6)


def test_strip_labels_follow_the_snapshots():
    from planners.pick_place.experiments import panda_execute

    assert panda_execute.strip_labels(1) == ["start"]
    labels = panda_execute.strip_labels(7)
    assert labels == ["start", "action 1: grasped", "action 1: carried", "action 1: released",
                      "action 2: grasped", "action 2: carried", "action 2: released"]


def test_scaling_plot_ticks_every_size(tmp_path):
    pytest.importorskip("matplotlib")
    import matplotlib.pyplot as plt

    from planners.pick_place.experiments import scaling as fig7_scaling

    record = ROOT / "docs" / "results" / "fig7-scaling-diagonal.json"
    if not record.is_file():
        pytest.skip("no committed scaling summary")
    stats = json.loads(record.read_text())
    seen = {}
    real = plt.close

    def keep(fig=None):
        seen["fig"] = fig
        real(fig)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(plt, "close", keep)
        assert fig7_scaling.plot(tmp_path / "s.png", stats, stats["goal"])
    sizes = sorted(int(k) ** 2 for k in stats["per_size"])
    for ax in seen["fig"].axes:
        assert sorted(ax.get_xticks()) == sizes
        assert [t.get_text() for t in ax.get_xticklabels()] == [str(n) for n in sizes]
        assert ax.get_xlabel() and ax.get_ylabel() and ax.get_legend() is not None
