"""Batched rollouts against a plain mj_step loop, and their error reporting."""

import mujoco
import numpy as np
import pytest

from dopt.errors import UnstableRolloutError
from dopt.rollout import RolloutConfig, RolloutService
from dopt.rollout_batch import ctrl_bounds
from dopt.scene import Scene
from dopt.state import INTEGRATION
from tests.dopt.models import ACTUATED_ARENA, MOCAP_ARENA


def step_loop(scene, x0, u):
    """Reference: one MjData, mj_setState + mj_step per step. (P, ns), (P, T, nu) -> (P, T, ns)."""
    m = scene.model
    d = mujoco.MjData(m)
    out = np.empty(u.shape[:2] + (scene.nstate,))
    for p in range(u.shape[0]):
        mujoco.mj_setState(m, d, x0[p], INTEGRATION)
        for t in range(u.shape[1]):
            d.ctrl[:] = u[p, t]
            mujoco.mj_step(m, d)
            out[p, t] = scene.state_of(d)
    return out


@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("P", [1, 5])
def test_rollout_bitwise_equals_step_loop(scene, moving_state, threads, P):
    rng = np.random.default_rng(P)
    T = 30
    x0 = np.repeat(moving_state[None], P, axis=0)
    x0[:, scene.layout["qvel"]] += rng.normal(0, 0.1, (P, scene.nv))
    u = rng.uniform(-1, 1, (P, T, scene.nu))
    svc = RolloutService(scene, RolloutConfig(threads=threads))
    res = svc.rollout(x0, u, record=(INTEGRATION, "xpos"))
    ref = step_loop(scene, x0, u)
    np.testing.assert_array_equal(res.final_states, ref[:, -1])
    np.testing.assert_array_equal(res.records[INTEGRATION], ref)
    assert res.records["xpos"].shape == (P, T, scene.model.nbody, 3)


def test_broadcast_initial_state_and_batch_reuse(scene, moving_state):
    rng = np.random.default_rng(1)
    svc = RolloutService(scene, RolloutConfig(threads=1))
    u = rng.uniform(-1, 1, (7, 12, scene.nu))
    big = svc.rollout(moving_state, u)                   # grows the batch to 7
    small = svc.rollout(moving_state[None], u[2:4])     # reuses it for 2 rollouts
    np.testing.assert_array_equal(small.final_states, big.final_states[2:4])
    assert big.records == {}


def test_trajectory_rows_hold_their_controls(scene, moving_state):
    rng = np.random.default_rng(2)
    u = rng.uniform(-1, 1, (10, scene.nu))
    tr = RolloutService(scene).trajectory(moving_state, u)
    assert tr.states.shape == (11, scene.nstate)
    np.testing.assert_array_equal(tr.states[:-1, scene.layout["ctrl"]], u)
    # restarting from any row reproduces the rest of the trajectory exactly
    ref = step_loop(scene, tr.states[4][None], u[None, 4:])
    np.testing.assert_array_equal(ref[0, -1, scene.layout["qpos"]],
                                  tr.states[-1, scene.layout["qpos"]])


def test_unstable_rollout_is_flagged_and_spares_the_others(scene, moving_state):
    """One NaN-producing sample among good ones: the batch returns, the bad one is flagged with
    its step, the others are bit-identical to a batch without it; on_unstable="raise" names
    it instead."""
    svc = RolloutService(scene, RolloutConfig(threads=2))
    T = 20
    u = np.zeros((3, T, scene.nu))
    u[:, :, 0] = [[0.1], [0.2], [-0.3]]
    u[1, 6:, 2] = 1e300   # the ball motor is unlimited: from step 6 its torque blows up rollout 1
    res = svc.rollout(moving_state, u, record=("qpos",))
    assert res.stability.unstable.tolist() == [False, True, False]
    assert res.stability.step.tolist() == [-1, 6, -1]    # the step that applied the huge control
    assert res.stability.reason[1].startswith("mjWARN_")
    alone = svc.rollout(moving_state, u[[0, 2]], record=("qpos",))
    assert not alone.stability.unstable.any()
    assert np.array_equal(res.final_states[[0, 2]], alone.final_states)
    assert np.array_equal(res.records["qpos"][[0, 2]], alone.records["qpos"])
    strict = RolloutService(scene, RolloutConfig(threads=1, on_unstable="raise"))
    with pytest.raises(UnstableRolloutError) as info:
        strict.rollout(moving_state, u)
    err = info.value
    assert err.rollout == 1 and err.step == 6
    assert "rollout" in str(err) and "simulation 1" in str(err)


def test_eq_active_as_control(moving_state):
    """A connect equality switched on mid-rollout through the control spec (picker grasp)."""
    xml = """<mujoco><option timestep="0.01"/><worldbody><geom type="plane" size="1 1 .1"/>
      <body name="hand" mocap="true" pos="0 0 .5"><geom size=".02" contype="0"/></body>
      <body name="obj" pos="0 0 .3"><freejoint/><geom size=".03" mass=".1"/></body>
      </worldbody><equality><weld body1="hand" body2="obj" active="false"/></equality>
      </mujoco>"""
    sc = Scene.from_xml(xml)
    m = sc.model
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    spec = int(mujoco.mjtState.mjSTATE_EQ_ACTIVE)
    on = np.zeros((2, 50, 1))
    on[1] = 1.0   # rollout 1 welds the object to the hand: it does not fall
    res = RolloutService(sc).rollout(sc.state_of(d), on, control_spec=spec, record=("xpos",))
    z = res.records["xpos"][:, -1, 2, 2]
    assert z[0] < 0.05 and z[1] > 0.25


def test_bad_inputs(scene, moving_state):
    svc = RolloutService(scene)
    u = np.zeros((2, 5, scene.nu))
    with pytest.raises(ValueError, match="controls must have shape"):
        svc.rollout(moving_state, u[..., :-1])
    with pytest.raises(ValueError, match="initial_states has 3 rollouts but controls has 2"):
        svc.rollout(np.repeat(moving_state[None], 3, 0), u)
    with pytest.raises(ValueError, match="NaN"):
        svc.rollout(moving_state, np.full_like(u, np.nan))
    with pytest.raises(TypeError, match="float"):
        svc.rollout(moving_state, np.zeros((2, 5, scene.nu), dtype=object))
    bad = moving_state.copy()
    bad[3] = np.inf
    with pytest.raises(ValueError, match="NaN/inf"):
        svc.rollout(bad, u)
    with pytest.raises(ValueError, match="control_spec"):
        svc.rollout(moving_state, u, control_spec=int(mujoco.mjtState.mjSTATE_QPOS))
    with pytest.raises(TypeError, match="Scene"):
        RolloutService(scene.model)
    with pytest.raises(ValueError, match="threads"):
        RolloutConfig(threads=-1)


def feedback_loop(scene, x0, ff, ref, K, dofs, lo, hi):
    """Reference: one MjData, u = clip(ff + K [q_C (-) ref_q_C; v_C - ref_v_C]) per step."""
    m = scene.model
    d = mujoco.MjData(m)
    qpos, qvel = scene.layout["qpos"], scene.layout["qvel"]
    out = np.empty((len(ff), ff.shape[1] + 1, scene.nstate))
    for p in range(len(ff)):
        mujoco.mj_setState(m, d, x0, INTEGRATION)
        for t in range(ff.shape[1]):
            dq = np.zeros(m.nv)
            mujoco.mj_differentiatePos(m, dq, 1.0, ref[t, qpos], d.qpos)
            dx = np.r_[dq[dofs], d.qvel[dofs] - ref[t, qvel][dofs]]
            d.ctrl[:] = np.clip(ff[p, t] + K[t] @ dx, lo, hi)
            out[p, t] = scene.state_of(d)
            mujoco.mj_step(m, d)
        out[p, -1] = scene.state_of(d)
    return out


@pytest.mark.parametrize("threads", [1, 2])
def test_feedback_rollouts_equal_step_loop(scene, moving_state, c_kernels, threads):
    svc = RolloutService(scene, RolloutConfig(threads=threads, c_kernels=c_kernels))
    assert svc.uses_c_kernels == c_kernels
    rng = np.random.default_rng(5)
    T, dofs = 30, np.array([0, 2, 3, 4, 7, 8])            # slide, ball, box (free) DoFs
    ref = svc.trajectory(moving_state, rng.uniform(-1, 1, (T, scene.nu))).states[:-1]
    ff = rng.uniform(-1.5, 1.5, (4, T, scene.nu))
    ff[:, :, 2] *= 0.05                                   # the light wrist stays sane
    K = rng.normal(0, 0.3, (T, scene.nu, 2 * len(dofs)))
    K[:, 2] *= 0.05
    got = svc.rollout_feedback(moving_state, ff, ref, K, dofs)
    lo, hi = ctrl_bounds(scene.model)
    want = feedback_loop(scene, moving_state, ff, ref, K, dofs, lo, hi)
    ctrl = scene.layout["ctrl"]
    assert np.any(np.abs(got.controls[:, :, 1]) == 1.0)    # the hinge motor was clamped
    np.testing.assert_allclose(got.states, want, rtol=0, atol=1e-10)
    np.testing.assert_array_equal(got.states[:, :-1, ctrl], got.controls)


def test_a_feedback_rollout_does_not_depend_on_the_rows_beside_it(scene, moving_state,
                                                                  c_kernels):
    """Bit for bit: a rollout run among seven equals it run alone or among two (the iLQR line
    search compares its alphas this way; a control law computed by BLAS on the whole batch
    rounds by the batch's shape)."""
    svc = RolloutService(scene, RolloutConfig(threads=1, c_kernels=c_kernels))
    rng = np.random.default_rng(11)
    T, dofs = 25, np.array([0, 2, 3, 4, 7, 8])
    ref = svc.trajectory(moving_state, rng.uniform(-1, 1, (T, scene.nu))).states[:-1]
    ff = rng.uniform(-1.0, 1.0, (7, T, scene.nu))
    ff[:, :, 2] *= 0.05
    K = rng.normal(0, 0.3, (T, scene.nu, 2 * len(dofs)))
    K[:, 2] *= 0.05
    together = svc.rollout_feedback(moving_state, ff, ref, K, dofs)
    for rows in ([3], [5, 1], [0, 2, 4, 6]):
        apart = svc.rollout_feedback(moving_state, ff[rows], ref, K, dofs)
        np.testing.assert_array_equal(apart.states, together.states[rows])
        np.testing.assert_array_equal(apart.controls, together.controls[rows])


def test_unstable_feedback_is_flagged_and_spares_the_others(scene, moving_state, c_kernels):
    svc = RolloutService(scene, RolloutConfig(threads=2, c_kernels=c_kernels))
    T = 20
    ref = svc.trajectory(moving_state, np.zeros((T, scene.nu))).states[:-1]
    ff = np.zeros((3, T, scene.nu))
    ff[:, :, 0] = [[0.1], [0.2], [-0.3]]
    ff[2, 6:, 2] = 1e300   # the unlimited ball motor blows up rollout 2 from step 6
    K = np.zeros((T, scene.nu, 2))
    res = svc.rollout_feedback(moving_state, ff, ref, K, [0])
    assert res.stability.unstable.tolist() == [False, False, True]
    assert res.stability.step.tolist() == [-1, -1, 6]
    alone = svc.rollout_feedback(moving_state, ff[:2], ref, K, [0])
    assert np.array_equal(res.states[:2], alone.states)
    assert np.array_equal(res.controls[:2], alone.controls)
    assert np.array_equal(res.states[2, 8:], np.repeat(res.states[2, 7:8], T - 7, 0))
    strict = RolloutService(scene, RolloutConfig(threads=2, c_kernels=c_kernels,
                                                 on_unstable="raise"))
    with pytest.raises(UnstableRolloutError) as info:
        strict.rollout_feedback(moving_state, ff, ref, K, [0])
    assert info.value.rollout == 2 and info.value.step == 6
    assert "rollout_feedback" in str(info.value)


def test_c_kernels_built_where_a_compiler_is():
    """The install builds dopt/_rollout_kernels when a C compiler exists; otherwise the
    Batch route must still serve (tested above) and the reason is known."""
    import shutil

    from dopt import kernels
    if shutil.which("cc") is None and shutil.which("gcc") is None:
        assert kernels.load() is None and kernels.load_error()
    else:
        assert kernels.load() is not None, kernels.load_error()


def test_mujoco_error_in_one_feedback_rollout_is_flagged_and_spares_the_others(c_kernels):
    """mju_error in one closed-loop rollout (arena overflow: models.ACTUATED_ARENA's slider
    driven onto the free box raises at step 37) flags that rollout with MuJoCo's message at
    that step, holds its state from before the step, and leaves the others as a call without
    it gives, on both routes; on_unstable="raise" names it."""
    scene = Scene.from_xml(ACTUATED_ARENA)
    x0 = scene.state_of(mujoco.MjData(scene.model))
    T = 45
    ff = np.zeros((3, T, 1))
    ff[1] = -0.2                                      # rollout 1 drives onto the free box
    ref, K = np.repeat(x0[None], T, 0), np.zeros((T, 1, 2))
    svc = RolloutService(scene, RolloutConfig(threads=2, c_kernels=c_kernels))
    res = svc.rollout_feedback(x0, ff, ref, K, [6])
    assert res.stability.unstable.tolist() == [False, True, False]
    assert res.stability.step[1] == 37
    reason = res.stability.reason[1]
    assert reason.startswith("MuJoCo error") and "memory" in reason
    assert (res.states[1, 38:] == res.states[1, 37]).all()   # stopped before the step that raised
    assert (res.controls[1, 37:] == -0.2).all()
    loop = step_loop(scene, x0[None], ff[1:2, :37])[0]       # its rows up to there are mj_step's
    qpos = scene.layout["qpos"]
    np.testing.assert_array_equal(res.states[1, 1:38, qpos], loop[:, qpos])
    alone = svc.rollout_feedback(x0, ff[[0, 2]], ref, K, [6])
    assert not alone.stability.unstable.any()
    assert np.array_equal(res.states[[0, 2]], alone.states)
    assert np.array_equal(res.controls[[0, 2]], alone.controls)
    again = svc.rollout_feedback(x0, ff, ref, K, [6])          # the route recovered
    assert np.array_equal(again.states, res.states)
    strict = RolloutService(scene, RolloutConfig(threads=1, c_kernels=c_kernels,
                                                 on_unstable="raise"))
    with pytest.raises(UnstableRolloutError, match="MuJoCo error") as info:
        strict.rollout_feedback(x0, ff, ref, K, [6])
    assert info.value.rollout == 1 and info.value.step == 37


def _use_every_call(svc, scene, x0):
    """One call of each public method (makes the Batch and, on the C route, the kernels)."""
    T = 5
    ref = svc.trajectory(x0, np.zeros((T, scene.nu))).states
    svc.rollout(x0, np.zeros((2, T, scene.nu)))
    svc.rollout_feedback(x0, np.zeros((3, T, scene.nu)), ref[:-1],
                         np.zeros((T, scene.nu, 2)), [0])
    svc.derivatives(ref[:-1], "robot")
    return ref


def _assert_closed(svc, scene, x0, ref):
    T = len(ref) - 1
    calls = [lambda: svc.rollout(x0, np.zeros((2, T, scene.nu))),
             lambda: svc.trajectory(x0, np.zeros((T, scene.nu))),
             lambda: svc.rollout_feedback(x0, np.zeros((3, T, scene.nu)), ref[:-1],
                                          np.zeros((T, scene.nu, 2)), [0]),
             lambda: svc.derivatives(ref[:-1], "robot")]
    for call in calls:
        with pytest.raises(RuntimeError, match="RolloutService is closed"):
            call()


def test_closed_service_raises_and_close_is_idempotent(scene, moving_state, c_kernels):
    svc = RolloutService(scene, RolloutConfig(threads=2, c_kernels=c_kernels))
    ref = _use_every_call(svc, scene, moving_state)
    pool = svc._route._kernels._pool if c_kernels else None
    workers = list(pool._threads) if pool else []
    assert not svc.closed and (not c_kernels or workers)
    svc.close()
    assert svc.closed and svc.uses_c_kernels == c_kernels
    assert not any(w.is_alive() for w in workers)     # the C kernels' pool is shut down
    _assert_closed(svc, scene, moving_state, ref)
    svc.close()                                        # idempotent
    _assert_closed(svc, scene, moving_state, ref)


def test_context_manager_closes(scene, moving_state, c_kernels):
    with RolloutService(scene, RolloutConfig(threads=2, c_kernels=c_kernels)) as svc:
        ref = _use_every_call(svc, scene, moving_state)
    _assert_closed(svc, scene, moving_state, ref)
    # an exception leaving the block closes the service too, and propagates
    with pytest.raises(KeyError):
        with RolloutService(scene, RolloutConfig(threads=2, c_kernels=c_kernels)) as svc:
            raise KeyError("boom")
    assert svc.closed
    # closing an unused service (nothing allocated yet) is fine
    RolloutService(scene, RolloutConfig(c_kernels=c_kernels)).close()


@pytest.mark.parametrize("chunk_bytes", [None, 2000])
def test_mujoco_error_in_one_rollout_is_flagged_and_spares_the_others(monkeypatch, chunk_bytes):
    """mju_error in one simulation of a batch (arena overflow: models.MOCAP_ARENA's mocap box
    pushed onto a box near the floor at step 6) flags that rollout with MuJoCo's message at that
    step and keeps its state from before; the other rollouts equal a batch without it, in one
    chunk or in many; on_unstable="raise" names it."""
    import dopt.rollout_batch as rollout_batch
    if chunk_bytes:
        monkeypatch.setattr(rollout_batch, "CHUNK_BYTES", chunk_bytes)
    scene = Scene.from_xml(MOCAP_ARENA)
    x0 = scene.state_of(mujoco.MjData(scene.model))
    T, spec = 12, int(mujoco.mjtState.mjSTATE_MOCAP_POS)
    u = np.zeros((3, T, 3))
    u[:, :, 0] = [[3.0], [3.1], [3.2]]                 # far from the boxes ...
    u[:, :, 2] = 1.0
    u[1, 6:] = [0.0, 0.0, 0.1]                         # ... but rollout 1's, from step 6
    svc = RolloutService(scene, RolloutConfig(threads=2))
    res = svc.rollout(x0, u, control_spec=spec, record=("qpos",))
    assert res.stability.unstable.tolist() == [False, True, False]
    assert res.stability.step[1] == 6
    assert "MuJoCo error" in res.stability.reason[1] and "memory" in res.stability.reason[1]
    alone = svc.rollout(x0, u[[0, 2]], control_spec=spec, record=("qpos",))
    assert not alone.stability.unstable.any()
    assert np.array_equal(res.final_states[[0, 2]], alone.final_states)
    assert np.array_equal(res.records["qpos"][[0, 2]], alone.records["qpos"])
    qpos = scene.layout["qpos"]
    if chunk_bytes:   # stopped after the last chunk before the error, at a state it recorded
        assert any(np.array_equal(res.final_states[1, qpos], q) for q in res.records["qpos"][1, :6])
    else:             # the error came in the first chunk: its start state, records unknown
        np.testing.assert_array_equal(res.final_states[1], x0)
        assert np.isnan(res.records["qpos"][1]).all()
    strict = RolloutService(scene, RolloutConfig(threads=1, on_unstable="raise"))
    with pytest.raises(UnstableRolloutError, match="MuJoCo error") as info:
        strict.rollout(x0, u, control_spec=spec)
    assert info.value.rollout == 1 and info.value.step == 6
