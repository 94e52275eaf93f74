"""dopt.tasks.pick.replay: a replayed plan ends where the rollout service's execution does."""

import numpy as np
import pytest

from dopt.tasks.pick.cloth_scene import ClothSceneConfig, make_cloth
from dopt.tasks.pick.replay import replay
from dopt.tasks.pick.scene import PickPlaceTask


@pytest.fixture(scope="module")
def cloth():
    return make_cloth(ClothSceneConfig(n=6))


def test_replay_ends_where_the_rollout_does(cloth):
    particles = np.array([0, -1, 35])
    displacements = np.array([[0.05, 0.02, 0.04], [0.0, 0.0, 0.0], [-0.03, 0.0, 0.02]])
    task = PickPlaceTask(cloth, cloth.positions(cloth.initial_state))
    final = task.execute(particles, displacements).state
    actions = [{"particles": particles[:2].tolist(), "displacements": displacements[:2].tolist()},
               {"particles": particles[2:].tolist(), "displacements": displacements[2:].tolist()}]
    rep = replay(cloth, cloth.initial_state, actions, max_frames=40)
    assert 2 < len(rep.states) <= 40 and len(rep.step) == len(rep.states)
    np.testing.assert_array_equal(rep.states[0], cloth.initial_state)
    np.testing.assert_allclose(cloth.positions(rep.states[-1]), cloth.positions(final),
                               atol=1e-9)
    K = cloth.picker.steps_per_action
    assert rep.step[-1] == 3 * K and np.all(np.diff(rep.step) > 0)
    assert rep.stage[-1] == 1 and rep.action[-1] == 0 and rep.stage.min() == 0
    with pytest.raises(ValueError):
        replay(cloth, cloth.initial_state, actions, max_frames=1)


def test_replay_refuses_a_scene_that_is_not_a_deformable_scene(cloth):
    with pytest.raises(TypeError, match="DeformableScene"):
        replay(object(), cloth.initial_state, [])
