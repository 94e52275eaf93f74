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
