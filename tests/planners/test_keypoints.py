"""Derivatives at key timesteps with linear interpolation (planners.keypoints) and the
box-constrained backward pass, against plain finite differences and a cvxpy QP."""

import cvxpy as cp
import mujoco
import numpy as np
import pytest
import torch

from dopt import RolloutService, Scene
from dopt.costs import QuadraticCost
from planners.ilqr import ILQR, Derivatives, ILQRConfig, _box_step, backward_pass
from planners.keypoints import KeypointConfig, interpolate, key_steps
from tests.dopt.models import MIXED_JOINTS

PENDULA = """<mujoco><option timestep="0.01"/><worldbody>
  <body><joint name="h1" type="hinge" axis="0 1 0" damping=".05"/>
    <geom type="capsule" fromto="0 0 0 0 0 -.3" size=".02" mass="1"/>
    <body pos="0 0 -.3"><joint name="h2" type="hinge" axis="0 1 0" damping=".05"/>
      <geom type="capsule" fromto="0 0 0 0 0 -.3" size=".02" mass="1"/></body></body>
  </worldbody><actuator><motor joint="h1" ctrlrange="-2 2" ctrllimited="true"/>
  <motor joint="h2" ctrlrange="-1 1" ctrllimited="true"/></actuator></mujoco>"""


@pytest.fixture(scope="module")
def pendula():
    scene = Scene.from_xml(PENDULA)
    d = mujoco.MjData(scene.model)
    d.qpos[:] = [0.8, -0.5]
    mujoco.mj_forward(scene.model, d)
    x0 = scene.state_of(d)
    U = np.random.default_rng(0).uniform(-1, 1, (40, 2))
    svc = RolloutService(scene, )
    cost = QuadraticCost(scene, np.zeros(2), np.ones(4), 10 * np.ones(4), np.full(2, 1e-2))
    yield scene, svc, cost, x0, U
    svc.close()


def test_skip_one_is_plain_finite_differences_bit_for_bit(pendula):
    scene, svc, cost, x0, U = pendula
    plain = ILQR(svc, cost).iterate(x0, U)
    skip1 = ILQR(svc, cost, ILQRConfig(Derivatives(keypoints="skip", fd_skip=1))).iterate(x0, U)
    assert torch.equal(plain.K, skip1.K) and torch.equal(plain.k, skip1.k)
    np.testing.assert_array_equal(plain.controls, skip1.controls)


@pytest.mark.parametrize("skip", [2, 5, 7])
def test_interpolated_derivatives_equal_fd_at_keys_and_blend_between(pendula, skip):
    scene, svc, _, x0, U = pendula
    X = svc.trajectory(x0, U).states
    full = torch.from_numpy(svc.derivatives(X[:-1]).F)
    keys = key_steps(KeypointConfig("skip", skip=skip), scene, X, scene.dofs())
    assert keys[0] == 0 and keys[-1] == len(U) - 1 and np.all(np.diff(keys) <= skip)
    at_keys = torch.from_numpy(svc.derivatives(X[keys]).F)
    assert torch.equal(at_keys, full[keys])                    # the same FD, row by row
    F = interpolate(at_keys, keys, len(U))
    assert torch.equal(F[keys], full[keys])
    for a, b in zip(keys[:-1], keys[1:], strict=True):
        for t in range(a + 1, b):
            w = (t - a) / (b - a)
            torch.testing.assert_close(F[t], (1 - w) * full[a] + w * full[b], rtol=0,
                                       atol=1e-12)


def test_adaptive_keys_follow_their_rules(pendula):
    """First and last included; gaps within [min, max] (the last gap may be shorter);
    a velocity that turns makes a key point (no later than min_interval after the turn)."""
    scene, svc, _, x0, U = pendula
    X = svc.trajectory(x0, U).states
    cfg = KeypointConfig("adaptive", min_interval=2, max_interval=6, threshold=1e3)
    keys = key_steps(cfg, scene, X, scene.dofs())
    gaps = np.diff(keys)
    assert keys[0] == 0 and keys[-1] == len(U) - 1
    assert np.all(gaps[:-1] >= 2) and np.all(gaps <= 6)
    v = X[:-1, scene.layout["qvel"]]
    acc = np.diff(v, axis=0)
    turns = [t for t in range(2, len(U)) if np.any(acc[t - 1] * acc[t - 2] < 0)]
    assert turns
    for t in turns:                                   # a key within min_interval of each turn
        assert np.any((keys >= t - 1) & (keys <= t + 1))
    # no turn, no threshold crossing: keys every max_interval
    still = np.repeat(X[:1], len(X), axis=0)
    keys = key_steps(cfg, scene, still, scene.dofs())
    np.testing.assert_array_equal(keys, np.append(np.arange(0, len(U), 6), len(U) - 1)
                                  if (len(U) - 1) % 6 else np.arange(0, len(U), 6))


def test_box_step_matches_a_cvxpy_qp():
    rng = np.random.default_rng(3)
    for _ in range(20):
        nu, n = 4, 6
        M = rng.normal(size=(nu, nu))
        H = M @ M.T + 0.1 * np.eye(nu)
        rhs = rng.normal(size=(nu, 1 + n)) * 3
        lo, hi = -rng.uniform(0.1, 1, nu), rng.uniform(0.1, 1, nu)
        out = torch.empty(nu, 1 + n, dtype=torch.float64)
        G = _box_step(torch.from_numpy(H), torch.from_numpy(rhs), lo, hi, out).numpy()
        x = cp.Variable(nu)
        cp.Problem(cp.Minimize(0.5 * cp.quad_form(x, H) + rhs[:, 0] @ x),
                   [x >= lo, x <= hi]).solve(solver=cp.CLARABEL)
        np.testing.assert_allclose(G[:, 0], x.value, atol=1e-6)
        clamped = (np.isclose(G[:, 0], lo) | np.isclose(G[:, 0], hi))
        assert np.all(G[clamped, 1:] == 0)
        free = ~clamped
        np.testing.assert_allclose(G[free, 1:], -np.linalg.solve(H[np.ix_(free, free)],
                                                                rhs[free, 1:]), atol=1e-9)


def test_box_backward_pass_with_inactive_bounds_is_the_plain_one():
    rng = np.random.default_rng(1)
    T, n, nu = 12, 6, 3
    F = torch.from_numpy(rng.normal(size=(T, n, n + nu)) * 0.3)
    L = rng.normal(size=(T + 1, n, n))
    lxx = torch.from_numpy(L @ L.transpose(0, 2, 1) + np.eye(n))
    lx = torch.from_numpy(rng.normal(size=(T + 1, n)))
    lu = torch.from_numpy(rng.normal(size=(T, nu)))
    luu = torch.from_numpy(np.tile(np.eye(nu), (T, 1, 1)))
    K, k = backward_pass(F, lx, lxx, lu, luu, 0.1)
    wide = (np.full((T, nu), -1e9), np.full((T, nu), 1e9))
    Kb, kb = backward_pass(F, lx, lxx, lu, luu, 0.1, wide)
    torch.testing.assert_close(Kb, K, rtol=1e-9, atol=1e-12)
    torch.testing.assert_close(kb, k, rtol=1e-9, atol=1e-12)
    unlimited = (np.full((T, nu), -np.inf), np.full((T, nu), np.inf))
    Ki, ki = backward_pass(F, lx, lxx, lu, luu, 0.1, unlimited)
    torch.testing.assert_close(ki, k, rtol=1e-9, atol=1e-12)


def test_box_qp_ilqr_keeps_its_feedforward_step_within_the_limits(pendula):
    scene, svc, cost, x0, U = pendula
    step = ILQR(svc, cost, ILQRConfig(Derivatives(box_qp=True))).iterate(x0, U)
    lo, hi = scene.model.actuator_ctrlrange.T
    u = U + step.k.numpy()
    assert np.all(u >= lo - 1e-9) and np.all(u <= hi + 1e-9)
    assert step.cost_after <= step.cost_before


def test_keypoint_config_errors():
    with pytest.raises(ValueError, match="keypoint method"):
        KeypointConfig("sometimes")
    with pytest.raises(ValueError, match="min_interval"):
        KeypointConfig("adaptive", min_interval=5, max_interval=2)
    with pytest.raises(ValueError, match="skip"):
        KeypointConfig("skip", skip=0)
    with pytest.raises(TypeError, match="ILQRConfig.derivatives must be a Derivatives"):
        ILQRConfig(derivatives=KeypointConfig("skip"))


def test_free_joint_model_works_with_skip():
    """Interpolation works on tangent-space derivatives of free joints too (shapes)."""
    scene = Scene.from_xml(MIXED_JOINTS)
    with RolloutService(scene) as svc:
        x0 = scene.state_of(mujoco.MjData(scene.model))
        X = svc.trajectory(x0, np.zeros((9, scene.nu))).states
        keys = key_steps(KeypointConfig("skip", skip=4), scene, X, scene.dofs())
        F = interpolate(torch.from_numpy(svc.derivatives(X[keys]).F), keys, 9)
        assert F.shape == (9, 2 * scene.nv, 2 * scene.nv + scene.nu)


def test_bench_rows_report_key_steps_and_interpolation_error():
    from planners.bench.ilqr import bench_ilqr

    rows = bench_ilqr("clutter", ["svr-sum"], 1.0, None, iterations=1, warmup=0, threads=1,
                      seed=0, variants=("every", "skip5"))
    every, skip = rows
    assert (every["keypoints"], every["fd_steps"], every["interp_error"]) == ("every", 80, None)
    assert skip["keypoints"] == "skip5" and skip["fd_steps"] == 17      # 0, 5, ..., 75, 79
    assert 0 < skip["interp_error"] < 0.05
    assert 0 <= skip["interp_error_median"] <= 2 * skip["interp_error"]   # Markov: non-negative
    assert skip["vs_every"] == skip["ms_per_iteration"] / every["ms_per_iteration"]
    assert 0 < skip["derivative_share"] < 1
    with pytest.raises(ValueError, match="keypoint variant"):
        KeypointConfig.parse("skip0")
