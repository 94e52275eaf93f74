"""Blow-up captures of MPC's executed episode (``dopt.mpc.MPC(blowup_out=...)``): a violent
control writes OUT/blowups/<label> at the step the stability verdict flags, and the viewer
opens it there with the offending body marked; a stable episode writes none."""

import json
import pickle

import mujoco
import numpy as np
import pytest

from dopt import Scene
from dopt.errors import UnstableRolloutError
from dopt.mpc import MPC, MPCConfig, Plan

#: two sliders, the first driven by a motor (limited to +-1e5 N, or unlimited)
SLIDERS = """<mujoco><option timestep="0.005" gravity="0 0 0"/><worldbody>
  <body name="a"><joint name="ax" type="slide" axis="1 0 0" damping=".5"/>
  <geom size=".05" mass="1"/></body>
  <body name="b" pos=".11 0 0"><joint name="bx" type="slide" axis="1 0 0" damping=".5"/>
  <geom size=".05" mass=".5"/></body></worldbody>
  <actuator><motor joint="ax" {limits}/></actuator>
</mujoco>"""
LIMITED = 'ctrlrange="-100000 100000" ctrllimited="true"'
VIOLENT_STEP = 25


class Constant:
    """Keeps the plan: the agent executes the initial plan as given."""

    def optimise(self, state, plan):
        return plan


def episode(out, push: float, limits: str = LIMITED, label: str = "sliders seed 0"):
    """A synchronous episode of 30 steps executing 0 N, then ``push`` N on slider a from step
    VIOLENT_STEP on, capturing into ``out``: (scene, MPCResult)."""
    scene = Scene.from_xml(SLIDERS.format(limits=limits))
    d = mujoco.MjData(scene.model)
    mujoco.mj_forward(scene.model, d)
    U = np.zeros((40, 1))
    U[VIOLENT_STEP:] = push
    mpc = MPC(scene, Constant(), MPCConfig(timeout=30, synchronous=True),
              np.random.default_rng(0), blowup_out=out, blowup_label=label)
    return scene, mpc.run(scene.state_of(d), Plan(U))


def test_a_violent_control_is_captured_and_opens_at_the_flagged_step(tmp_path):
    from dopt.view.episode import collect

    scene, res = episode(tmp_path, -1e5)                       # 500 m/s after one step
    step = int(res.stability.step[0])
    assert res.stability.unstable[0] and step == VIOLENT_STEP
    assert "(body a)" in res.stability.reason[0]
    assert len(res.controls) == 30                          # a broken bound does not stop it
    capture = tmp_path / "blowups" / "sliders-seed-0"
    assert res.blowups == (str(capture),)
    meta = json.loads((capture / "blowup.json").read_text())
    assert meta["step"] == step and meta["reason"] == res.stability.reason[0]
    assert meta["body"] == "a" and meta["label"] == "sliders seed 0"
    rows = np.load(capture / "states.npy")
    assert meta["first_row"] == 0 and len(rows) == step + 2    # all rows up to step + 1
    lay = scene.layout
    for part in ("qpos", "qvel"):
        np.testing.assert_array_equal(rows[:, lay[part]], res.states[:step + 2, lay[part]])
    # the viewer finds it in the run folder and opens it at the state after the flagged step
    entries = collect(tmp_path)
    assert list(entries) == ["sliders-seed-0"]
    source, path = entries["sliders-seed-0"]
    ep = source.load(path)
    np.testing.assert_array_equal(ep.states[ep.start_frame][lay["qvel"]],
                                  res.states[step + 1][lay["qvel"]])
    assert "flagged" in ep.captions[ep.start_frame]
    assert ep.marked_body == scene.model.body("a").id


def test_the_capture_keeps_the_last_states_only(tmp_path, monkeypatch):
    """A ring of KEEP rows: the capture of a late failure starts KEEP - 1 rows before it."""
    import dopt.mpc

    monkeypatch.setattr(dopt.mpc, "KEEP", 10)
    _, res = episode(tmp_path, -1e5)
    meta = json.loads((tmp_path / "blowups" / "sliders-seed-0" / "blowup.json").read_text())
    assert meta["rows"] == 10 and meta["first_row"] == VIOLENT_STEP + 2 - 10
    assert meta["step"] == res.stability.step[0]


def test_a_step_that_makes_mujoco_warn_raises_with_its_capture(tmp_path):
    """An unlimited motor given 1e300 N: MuJoCo warns (bad control) and the agent raises; the
    error names the capture, written at its step with the actuator's body."""
    with pytest.raises(UnstableRolloutError) as info:
        episode(tmp_path, 1e300, limits='ctrllimited="false"')
    err = info.value
    assert err.step == VIOLENT_STEP and err.reason == "mjWARN_BADCTRL"
    assert err.capture == str(tmp_path / "blowups" / "sliders-seed-0")
    meta = json.loads((tmp_path / "blowups" / "sliders-seed-0" / "blowup.json").read_text())
    assert meta["step"] == err.step and meta["body"] == "a"
    assert meta["reason"].startswith("mjWARN_BADCTRL")


def test_a_stable_episode_or_no_folder_writes_no_capture(tmp_path):
    _, res = episode(tmp_path, 0.5)
    assert not res.stability.unstable[0] and res.blowups == ()
    assert not (tmp_path / "blowups").exists()
    _, res = episode(None, -1e5)                               # captures are opt-in
    assert res.stability.unstable[0] and res.blowups == ()


def test_a_second_failure_gets_its_own_folder(tmp_path):
    episode(tmp_path, -1e5)
    _, res = episode(tmp_path, -1e5)
    assert res.blowups == (str(tmp_path / "blowups" / "sliders-seed-0-2"),)


def test_bad_capture_arguments():
    scene = Scene.from_xml(SLIDERS.format(limits=LIMITED))
    with pytest.raises(TypeError, match="blowup_out"):
        MPC(scene, Constant(), MPCConfig(timeout=3), np.random.default_rng(0), blowup_out=3)
    with pytest.raises(TypeError, match="blowup_label"):
        MPC(scene, Constant(), MPCConfig(timeout=3), np.random.default_rng(0),
            blowup_label=None)


def test_the_capturing_trial_function_suits_the_sweeps():
    """Picklable for the pools and Ray, with the ``report`` parameter the sweep looks for."""
    from dopt.lab.sweep import takes_checkpoint, takes_report
    from planners.svr_mpc import CapturingTrial

    fn = pickle.loads(pickle.dumps(CapturingTrial("out")))
    assert fn == CapturingTrial("out")
    assert takes_report(fn) and not takes_checkpoint(fn)
