"""Soft-body meshes and their placement; the soft_rigid arrangement."""

import math

import mujoco
import numpy as np
import pytest

from dopt.tasks.panda import table_scene_spec
from dopt.tasks.push.soft import (
    DENSITY,
    SOFT_BODY,
    SPACING,
    VERTEX_RADIUS,
    add_soft_block,
    block_mesh,
    build_soft_rigid,
)


def tet_volumes(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    corners = points[tets]
    return np.linalg.det(corners[:, 1:] - corners[:, :1]) / 6


@pytest.mark.parametrize(
    ("counts", "notch", "n_points", "n_tets", "n_cells"),
    [((3, 4, 3), False, 36, 72, 12), ((4, 4, 3), True, 47, 102, 17)],
)
def test_block_mesh_fills_the_block_with_equal_tets(counts, notch, n_points, n_tets, n_cells):
    points, tets = block_mesh(counts, SPACING, notch=notch)
    assert points.shape == (n_points, 3) and tets.shape == (n_tets, 4)
    np.testing.assert_array_equal(np.unique(tets), np.arange(n_points))  # every point in some tet
    volumes = np.abs(tet_volumes(points, tets))
    np.testing.assert_allclose(volumes, SPACING**3 / 6)
    assert volumes.sum() == pytest.approx(n_cells * SPACING**3)
    np.testing.assert_allclose(points[:, :2].min(axis=0), -points[:, :2].max(axis=0))  # centred
    assert points[:, 2].min() == 0.0


def test_notch_removes_a_top_corner_only():
    full, _ = block_mesh((4, 4, 3), SPACING)
    notched, _ = block_mesh((4, 4, 3), SPACING, notch=True)
    missing = [p for p in full if not np.any(np.all(np.isclose(notched, p), axis=1))]
    np.testing.assert_allclose(missing, [[0.06, 0.06, 0.08]])


@pytest.mark.parametrize(("counts", "spacing"),
                         [((1, 3, 3), 0.04), ((3, 3), 0.04), ((3, 3, 3), 0.0)])
def test_block_mesh_rejects_bad_sizes(counts, spacing):
    with pytest.raises(ValueError, match="counts"):
        block_mesh(counts, spacing)


def test_soft_block_is_placed_turned_and_weighed_as_asked():
    points, tets = block_mesh((3, 4, 3), SPACING)
    heading, xy = 0.4, np.array([0.5, -0.1])
    spec = table_scene_spec(0.004, mujoco.mjtIntegrator.mjINT_DISCRETE)
    add_soft_block(spec, points, tets, xy, heading)
    model = spec.compile()
    assert model.nv == 7 + 3 * len(points) and model.nmesh == 0
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    c, s = math.cos(heading), math.sin(heading)
    expected = points @ np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]]) + [xy[0], xy[1], VERTEX_RADIUS]
    np.testing.assert_allclose(data.flexvert_xpos, expected, atol=1e-12)
    flex = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_FLEX, SOFT_BODY)
    first = model.flex_vertadr[flex]
    bodies = model.flex_vertbodyid[first : first + model.flex_vertnum[flex]]
    volume = np.abs(tet_volumes(points, tets)).sum()
    assert model.body_mass[bodies].sum() == pytest.approx(DENSITY * volume)


def test_soft_rigid_puts_the_soft_body_between_pusher_and_cylinder():
    task = build_soft_rigid(np.random.default_rng(2))
    data = mujoco.MjData(task.model)
    mujoco.mj_setState(task.model, data, task.initial_state, mujoco.mjtState.mjSTATE_INTEGRATION)
    mujoco.mj_forward(task.model, data)
    tip = data.site(task.ee_site).xpos[:2]
    soft = data.flexvert_xpos[:, :2].mean(axis=0)
    cylinder = data.body(task.goal_object).xpos[:2]
    assert 0 < np.dot(soft - tip, cylinder - tip) / np.linalg.norm(cylinder - tip) ** 2 < 1
    cylinder_geom = task.model.geom(task.goal_object).id
    touching = [c for c in data.contact[: data.ncon]
                if cylinder_geom in c.geom and c.flex.max() >= 0]
    assert not touching, "the soft body touches the cylinder at the start"
