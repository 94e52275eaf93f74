import pytest

from dopt.scene import Scene
from tests.dopt import models
from tests.dopt.models import MIXED_JOINTS, SLIDER


@pytest.fixture(scope="module")
def scene():
    return Scene.from_xml(MIXED_JOINTS)


@pytest.fixture
def moving_state(scene):
    """An mjSTATE_INTEGRATION row of the mixed model in motion, with contacts."""
    return models.moving_state(scene)


@pytest.fixture(scope="module")
def slider():
    """(scene, its rest state row): two sliders, no gravity (``models.SLIDER``)."""
    import mujoco

    scene = Scene.from_xml(SLIDER)
    d = mujoco.MjData(scene.model)
    mujoco.mj_forward(scene.model, d)
    return scene, scene.state_of(d)
