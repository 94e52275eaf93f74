import mujoco
import numpy as np
import pytest

from dopt.scene import Scene
from tests.dopt.models import MIXED_JOINTS


@pytest.fixture(scope="module")
def scene():
    return Scene.from_xml(MIXED_JOINTS)


@pytest.fixture
def moving_state(scene):
    """An mjSTATE_INTEGRATION row of the mixed model in motion, with contacts."""
    m = scene.model
    d = mujoco.MjData(m)
    rng = np.random.default_rng(3)
    d.qvel[:] = rng.normal(0, 0.3, m.nv)
    for _ in range(40):
        d.ctrl[:] = rng.uniform(-1, 1, m.nu)
        mujoco.mj_step(m, d)
    assert d.ncon > 0
    return scene.state_of(d)


@pytest.fixture(params=[True, False], ids=["c-kernels", "batch"])
def c_kernels(request):
    """Both routes of RolloutService's derivatives and feedback rollouts: dopt.kernels' C loops
    (skipped, with the reason, where they were not built) and mujoco.batch.Batch."""
    if request.param:
        from dopt import kernels
        if kernels.load() is None:
            pytest.skip(f"C kernels not built: {kernels.load_error()}")
    return request.param
