"""PinnedScene: particles of a pick scene welded to the world where asked, the rest shape of
the scene as built (MuJoCo's own compile-time edge lengths), placement round-trips, and bad
pins named."""

import mujoco
import numpy as np
import pytest

from dopt.tasks.pick.cloth_scene import ClothSceneConfig, make_cloth
from dopt.tasks.pick.picker import PickerConfig
from dopt.tasks.pick.pinned import PinnedScene
from dopt.tasks.pick.rope_scene import RopeSceneConfig, make_rope, rope_xml
from dopt.tasks.pick.scene import DeformableScene

N = 10


@pytest.fixture(scope="module")
def rope():
    return make_rope(RopeSceneConfig(n=N, length=0.2, settle=0.0))


def _straight(scene: DeformableScene, height: float = 0.3) -> np.ndarray:
    """The scene's compiled layout lifted to ``height``: (N, 3)."""
    pos = scene.positions(scene.initial_state)
    return pos + [0.0, 0.0, height]


def test_pinned_particles_lose_their_joints_and_keep_the_rest_lengths(rope):
    start = _straight(rope)
    pinned = PinnedScene(rope, {0: start[0] + [0.05, 0, 0], N - 1: start[-1]})
    assert pinned.model.nv == rope.model.nv - 6
    # the edges' rest lengths are MuJoCo's compile-time ones of the scene as built: moving the
    # pin after compiling does not make the moved layout the rest shape
    assert np.array_equal(pinned.model.flexedge_length0, rope.model.flexedge_length0)
    assert pinned.free.tolist() == list(range(1, N - 1))


def test_place_and_positions_round_trip(rope):
    rng = np.random.default_rng(3)
    start = _straight(rope)
    pinned = PinnedScene(rope, {2: start[2] + [0, 0.01, 0], 7: start[7]})
    pos = rng.uniform(-0.3, 0.3, (N, 3))
    pos[pinned.pinned] = pinned.pins
    data = pinned.place(pos)
    np.testing.assert_allclose(pinned.positions(data), pos, atol=1e-12)
    # MuJoCo's own vertex positions agree
    f = mujoco.mj_name2id(pinned.model, mujoco.mjtObj.mjOBJ_FLEX, "rope")
    adr = pinned.model.flex_vertadr[f]
    np.testing.assert_allclose(data.flexvert_xpos[adr:adr + N], pos, atol=1e-12)


def test_a_straight_rope_pinned_where_it_lies_stays_put_without_gravity(rope):
    """Its rest shape is straight (rest lengths and rest curvature of the built scene): with
    nothing acting on it, it does not move; under gravity the pins hold exactly."""
    start = _straight(rope)
    pinned = PinnedScene(rope, {0: start[0], N - 1: start[-1]})
    still = pinned.relax(start, 0.5, 5.0, gravity=(0.0, 0.0, 0.0))
    np.testing.assert_allclose(still.positions, start, atol=1e-7)
    hung = pinned.relax(start, 0.5, 5.0)
    assert np.array_equal(hung.positions[[0, N - 1]], start[[0, N - 1]])
    assert hung.positions[N // 2, 2] < start[N // 2, 2] - 1e-3
    assert hung.steps == int(np.ceil(0.5 / rope.model.opt.timestep))


def test_a_rope_pinned_at_one_end_hangs_straight_down(rope):
    """Independent of any curve: held at one end, from a horizontal start, the rope settles
    vertically below its pin (every particle within a millimetre of the plumb line)."""
    start = _straight(rope)
    pinned = PinnedScene(rope, {0: start[0]})
    hung = pinned.relax(start, 4.0, 2 * np.sqrt(9.81 / 0.2) * 2)
    plumb = np.linalg.norm(hung.positions[:, :2] - start[0, :2], axis=1)
    assert plumb.max() < 1e-3
    assert np.all(np.diff(hung.positions[:, 2]) < 0)            # each particle below the last


def test_cloth_rows_can_be_pinned():
    cloth = make_cloth(ClothSceneConfig(n=4, settle=0.0))
    start = _straight(cloth)
    pinned = PinnedScene(cloth, {i: start[i] for i in range(4)})
    assert pinned.model.nv == cloth.model.nv - 12
    assert pinned.edges.shape[1] == 2 and pinned.edges.max() == 15


@pytest.mark.parametrize("pins, error, match", [
    ({N: (0, 0, 0)}, ValueError, r"pins \(particles\): index out of range"),
    ({1.0: (0, 0, 0)}, TypeError, r"pins \(particles\) must be integers"),
    ({1: (0, 0)}, ValueError, r"pins \(positions\) must have shape"),
    ({1: (0, np.nan, 0)}, ValueError, r"pins \(positions\) contains NaN"),
    ({i: (0, 0, 0) for i in range(N)}, ValueError, "nothing is left to move"),
    ([(1, (0, 0, 0))], TypeError, "pins must map particle -> position"),
])
def test_bad_pins_are_named(rope, pins, error, match):
    with pytest.raises(error, match=match):
        PinnedScene(rope, pins)


def test_bad_scene_and_starts_are_named(rope):
    with pytest.raises(TypeError, match="scene must be a DeformableScene"):
        PinnedScene(rope.model, {0: (0, 0, 0)})
    bare = DeformableScene(mujoco.MjModel.from_xml_string(rope_xml(RopeSceneConfig(n=N,
                                                                                   length=0.2))),
                           "rope", PickerConfig(), settle=0.0)
    with pytest.raises(ValueError, match="scene has no MJCF"):
        PinnedScene(bare, {0: (0, 0, 0)})
    start = _straight(rope)
    pinned = PinnedScene(rope, {0: start[0]})
    with pytest.raises(ValueError, match="pinned particle 0.01 m off its pin"):
        pinned.place(start + [0.01, 0, 0])
    with pytest.raises(ValueError, match="seconds"):
        pinned.relax(start, 0.0, 1.0)
    with pytest.raises(ValueError, match="forces"):
        pinned.relax(start, 0.1, 1.0, forces={N: (0, 0, 1)})
