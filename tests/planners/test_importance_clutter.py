"""The FD trap of the notes: on the clutter task, the importance ranking from K must put the
goal cylinder's translations first among the objects, not the tilt of an untouched distractor."""

import numpy as np
import pytest
import torch

from dopt import RolloutConfig, RolloutService, Scene
from dopt.rollout import FDConfig
from dopt.tasks import get_task
from dopt.tasks.push.costs import push_cost
from planners.ilqr import ILQR, ILQRConfig
from planners.svr import importance_sum, importance_svd


@pytest.fixture(scope="module")
def clutter_gains():
    torch.set_num_threads(1)
    tm = get_task("clutter")(np.random.default_rng(0))
    scene = Scene(tm.model)
    ilqr = ILQR(RolloutService(scene, RolloutConfig(threads=1)), push_cost(tm, scene),
                ILQRConfig())
    U = np.zeros((tm.horizon, scene.nu))
    for _ in range(4):
        step = ilqr.iterate(tm.initial_state, U)
        U = step.controls
    return tm, scene, step


@pytest.mark.parametrize("importance", [importance_sum, importance_svd])
def test_goal_cylinder_outranks_every_distractor(clutter_gains, importance):
    tm, scene, step = clutter_gains
    imp = importance(step.K).numpy()
    goal_xy = scene.dofs(f"object:{tm.goal_object}")[:2]
    distractors = scene.dofs(*[f"object:{n}" for n in tm.distractors])
    assert imp[goal_xy].min() > imp[distractors].max()
    # and most distractor DoFs are not coupled to the controls at all
    assert np.mean(imp[distractors] == 0) > 0.5


def test_tiny_eps_falls_into_the_trap(clutter_gains):
    """The reason for the default: at eps 1e-6 the contact FD entries explode."""
    tm, scene, step = clutter_gains
    svc = RolloutService(scene, RolloutConfig(threads=1))
    small = svc.derivatives(step.states[:-1], None, FDConfig(eps=1e-6))
    default = svc.derivatives(step.states[:-1], None, ILQRConfig().derivatives.fd_config)
    assert np.abs(small.A).max() > 50 * np.abs(default.A).max()
