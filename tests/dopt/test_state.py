"""State rows, save/restore and tangent-space arithmetic."""

import mujoco
import numpy as np
import pytest

from dopt.state import INTEGRATION, StateLayout, Tangent, check_states, get_state, set_state


def test_layout_matches_data_fields(scene, moving_state):
    m = scene.model
    d = mujoco.MjData(m)
    set_state(m, d, moving_state)
    lay = StateLayout.of(m)
    assert lay.size == mujoco.mj_stateSize(m, INTEGRATION)
    for name, field in [("qpos", d.qpos), ("qvel", d.qvel), ("ctrl", d.ctrl),
                        ("warmstart", d.qacc_warmstart), ("eq_active", d.eq_active)]:
        np.testing.assert_array_equal(moving_state[lay[name]], field)
    assert moving_state[lay["time"]][0] == d.time > 0
    with pytest.raises(ValueError, match="no component"):
        StateLayout.of(m, int(mujoco.mjtState.mjSTATE_QPOS))["qvel"]


def test_save_restore_round_trip_continues_bitwise(scene, moving_state):
    m = scene.model
    a, b = mujoco.MjData(m), mujoco.MjData(m)
    set_state(m, a, moving_state)
    np.testing.assert_array_equal(get_state(m, a), moving_state)
    set_state(m, b, get_state(m, a))
    for _ in range(50):
        mujoco.mj_step(m, a)
        mujoco.mj_step(m, b)
    np.testing.assert_array_equal(get_state(m, a), get_state(m, b))


def test_bad_states(scene, moving_state):
    m = scene.model
    with pytest.raises(ValueError, match="shape"):
        check_states(m, moving_state[:-1])
    with pytest.raises(ValueError, match=r"\(P, "):
        check_states(m, moving_state, batched=True)
    with pytest.raises(ValueError, match="NaN"):
        check_states(m, np.where(np.arange(len(moving_state)) == 4, np.nan, moving_state))
    with pytest.raises(TypeError, match="float"):
        check_states(m, np.array(["a"] * len(moving_state)))


def random_qpos(m, rng, n):
    q = np.tile(m.qpos0, (n, 1)) + rng.normal(0, 0.3, (n, m.nq))
    return q


def test_difference_matches_mj_differentiatePos(scene):
    m, rng = scene.model, np.random.default_rng(0)
    tan = Tangent(m)
    q1, q2 = random_qpos(m, rng, 20), random_qpos(m, rng, 20)
    # unnormalised quaternions and a rotation of more than pi are both handled as MuJoCo does
    got = tan.difference(q1, q2, 0.01)
    for i in range(20):
        ref = np.zeros(m.nv)
        mujoco.mj_differentiatePos(m, ref, 0.01, q1[i], q2[i])
        np.testing.assert_allclose(got[i], ref, rtol=1e-12, atol=1e-10)


def test_perturb_is_mj_integratePos(scene):
    m, rng = scene.model, np.random.default_rng(1)
    tan = Tangent(m)
    q = random_qpos(m, rng, m.nv)
    got = tan.perturb(q, np.arange(m.nv), -1e-3)
    for i in range(m.nv):
        ref = q[i].copy()
        e = np.zeros(m.nv)
        e[i] = 1
        mujoco.mj_integratePos(m, ref, e, -1e-3)
        np.testing.assert_array_equal(got[i], ref)
    # and differencing undoes it, DoF by DoF
    back = tan.difference(q, got, -1e-3)
    np.testing.assert_allclose(back, np.eye(m.nv), atol=1e-7)


def test_difference_on_a_dof_subset(scene):
    m, rng = scene.model, np.random.default_rng(4)
    tan = Tangent(m)
    q1, q2 = random_qpos(m, rng, 6), random_qpos(m, rng, 6)
    full = tan.difference(q1, q2, 0.5)
    for dofs in ([0], [3], [2, 4, 9, 16], list(range(m.nv))):
        np.testing.assert_array_equal(tan.difference(q1, q2, 0.5, np.array(dofs)),
                                      full[:, dofs])


@pytest.mark.parametrize("quat", [(0.0, 0.0, 0.0, 0.0), (2.0, 0.0, 0.0, 0.0),
                                  (1.0, 1e-2, 0.0, 0.0)])
def test_a_non_unit_quaternion_in_a_given_state_is_refused(scene, quat):
    """MuJoCo would silently normalise these (an all-zero quaternion becomes the identity);
    check_states names the joint instead. A unit quaternion off by rounding passes."""
    d = mujoco.MjData(scene.model)
    mujoco.mj_forward(scene.model, d)
    row = scene.state_of(d)
    adr = scene.layout["qpos"].start + scene.model.joint("box_free").qposadr[0] + 3
    bad = row.copy()
    bad[adr:adr + 4] = quat
    with pytest.raises(ValueError, match="quaternion of joint 'box_free' in row 0"):
        check_states(scene.model, bad)
    near = row.copy()
    near[adr:adr + 4] = np.array([1.0, 0.0, 0.0, 0.0]) * (1 + 1e-12)
    check_states(scene.model, near)
