import pytest

from dopt.scene import Scene
from tests.dopt import models
from tests.dopt.models import MIXED_JOINTS


@pytest.fixture(scope="module")
def scene():
    return Scene.from_xml(MIXED_JOINTS)


@pytest.fixture
def moving_state(scene):
    """An mjSTATE_INTEGRATION row of the mixed model in motion, with contacts."""
    return models.moving_state(scene)


@pytest.fixture(params=[True, False], ids=["c-kernels", "batch"])
def c_kernels(request):
    """Both routes of RolloutService's derivatives and feedback rollouts: dopt.kernels' C loops
    (skipped, with the reason, where they were not built) and mujoco.batch.Batch."""
    if request.param:
        from dopt import kernels
        if kernels.load() is None:
            pytest.skip(f"C kernels not built: {kernels.load_error()}")
    return request.param
