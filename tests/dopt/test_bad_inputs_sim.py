"""Invalid or blowing-up simulations raise UnstableRolloutError with the same reason and step on
both routes (C kernels and mujoco.batch), the step being the one whose state row and control
caused it; no failure passes as a result."""
import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco's first import (dopt.render)

from types import SimpleNamespace  # noqa: E402

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from dopt.errors import UnstableRolloutError  # noqa: E402
from dopt.mpc import MPC, MPCConfig, Plan  # noqa: E402
from dopt.rollout import FDConfig, RolloutConfig, RolloutService  # noqa: E402
from dopt.scene import Scene  # noqa: E402
from tests.dopt.models import MIXED_JOINTS, moving_state  # noqa: E402

# one 0.1 kg slider, an unlimited motor, a 2 s timestep: u = 9e8 gives qacc 9e9 (< mjMAXVAL
# 1e10, no warning in that step) but leaves qvel 1.8e10 and qpos 3.6e10 behind, which MuJoCo
# only rejects at the next step; within the step, u = 5e9 gives a bad qacc (mjWARN_BADQACC)
# and u = 1e300 a bad control (mjWARN_BADCTRL, any |u| > 1e10)
SLIDER = """<mujoco><option timestep="2" gravity="0 0 0"/><worldbody>
  <body><joint name="x" type="slide" axis="1 0 0"/><geom size=".1" mass=".1"/></body></worldbody>
  <actuator><motor joint="x" ctrllimited="false"/></actuator></mujoco>"""
# a heavy slider: a control of exactly mjMAXVAL (1e10) is fine, its nudge u + eps is not
HEAVY = SLIDER.replace('timestep="2"', 'timestep=".01"').replace('mass=".1"', 'mass="1000"')


@pytest.fixture(scope="module")
def mixed():
    scene = Scene.from_xml(MIXED_JOINTS)
    x = moving_state(scene)
    svc = RolloutService(scene, RolloutConfig(threads=1, c_kernels=False))
    traj = svc.trajectory(x, np.zeros((10, scene.nu)))
    return SimpleNamespace(scene=scene, x=x, states=traj.states)


def _services(scene, c_kernels):
    return RolloutService(scene, RolloutConfig(threads=2, c_kernels=c_kernels, on_unstable="raise"))


def _raised(call) -> UnstableRolloutError:
    with pytest.raises(UnstableRolloutError) as info:
        call()
    return info.value


# ============================================================ invalid and unstable simulations
@pytest.mark.parametrize("component, value, reason", [
    ("qvel", 1e12, "mjWARN_BADQVEL"), ("qvel", -1e12, "mjWARN_BADQVEL"),
    ("qpos", 1e12, "mjWARN_BADQPOS")])
def test_invalid_state_row_raises_the_same_on_both_routes(mixed, c_kernels, component, value,
                                                          reason):
    """A state with |qvel| or |qpos| > mjMAXVAL is no state: derivatives (C loop and Batch),
    feedback and open-loop rollouts name the timestep and MuJoCo's reason, never A and B."""
    sc = mixed.scene
    states = mixed.states[:-1].copy()
    states[5, sc.layout[component].start + 1] = value
    svc = _services(sc, c_kernels)
    err = _raised(lambda: svc.derivatives(states, "robot"))
    assert (err.step, err.rollout, err.reason) == (5, 0, reason)
    assert str(err) == (f"derivatives t=5 perturbation=0: simulation 0 went unstable at step 5 "
                        f"({reason})")
    T = 4
    ref = states[:T]
    err = _raised(lambda: svc.rollout_feedback(states[5], np.zeros((2, T, sc.nu)), ref,
                                               np.zeros((T, sc.nu, 2)), [0]))
    assert (err.step, err.rollout, err.reason) == (0, 0, reason)
    err = _raised(lambda: svc.rollout(states[5], np.zeros((2, T, sc.nu))))
    assert (err.step, err.rollout, err.reason) == (0, 0, reason)


def test_nan_state_rows_are_bad_input(mixed, c_kernels):
    sc = mixed.scene
    states = mixed.states[:-1].copy()
    states[5, sc.layout["qvel"].start + 1] = np.nan
    svc = _services(sc, c_kernels)
    with pytest.raises(ValueError, match=r"states contains NaN/inf \(first at row 5"):
        svc.derivatives(states)
    with pytest.raises(ValueError, match="initial_state contains NaN/inf"):
        svc.rollout_feedback(states[5], np.zeros((1, 2, sc.nu)), states[:2],
                             np.zeros((2, sc.nu, 2)), [0])


@pytest.mark.parametrize("u, reason", [(1e300, "mjWARN_BADCTRL"), (5e9, "mjWARN_BADQACC"),
                                       (9e8, "mjWARN_BADQPOS")],
                         ids=["bad-ctrl", "bad-qacc", "bad-next-state"])
def test_unstable_step_is_the_step_whose_control_caused_it(c_kernels, u, reason):
    """Step t is the step that started from state row t with control t: a huge control at step
    7 is reported as step 7 by rollout, trajectory, rollout_feedback and derivatives, whether
    MuJoCo warns within the step or the step leaves a state it would only reject later."""
    sc = Scene.from_xml(SLIDER)
    x0 = sc.state_of(mujoco.MjData(sc.model))
    T = 12
    U = np.zeros((3, T, 1))
    U[1, 7] = u
    svc = _services(sc, c_kernels)
    for err in (_raised(lambda: svc.rollout(x0, U)),
                _raised(lambda: svc.rollout_feedback(x0, U, np.repeat(x0[None], T, 0),
                                                     np.zeros((T, 1, 2)), [0]))):
        assert (err.rollout, err.step, err.reason) == (1, 7, reason)
    err = _raised(lambda: svc.trajectory(x0, U[1]))
    assert (err.rollout, err.step, err.reason) == (0, 7, reason)
    states = np.repeat(x0[None], T, 0)
    states[7, sc.layout["ctrl"]] = u
    err = _raised(lambda: svc.derivatives(states))
    assert (err.rollout, err.step, err.reason) == (0, 7, reason)
    assert "derivatives t=7 perturbation=0" in str(err)


@pytest.mark.parametrize("centered", [False, True], ids=["forward", "centred"])
def test_a_failing_nudge_names_its_timestep_and_perturbation(c_kernels, centered):
    """Only the control nudge of timestep 2 fails: both routes name t = 2 and perturbation
    row 1 (the first control nudge), not the nominal step."""
    sc = Scene.from_xml(HEAVY)
    states = np.repeat(sc.state_of(mujoco.MjData(sc.model))[None], 4, 0)
    states[2, sc.layout["ctrl"]] = 1e10
    svc = _services(sc, c_kernels)
    svc.derivatives(states[:2], fd=FDConfig(centered=centered))
    err = _raised(lambda: svc.derivatives(states, fd=FDConfig(centered=centered)))
    assert (err.step, err.rollout, err.reason) == (2, 1, "mjWARN_BADCTRL")
    assert "derivatives t=2 perturbation=1" in str(err)


def test_mpc_agent_names_the_step_of_a_bad_control():
    sc = Scene.from_xml(SLIDER)
    x0 = sc.state_of(mujoco.MjData(sc.model))
    U = np.zeros((20, 1))
    U[7] = 1e300

    class Fixed:
        def optimise(self, state, plan):
            return plan

    mpc = MPC(sc, Fixed(), MPCConfig(timeout=15, synchronous=True, steps_per_plan=20),
              np.random.default_rng(0))
    err = _raised(lambda: mpc.run(x0, Plan(U)))
    assert (err.step, err.reason) == (7, "mjWARN_BADCTRL") and "mpc agent" in str(err)


