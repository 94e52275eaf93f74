"""The speed bound on bodies turned by hinge and ball joints: the speed of their farthest
geometry (dopt.stability's module docstring), against MuJoCo's own point velocities, and the
same verdict on every route."""

import mujoco
import numpy as np
import pytest

from dopt.rollout import RolloutConfig, RolloutService
from dopt.scene import Scene
from dopt.stability import StabilityBounds

# A link on a hinge about z whose anchor sits 0.1 m behind the body's origin, with a sphere on a
# welded (jointless) child body at its end: the farthest geometry point from the axis is the
# sphere's far side, 0.1 + 0.3 + 0.05 = 0.45 m out, where the site "far" is. A pendulum bob on
# a ball joint, its capsule's tip 0.27 m below the joint (site "bob_far"). No gravity or
# damping: a turning body keeps its speed.
SPIN = """<mujoco><option gravity="0 0 0" timestep="0.002"/><worldbody>
  <body name="link" pos="0 0 .5">
    <joint name="hinge" type="hinge" axis="0 0 1" pos="-.1 0 0"/>
    <geom type="capsule" fromto="0 0 0 .3 0 0" size=".02"/>
    <body name="tip" pos=".3 0 0">
      <geom type="sphere" size=".05"/>
      <site name="far" pos=".05 0 0"/>
    </body>
  </body>
  <body name="bob" pos="1 0 .5">
    <joint name="ball" type="ball"/>
    <geom type="capsule" fromto="0 0 0 0 0 -.25" size=".02"/>
    <site name="bob_far" pos="0 0 -.27"/>
  </body>
</worldbody><actuator><motor joint="hinge" gear="1"/></actuator></mujoco>"""
HINGE_R, BALL_R = 0.45, 0.27


def spin_scene(bounds=StabilityBounds()):
    return Scene.from_xml(SPIN, stability=bounds)


def state_with(scene, hinge=0.0, ball=(0.0, 0.0, 0.0)):
    """The start state with the hinge's angular speed and the ball's angular velocity set."""
    m = scene.model
    d = mujoco.MjData(m)
    d.qvel[scene.dofs("joint:hinge")] = hinge
    d.qvel[scene.dofs("joint:ball")] = ball
    return scene.state_of(d)


def site_speed(scene, x, site):
    """|linear velocity| of a site in state x, from mj_objectVelocity."""
    m = scene.model
    d = mujoco.MjData(m)
    mujoco.mj_setState(m, d, x, scene.layout.spec)
    mujoco.mj_forward(m, d)
    v = np.empty(6)
    mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_SITE, m.site(site).id, v, 0)
    return float(np.linalg.norm(v[3:]))


def test_spin_speed_is_the_speed_of_the_farthest_geometry():
    """Monitor.speed of a turning hinge link and ball bob equals MuJoCo's velocity of their
    farthest geometry point; the reason names the body."""
    sc = spin_scene()
    m, mon = sc.model, sc.monitor
    assert len(mon.groups) == 0
    assert [m.body(int(b)).name for b in mon.spin_body] == ["link", "bob"]
    np.testing.assert_allclose(mon.spin_radius[:, 0], [HINGE_R, BALL_R], rtol=1e-12)
    lay = sc.layout["qvel"]
    for x, site, body in [(state_with(sc, hinge=-7.0), "far", "link"),
                          (state_with(sc, ball=(3.0, -4.0, 0.0)), "bob_far", "bob")]:
        want = site_speed(sc, x, site)
        assert want > 1.0
        speed, i = mon.speed(x[None, lay])
        assert speed[0] == pytest.approx(want, rel=1e-12)
        assert mon.speed_body[i[0]] == m.body(body).id
        assert mon.reason("speed", float(speed[0]), int(i[0])).endswith(f"(body {body})")
    # both turning: the faster one is the speed, naming its body
    x = state_with(sc, hinge=2.0, ball=(0.0, 5.0, 0.0))      # 0.9 m/s and 1.35 m/s
    speed, i = mon.speed(x[None, lay])
    assert speed[0] == pytest.approx(5.0 * BALL_R) and mon.speed_body[i[0]] == m.body("bob").id


# one body on two hinges, and a ball-jointed child on it
TWO_HINGES = """<mujoco><option gravity="0 0 0"/><worldbody><body name="b" pos="0 0 1">
  <joint type="hinge" axis="0 0 1"/><joint type="hinge" axis="1 0 0" pos=".1 0 0"/>
  <geom type="box" size=".2 .05 .1" pos=".1 .1 0"/>
  <body name="c" pos=".3 0 0"><joint type="ball"/><geom type="sphere" size=".05" pos=".1 0 0"/>
  </body></body></worldbody></mujoco>"""


def test_the_farthest_geometry_bounds_every_point():
    """With two hinges on one body the bound is the sum of each joint's |w| r_j: never below
    the speed, relative to the parent, of any geometry point (sampled: the extreme points of
    the body's geom's bounding sphere, the child held still)."""
    sc = Scene.from_xml(TWO_HINGES)
    assert sc.monitor.spin_dofs.shape == (2, 2, 3)
    m = sc.model
    d = mujoco.MjData(m)
    rng = np.random.default_rng(0)
    for _ in range(20):
        d.qpos[:] = rng.uniform(-1, 1, m.nq)
        d.qvel[:] = rng.normal(0, 3, m.nv)
        d.qvel[2:] = 0.0
        mujoco.mj_forward(m, d)
        bound = sc.monitor.speed(d.qvel[None])[0][0]
        jac = np.empty((3, m.nv))
        for offset in np.vstack([np.zeros(3), np.eye(3), -np.eye(3)]):
            p = d.geom_xpos[0] + m.geom_rbound[0] * offset
            mujoco.mj_jac(m, d, jac, None, p, 1)
            assert np.linalg.norm(jac @ d.qvel) <= bound * (1 + 1e-12)


@pytest.mark.parametrize("x_kw, step, body", [
    (dict(hinge=1.5e5), 0, "link"),                  # the tip at 67 km/s from the start
    (dict(ball=(6e4, -8e4, 0.0)), 0, "bob"),         # 27 km/s
    (dict(hinge=1.0, ball=(0.0, 3.0, 0.0)), -1, None),   # 0.45 m/s, 0.81 m/s: normal
])
def test_spun_bodies_are_flagged_on_every_route(x_kw, step, body, c_kernels):
    """The open-loop rollout (chunked Batch) and the feedback loop (Batch or C) flag a spun
    hinge link or ball bob at the same step, with the same reason naming it; slowly turning
    ones are not flagged, and both routes see their speed, that of the farthest geometry."""
    sc = spin_scene()
    x0 = state_with(sc, **x_kw)
    T = 20
    u = np.zeros((1, T, 1))
    with RolloutService(sc, RolloutConfig(threads=1, c_kernels=c_kernels)) as svc:
        open_loop = svc.rollout(x0, u).stability
        fb = svc.rollout_feedback(x0, u, np.repeat(x0[None], T, 0), np.zeros((T, 1, 2)),
                                  [0]).stability
    assert open_loop.step.tolist() == fb.step.tolist() == [step]
    assert open_loop.reason == fb.reason
    np.testing.assert_allclose(fb.max_speed, open_loop.max_speed, rtol=1e-12)
    if body is None:
        assert not open_loop.unstable.any() and not fb.unstable.any()
        want = max(site_speed(sc, x0, "far"), site_speed(sc, x0, "bob_far"))
        assert open_loop.max_speed[0] == pytest.approx(want, rel=1e-9)
    else:
        from dopt.blowup import _body_of_reason
        reason = open_loop.reason[0]
        assert reason.startswith("speed") and reason.endswith(f"(body {body})"), reason
        assert _body_of_reason(sc.model, reason) == sc.model.body(body).id
        assert open_loop.max_speed[0] == pytest.approx(site_speed(sc, x0, {
            "link": "far", "bob": "bob_far"}[body]), rel=1e-6)


def test_two_hinges_and_a_ball_give_the_same_verdict_on_every_route(c_kernels):
    """Several joints on one body (summed in slot order) and one below it: the same speeds,
    step and reason on the open-loop and the feedback routes."""
    sc = Scene.from_xml(TWO_HINGES, stability=StabilityBounds(max_speed=20.0))
    d = mujoco.MjData(sc.model)
    d.qvel[:] = [30.0, -40.0, 70.0, 10.0, -20.0]
    x0 = sc.state_of(d)
    T = 30
    u = np.zeros((1, T, 0))
    with RolloutService(sc, RolloutConfig(threads=1, c_kernels=c_kernels)) as svc:
        open_loop = svc.rollout(x0, u).stability
        fb = svc.rollout_feedback(x0, u, np.repeat(x0[None], T, 0), np.zeros((T, 0, 2)),
                                  [0]).stability
    assert open_loop.unstable[0] and open_loop.reason[0].startswith("speed")
    assert fb.step.tolist() == open_loop.step.tolist() and fb.reason == open_loop.reason
    np.testing.assert_allclose(fb.max_speed, open_loop.max_speed, rtol=1e-12)


def test_a_hinge_spun_up_is_flagged_where_its_tip_passes_the_bound(c_kernels):
    """A motor spins the link up from rest: every route flags the first step after which its
    tip (|qvel| r) is past max_speed, and no step before; without torque it is not flagged."""
    sc = spin_scene()
    x0 = state_with(sc)
    T = 80
    u = np.zeros((2, T, 1))
    u[1] = 20.0
    with RolloutService(sc, RolloutConfig(threads=1, c_kernels=c_kernels)) as svc:
        res = svc.rollout(x0, u, record=("qvel",))
        fb = svc.rollout_feedback(x0, u, np.repeat(x0[None], T, 0), np.zeros((T, 1, 2)),
                                  [0]).stability
    tip = np.abs(res.records["qvel"][1, :, sc.dofs("joint:hinge")[0]]) * HINGE_R
    assert tip[-1] > 5.0
    first = int(np.argmax(tip > 5.0))
    assert 0 < first
    st = res.stability
    assert st.unstable.tolist() == [False, True] and st.step[1] == first
    assert st.reason[1].endswith("(body link)")
    assert fb.step.tolist() == st.step.tolist() and fb.reason == st.reason
    np.testing.assert_allclose(fb.max_speed, st.max_speed, rtol=1e-12)


def test_unjudged_bodies_leave_their_hinges_out():
    sc = spin_scene(StabilityBounds(unjudged_bodies=("link",)))
    assert [sc.model.body(int(b)).name for b in sc.monitor.spin_body] == ["bob"]
    speed, _ = sc.monitor.speed(state_with(sc, hinge=1e5)[None, sc.layout["qvel"]])
    assert speed[0] == 0.0
