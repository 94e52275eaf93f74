"""The fixes beyond the paper, as named rows: ``+costdofs`` keeps the DoFs the cost weights in
C whatever their importance (``SelectionConfig.keep_costed``), ``+mureset`` starts every MPC
call's iLQR iteration from mu_init (``ILQRConfig.mu_reset``); both reach the trial's settings,
key and row label, and the paper's rows are unchanged without them."""

import numpy as np
import pytest
import torch

from planners.svr import DofSelector, SelectionConfig
from planners.svr_mpc.settings import SVRMPCSettings, parse_row, row_label
from planners.svr_mpc.trial_names import legacy_trial_key, trial_key


def selector(method, keep_costed, theta=2):
    return DofSelector(12, robot=[0, 1], costed=[7, 8],
                       config=SelectionConfig(method, rho=1.0, theta=theta,
                                              keep_costed=keep_costed),
                       rng=np.random.default_rng(0))


def test_svr_never_drops_the_cost_dofs_with_keep_costed():
    """All gains 0: every importance is below rho, so the paper's rule keeps the robot only;
    with keep_costed the cost's DoFs stay too."""
    for keep, expected in ((False, [0, 1]), (True, [0, 1, 7, 8])):
        s = selector("svr-sum", keep)
        dofs = np.arange(12)
        kept = s.after(torch.zeros(5, 2, 24, dtype=torch.float64), dofs)
        np.testing.assert_array_equal(kept, expected)


def test_rand_draws_theta_dofs_besides_the_robot_and_the_cost_dofs():
    for _ in range(20):
        s = selector("rand", True, theta=3)
        C = s.before()
        assert {0, 1, 7, 8} <= set(C.tolist()) and len(C) == 4 + 3


def test_rows_name_their_fixes_and_the_keys_hold_them():
    row = parse_row("sum-t10-r500+costdofs+mureset")
    assert row.fixes == {"keep_costed": True, "mu_reset": True} and row.variants == {}
    s = SVRMPCSettings.authors("soft_rigid", "sum-t10-r500", keep_costed=True, mu_reset=True,
                               slowdown=1.0)
    p = {**s.params(), "seed": 0}
    assert row_label(p) == "sum-t10-r500 +costdofs +mureset"
    assert legacy_trial_key(p).endswith("-fixcostdofs-fixmureset")
    assert s.ilqr.mu_reset and s.selection.keep_costed and s.selection.config.keep_costed
    assert row.apply(SVRMPCSettings.authors("soft_rigid", slowdown=1.0)) == s
    plain = {**SVRMPCSettings.authors("soft_rigid", "sum-t10-r500", slowdown=1.0).params(),
             "seed": 0}
    assert "fix" not in legacy_trial_key(plain) and row_label(plain) == "sum-t10-r500"
    assert trial_key(plain) != trial_key(p)                    # the fixes name the trial
    with pytest.raises(ValueError, match="repeated"):
        parse_row("sum-t10-r1+mureset+mureset")


@pytest.mark.parametrize("reset", [False, True])
def test_mu_reset_starts_every_iteration_from_mu_init(reset):
    """A mu left at 7 by earlier calls: the next iteration ends at 7 / 10 or 7 x 10 (capped)
    without the reset, at 0.1 / 10 or 0.1 x 10 with it (a real iteration on two sliders)."""
    import mujoco

    from dopt import RolloutService, Scene
    from dopt.costs import QuadraticCost
    from planners.ilqr import ILQR, ILQRConfig

    from ...dopt.models import SLIDER

    scene = Scene.from_xml(SLIDER)
    d = mujoco.MjData(scene.model)
    mujoco.mj_forward(scene.model, d)
    w = np.array([0.0, 50.0, 0.0, 0.0])
    cost = QuadraticCost(scene, np.array([0.0, 0.3]), w, 10 * w, np.array([1e-4]))
    solver = ILQR(RolloutService(scene), cost, ILQRConfig(mu_reset=reset))
    solver.mu = 7.0
    step = solver.iterate(scene.state_of(d), np.full((10, 1), 5.0))
    assert step.mu in ((0.01, 1.0) if reset else (0.7, 10.0))
