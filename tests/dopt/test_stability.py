"""The stability verdict: each bound against an independent computation, the same verdict on
every route, a violent pick flagged with its reason and step, normal runs not flagged."""

from dataclasses import replace

import mujoco
import numpy as np
import pytest

from dopt.rollout import RolloutConfig, RolloutService
from dopt.scene import Scene
from dopt.stability import StabilityBounds
from dopt.tasks.pick.cloth_scene import ClothSceneConfig, make_cloth
from dopt.tasks.pick.picker import CONTROL_SPEC, PickerConfig
from dopt.tasks.pick.rope_scene import RopeSceneConfig, make_rope

# a 4 x 4 sheet dropped from 0.3 m onto a tilted plane, next to a motor-driven slider
DROP = """<mujoco><option integrator="discrete" timestep="0.01" iterations="{it}"/><worldbody>
  <geom type="plane" size="2 2 .1" euler="5 0 0"/>
  <flexcomp name="sheet" type="grid" dim="2" count="4 4 1" spacing=".05 .05 .05" radius=".005"
            pos="0 0 .3" mass=".05">
    <elasticity young="2e3" poisson="0.2" thickness="1e-3" elastic2d="both"/>
  </flexcomp>
  <body name="slider" pos=".5 0 .2"><joint name="s" type="slide" axis="1 0 0"/>
    <geom type="box" size=".02 .02 .02" contype="0" conaffinity="0"/></body>
</worldbody><actuator><motor joint="s" gear="1"/></actuator></mujoco>"""


def drop_scene(bounds=StabilityBounds(), iterations=100):
    return Scene.from_xml(DROP.format(it=iterations), stability=bounds)


def test_bounds_against_direct_geometry():
    """Speed, penetration and strain of hand-set states, computed here from the definitions."""
    sc = drop_scene()
    m, mon = sc.model, sc.monitor
    d = mujoco.MjData(m)
    vert_qpos = sc.qpos_indices("vertex:5")
    d.qpos[vert_qpos] = [0.01, 0.0, -0.32]          # vertex 5 pushed below the plane
    d.qvel[sc.dofs("vertex:7")] = [3.0, 4.0, 0.0]    # |v| = 5
    d.qvel[sc.dofs("joint:s")] = [6.0]               # the slider is faster
    mujoco.mj_forward(m, d)
    speed, i = mon.speed(d.qvel[None])
    assert speed[0] == 6.0 and mon.group_body[i[0]] == m.body("slider").id
    n = np.empty(9)
    mujoco.mju_quat2Mat(n, m.geom_quat[0])
    normal = n.reshape(3, 3)[:, 2]
    depth = m.flex_radius[0] - d.flexvert_xpos @ normal
    pen, j = mon.penetration(d.flexvert_xpos[None])
    assert j[0] == 5 and pen[0] == pytest.approx(depth.max())
    edges = m.flex_edge.reshape(-1, 2)
    length = np.linalg.norm(d.flexvert_xpos[edges[:, 0]] - d.flexvert_xpos[edges[:, 1]], axis=1)
    strain, k = mon.strain(d.flexedge_length[None])
    expected = np.abs(length / m.flexedge_length0 - 1)
    assert strain[0] == pytest.approx(expected.max()) and k[0] == np.argmax(expected)
    assert 5 in edges[k[0]]


LOOSE = dict(max_speed=1e3, max_penetration=1.0, max_strain=1e3)


@pytest.mark.parametrize("bounds, name", [
    (StabilityBounds(**{**LOOSE, "max_speed": 1.5}), "speed"),
    (StabilityBounds(**{**LOOSE, "max_penetration": 2e-3}), "penetration"),
    (StabilityBounds(**{**LOOSE, "max_strain": 2e-3}), "strain"),
    (StabilityBounds(**LOOSE, max_capped_steps=3), "capped_steps"),
])
def test_same_verdict_on_every_route(bounds, name, c_kernels):
    """The open-loop rollout (chunked Batch), the lock-step Batch feedback and the C feedback
    loop flag the same step for the same reason, and agree on the extremes seen."""
    sc = drop_scene(bounds, iterations=2 if name == "capped_steps" else 100)
    x0 = sc.state_of(mujoco.MjData(sc.model))
    T = 60
    u = np.zeros((2, T, 1))
    u[1] = 0.5
    svc = RolloutService(sc, RolloutConfig(threads=2, c_kernels=c_kernels))
    open_loop = svc.rollout(x0, u).stability
    ref = np.repeat(x0[None], T, 0)
    fb = svc.rollout_feedback(x0, u, ref, np.zeros((T, 1, 2)), [0]).stability
    assert open_loop.unstable.all(), open_loop.reason
    assert all(r.startswith(name) for r in open_loop.reason), open_loop.reason
    assert fb.step.tolist() == open_loop.step.tolist()
    assert fb.reason == open_loop.reason
    for field in ("max_speed", "max_penetration", "max_strain"):
        np.testing.assert_allclose(getattr(fb, field), getattr(open_loop, field), rtol=1e-12)
    assert fb.capped_steps.tolist() == open_loop.capped_steps.tolist()


def test_chunked_rollout_equals_one_call(monkeypatch):
    """Judging chunk by chunk changes nothing: final states and records equal one call."""
    from dopt import rollout_batch
    sc = drop_scene()
    x0 = sc.state_of(mujoco.MjData(sc.model))
    u = np.random.default_rng(0).normal(size=(3, 40, 1))
    svc = RolloutService(sc, RolloutConfig(threads=2))
    whole = svc.rollout(x0, u, record=("qpos", "xpos"))
    monkeypatch.setattr(rollout_batch, "CHUNK_BYTES", 1)     # one step per call
    chunked = RolloutService(sc, RolloutConfig(threads=2)).rollout(x0, u, record=("qpos", "xpos"))
    assert np.array_equal(whole.final_states, chunked.final_states)
    for item in ("qpos", "xpos"):
        assert np.array_equal(whole.records[item], chunked.records[item])
    assert whole.stability.max_strain.tolist() == chunked.stability.max_strain.tolist()


def energy_reference(energy: np.ndarray, mass: float) -> np.ndarray:
    """Energy gain by its definition, for a rollout free from its first step: (T, 2) MuJoCo's
    potential and kinetic energy of states 0..T-1 -> (T,) J/kg, E_t - min_{s<t} E_s."""
    e = energy.sum(axis=1)
    gain = np.zeros(len(e))
    gain[1:] = (e[1:] - np.minimum.accumulate(e)[:-1]) / mass
    return gain


def test_energy_gain_is_judged_while_nothing_does_work(c_kernels):
    """The drop: once the sheet lands, its soft contacts give back some of the energy they
    took. With the slider's motor off nothing works on the system and the gain is judged
    (against its definition on MuJoCo's own energy); with the motor pushing (rollout 1) it is
    not. With the bound below the gain, every route flags the same step for it."""
    bounds = StabilityBounds(**LOOSE, max_energy_gain=1e9)
    sc = drop_scene(bounds)
    assert sc.model.opt.enableflags & mujoco.mjtEnableBit.mjENBL_ENERGY
    x0 = sc.state_of(mujoco.MjData(sc.model))
    T = 60
    u = np.zeros((2, T, 1))
    u[1] = 0.5
    with RolloutService(sc, RolloutConfig(threads=2, c_kernels=c_kernels)) as svc:
        res = svc.rollout(x0, u, record=("energy",))
    mass = sc.model.body_mass[1:].sum()
    ref = energy_reference(res.records["energy"][0], mass)
    st = res.stability
    assert ref.max() > 1e-3, "the landing should give energy back"
    assert st.max_energy_gain[0] == pytest.approx(ref.max(), rel=1e-12)
    assert st.max_energy_gain[1] == 0.0 and not st.unstable.any()

    bound = ref.max() / 2
    sc = drop_scene(StabilityBounds(**LOOSE, max_energy_gain=bound))
    with RolloutService(sc, RolloutConfig(threads=2, c_kernels=c_kernels)) as svc:
        open_loop = svc.rollout(x0, u).stability
        fb = svc.rollout_feedback(x0, u, np.repeat(x0[None], T, 0), np.zeros((T, 1, 2)),
                                  [0]).stability
    first = int(np.argmax(ref > bound))
    assert open_loop.unstable.tolist() == [True, False]
    assert open_loop.step[0] == first and open_loop.reason[0].startswith("energy gain")
    assert fb.step.tolist() == open_loop.step.tolist() and fb.reason == open_loop.reason
    np.testing.assert_allclose(fb.max_energy_gain, open_loop.max_energy_gain, rtol=1e-12)


def test_energy_window_ends_with_a_grasp_or_a_working_actuator():
    """Pick scenes judge energy; the picker's grasps end a free window, its servo does not
    (it drives only the massless picker), the rope's own flex equality does not; an actuator
    on a judged body does."""
    cloth = make_cloth(ClothSceneConfig(n=6)).scene
    mon = cloth.monitor
    assert mon.energy_judged and {"energy", "eq_active"} <= set(mon.record)
    grasps = [i for i in range(cloth.model.neq)
              if mujoco.mj_id2name(cloth.model, mujoco.mjtObj.mjOBJ_EQUALITY, i)
              .startswith("pick")]
    assert mon.window_eqs.tolist() == grasps and len(mon.working_actuators) == 0
    rope = make_rope(RopeSceneConfig(n=10, length=0.2)).scene
    flex_eqs = [i for i in range(rope.model.neq)
                if rope.model.eq_type[i] == mujoco.mjtEq.mjEQ_FLEX]
    assert flex_eqs and not set(flex_eqs) & set(rope.monitor.window_eqs.tolist())
    drop = drop_scene(StabilityBounds(max_energy_gain=1.0)).monitor
    assert drop.working_actuators.tolist() == [0] and "actuator_force" in drop.record
    eq = np.zeros((2, 3, 0), np.uint8)
    force = np.array([[[0.0], [0.0], [0.0]], [[0.0], [1e-9], [0.0]]])
    assert drop.free({"eq_active": eq, "actuator_force": force}, (2, 3)).tolist() == \
        [[True, True, True], [True, False, True]]


def test_violent_pick_is_flagged_with_reason_and_step():
    """A rope yanked up by a picker commanded to 50 m/s: finite states, no MuJoCo warning,
    but flagged by the speed bound at the first step of the move, naming a rope body."""
    picker = PickerConfig(bound=(0.1, 0.1, 0.5), speed=50.0)
    scene = make_rope(RopeSceneConfig(n=10, length=0.2), picker)
    svc = RolloutService(scene.scene, RolloutConfig(threads=1))
    U = scene.picker.encode(np.array([[4]]), np.array([[[0.0, 0.0, 0.5]]]))
    res = svc.rollout(scene.initial_state, U, control_spec=CONTROL_SPEC)
    assert np.isfinite(res.final_states).all()
    st = res.stability
    assert st.unstable[0] and st.reason[0].startswith("speed") and "rope_" in st.reason[0]
    move = scene.picker.snap_steps + scene.picker.hold_steps
    assert move <= st.step[0] < move + scene.picker.move_steps
    assert st.max_speed[0] > 5.0


# The fast preset (the soft 5e4 Pa sheet at 20 ms) stretches edges beyond 50 % under ordinary
# pick-and-place, away from the grasped particle too on the multi-stage folds
# (docs/results/physics-cloth.json): these false-positive checks fail there, which is why it
# is not the default, not a reason to loosen the bound.
STRAINED = pytest.mark.xfail(strict=True, reason="the fast cloth preset exceeds 50 % edge "
                                                 "strain (docs/RESULTS.md, physics presets)")


@pytest.mark.parametrize("goal, n, physics", [
    ("diagonal", 8, "default"), ("side", 8, "default"), ("diagonal", 12, "default"),
    ("side", 12, "default"), ("reflective", 12, "default"), ("underneath", 12, "default"),
    # the paper protocol's cloth is 20 x 20
    ("diagonal", 20, "default"), ("side", 20, "default"),
    ("diagonal", 12, "accurate"), ("side", 12, "accurate"),
    ("diagonal", 12, "fast"), ("side", 12, "fast"),
    pytest.param("reflective", 12, "fast", marks=STRAINED),
    pytest.param("underneath", 12, "fast", marks=STRAINED)])
def test_scripted_cloth_folds_are_not_flagged(goal, n, physics):
    """False positives: the scripted folds of an n x n cloth under a physics preset."""
    from planners.pick_place import PickPlaceSettings, ScriptedPlanner, make_problem, run_problem
    settings = replace(PickPlaceSettings.preset("cloth", goal, quick=True), n=n, physics=physics)
    res = run_problem(make_problem(settings), ScriptedPlanner(), method="scripted")
    assert not res.unstable, res.unstable_reason
    assert res.n_rollouts > 0 and res.n_unstable_rollouts == 0


@pytest.mark.parametrize("physics", ["default", "accurate"])
def test_rope_actions_are_not_flagged(physics):
    """False positives: bounded random pick-and-place actions on the 40-particle rope under
    a physics preset (accurate: the stiff edges and Newton of the catenary reference)."""
    scene = make_rope(RopeSceneConfig.physics(physics))
    rng = np.random.default_rng(3)
    P = 16
    U = scene.picker.encode(rng.integers(0, 40, (P, 2)), rng.uniform(-0.1, 0.1, (P, 2, 3)))
    res = RolloutService(scene.scene, RolloutConfig(threads=2)).rollout(
        scene.initial_state, U, control_spec=CONTROL_SPEC)
    assert not res.stability.unstable.any(), res.stability.reason


def grasped_cloth(strain_at_grasps: bool, max_strain: float = 1e-3):
    """A 6 x 6 cloth whose particle 14 an active picker equality holds, and the scene with
    the given strain bounds."""
    base = make_cloth(ClothSceneConfig.physics("fast", n=6))     # the soft sheet: strains
    bounds = replace(base.scene.stability, max_strain=max_strain,
                     strain_at_grasps=strain_at_grasps)
    scene = Scene(base.model, stability=bounds)
    m = base.model
    eq = next(i for i in range(m.neq) if m.eq_obj2id[i] == m.flex_vertbodyid[14])
    d = mujoco.MjData(m)
    mujoco.mj_setState(m, d, base.initial_state, mujoco.mjtState.mjSTATE_INTEGRATION)
    d.eq_active[:] = 0
    d.eq_active[eq] = 1
    return scene, scene.state_of(d), eq


def test_strain_leaves_out_the_edges_of_a_grasped_particle():
    """Monitor.strain against the definition: with particle 14 held, its edges do not count
    (unless strain_at_grasps); with no equality active, every edge counts."""
    scene, x0, eq = grasped_cloth(False)
    m, mon = scene.model, scene.monitor
    d = mujoco.MjData(m)
    mujoco.mj_setState(m, d, x0, mujoco.mjtState.mjSTATE_INTEGRATION)
    d.qpos[scene.qpos_indices("vertex:14")] += [0.0, 0.0, 0.02]     # stretch 14's edges most
    mujoco.mj_forward(m, d)
    edges = m.flex_edge
    length = np.linalg.norm(d.flexvert_xpos[edges[:, 0]] - d.flexvert_xpos[edges[:, 1]], axis=1)
    strain = np.abs(length / m.flexedge_length0 - 1)
    at14 = (edges == 14).any(axis=1)
    held, k = mon.strain(d.flexedge_length[None], d.eq_active[None])
    assert held[0] == pytest.approx(strain[~at14].max()) and not at14[k[0]]
    free, k = mon.strain(d.flexedge_length[None], np.zeros((1, m.neq), np.uint8))
    assert free[0] == pytest.approx(strain.max()) and at14[k[0]]
    every, _ = grasped_cloth(True)[0].monitor.strain(d.flexedge_length[None],
                                                     d.eq_active[None])
    assert every[0] == pytest.approx(strain.max())
    assert "eq_active" in mon.record
    every = grasped_cloth(True)[0]       # the energy bound reads eq_active too; without it:
    assert "eq_active" not in Scene(every.model, stability=replace(
        every.stability, max_energy_gain=None)).monitor.record


@pytest.mark.parametrize("strain_at_grasps", [False, True])
def test_grasp_verdict_is_the_same_on_every_route(strain_at_grasps, c_kernels):
    """With an active grasp pulling particle 14 to the picker, the open-loop Batch rollout
    and the feedback loops (Batch, C) flag the same step for the same reason."""
    scene, x0, _ = grasped_cloth(strain_at_grasps, max_strain=0.05)
    picker = make_cloth(ClothSceneConfig.physics("fast", n=6)).picker
    rows = picker.encode(np.array([[14]]), np.array([[[0.1, 0.0, 0.1]]]))[0]
    u = np.ascontiguousarray(rows[None, :, :scene.nu])     # the picker's controls, no grasp
    T = u.shape[1]                                         # switching: the grasp stays on
    with RolloutService(scene, RolloutConfig(threads=1, c_kernels=c_kernels)) as svc:
        open_loop = svc.rollout(x0, u).stability
        fb = svc.rollout_feedback(x0, u, np.repeat(x0[None], T, 0),
                                  np.zeros((T, scene.nu, 2)), [0]).stability
    assert open_loop.unstable[0], "the grasp should strain the cloth"
    assert fb.step.tolist() == open_loop.step.tolist() and fb.reason == open_loop.reason
    np.testing.assert_allclose(fb.max_strain, open_loop.max_strain, rtol=1e-12)
    # the cloth judges energy too; the grasp stays on, so no window opens on either route
    assert scene.monitor.energy_judged
    assert fb.max_energy_gain.tolist() == open_loop.max_energy_gain.tolist() == [0.0]


def test_cloth_energy_verdict_is_the_same_on_every_route(c_kernels):
    """A 6 x 6 cloth dropped from 1 cm while the picker moves without a grasp: its servo does
    no work on the cloth, so the whole drop is one free window; both routes judge the same
    gain, which the landing makes positive."""
    cloth = make_cloth(ClothSceneConfig(n=6))
    scene = cloth.scene
    x = cloth.positions(cloth.initial_state) + [0.0, 0.0, 0.01]
    x0 = cloth.with_positions(cloth.initial_state, x)
    rows = cloth.picker.encode(np.array([[14]]), np.array([[[0.1, 0.0, 0.1]]]))[0]
    u = np.ascontiguousarray(rows[None, :, :scene.nu])     # the picker's controls, no grasp
    T = u.shape[1]
    with RolloutService(scene, RolloutConfig(threads=1, c_kernels=c_kernels)) as svc:
        open_loop = svc.rollout(x0, u).stability
        fb = svc.rollout_feedback(x0, u, np.repeat(x0[None], T, 0),
                                  np.zeros((T, scene.nu, 2)), [0]).stability
    assert 0 < open_loop.max_energy_gain[0] < scene.stability.max_energy_gain
    np.testing.assert_allclose(fb.max_energy_gain, open_loop.max_energy_gain, rtol=1e-12)
    assert not open_loop.unstable.any() and not fb.unstable.any()


def test_the_picker_is_not_speed_judged():
    """The massless picker snaps onto a particle at > 5 m/s; only the cloth is judged."""
    scene = make_cloth(ClothSceneConfig(n=6))
    assert scene.scene.stability.unjudged_bodies == ("picker",)
    picker = scene.model.body("picker").id
    assert picker not in scene.scene.monitor.group_body


def test_bad_bounds():
    with pytest.raises(ValueError, match="max_speed"):
        StabilityBounds(max_speed=0)
    with pytest.raises(ValueError, match="max_energy_gain"):
        StabilityBounds(max_energy_gain=-1.0)
    with pytest.raises(ValueError, match="no body 'hand'"):
        drop_scene(StabilityBounds(unjudged_bodies=("hand",)))
    with pytest.raises(ValueError, match="on_unstable"):
        RolloutConfig(on_unstable="ignore")
