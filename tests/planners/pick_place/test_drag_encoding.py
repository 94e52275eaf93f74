"""The authors' drag encoding (planners.pick_place.drag, dopt.tasks.pick.drag,
planners.gaussian_cem): the pick scalar lands on the candidate the authors' interp1d picks,
at every bin edge; a virtual point moves with its triangle; the plain CEM minimises."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.interpolate import interp1d

from dopt.tasks.pick.cloth_scene import ClothSceneConfig, make_cloth
from dopt.tasks.pick.constraints import ActionConstraint
from dopt.tasks.pick.drag import DragConfig, DragSimulator, VirtualPoints
from dopt.tasks.pick.picker import PickerConfig
from planners.gaussian_cem import GaussianCEM, GaussianCEMConfig
from planners.pick_place import PickPlaceSettings, make_planner
from planners.pick_place.drag import decode, grid_points, pick_index
from planners.pick_place.drag_settings import DragSettings


def authors_pick(a: float, n: int):
    """The particle the authors' Picker.step grasps for scalar a over all n particles
    (reset_action_space(None): key_point_index = linspace(0, n - 1, n)), None for none."""
    key_point_index = np.linspace(0, n - 1, n)
    f = interp1d(np.linspace(0, 1, n + 2), np.linspace(0, n + 1, n + 2))
    i = np.floor(f(a))
    return None if i >= n else int(np.int32(key_point_index[np.int32(i)]))


def edges(n: int) -> np.ndarray:
    """Every bin edge of n candidates (the interpolation's nodes) and its float neighbours."""
    x = np.linspace(0, 1, n + 2)
    near = np.concatenate([x, np.nextafter(x, 2.0), np.nextafter(x, -1.0)])
    return np.unique(np.clip(near, 0.0, 1.0))


@pytest.mark.parametrize("n", [4, 10_000])
def test_pick_index_matches_interp1d_at_every_bin_edge(n):
    a = edges(n)
    ours = pick_index(a, n)
    theirs = np.array([-1 if (p := authors_pick(v, n)) is None else p for v in a])
    np.testing.assert_array_equal(ours, theirs)
    # the edges really separate neighbouring candidates, and the last bin is None
    assert set(np.unique(ours)) == set(range(n)) | {-1}
    assert pick_index(1.0, n) == -1 and pick_index(0.0, n) == 0


@settings(max_examples=200, deadline=None)
@given(st.floats(0.0, 1.0), st.integers(1, 50))
def test_pick_index_matches_interp1d_anywhere(a, n):
    p = authors_pick(a, n)
    assert int(pick_index(a, n)) == (-1 if p is None else p)


def test_decode_denormalises_like_softagent():
    u = np.array([[-1.0, 1.0, 0.0, -1.0, 0.2, -0.4, 1.0, 1.0]])
    picks, moves = decode(u, 4, 0.01)
    np.testing.assert_allclose(moves, [[[-0.01, 0.01, 0.0], [0.002, -0.004, 0.01]]])
    assert picks.tolist() == [[0, -1]]             # a = 0 -> first candidate, a = 1 -> None


def test_bad_pick_scalars_and_settings():
    with pytest.raises(ValueError, match=r"\[0, 1\]"):
        pick_index([0.5, 1.2], 4)
    with pytest.raises(ValueError, match="perfect square"):
        DragSettings(n_points=99)
    s = PickPlaceSettings.preset("cloth", "diagonal", quick=True)
    with pytest.raises(ValueError, match="settings.drag"):
        make_planner("original-drag", s, 0)


def test_settings_without_drag_keep_their_form_and_with_it_round_trip():
    s = PickPlaceSettings.preset("cloth", "side", quick=True)
    assert "drag" not in s.to_dict() and "drag" not in s.identity()
    d = replace(s, drag=DragSettings(n_points=100, substeps=2))
    assert PickPlaceSettings.from_dict(d.to_dict()) == d
    assert d.identity() != s.identity()


@pytest.fixture(scope="module")
def cloth():
    side = 0.2
    return make_cloth(ClothSceneConfig.physics("default", n=6, side=side),
                      PickerConfig(bound=(0.08,) * 3, workspace=ActionConstraint.table(side)))


def test_virtual_points_follow_an_affine_map_of_the_mesh(cloth):
    rng = np.random.default_rng(7)
    rest = cloth.positions(cloth.initial_state)
    lo, hi = rest[:, :2].min(0), rest[:, :2].max(0)
    pts = np.column_stack([rng.uniform(lo, hi, (50, 2)), np.full(50, rest[:, 2].mean())])
    vp = VirtualPoints(rest, cloth.elements, pts)
    assert np.all(vp.weights >= 0) and np.allclose(vp.weights.sum(1), 1)
    # barycentric weights reproduce the points at rest (the sheet is flat: z is the mean)
    np.testing.assert_allclose(vp.positions(rest)[:, :2], pts[:, :2], atol=1e-12)
    # and move them with any affine map of the vertices, as points of their triangles
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    A, b = q * 1.7, rng.normal(size=3)
    moved = rest @ A.T + b
    np.testing.assert_allclose(vp.positions(moved), vp.positions(rest) @ A.T + b, atol=1e-12)


def test_grid_points_on_vertices_sit_on_them(cloth):
    rest = cloth.positions(cloth.initial_state)
    vp = VirtualPoints(rest, cloth.elements, grid_points(rest, 6))
    # a 6 x 6 grid on a 6 x 6 sheet: every point is its vertex (weight 1), same numbering
    heavy = vp.triangles[np.arange(36), vp.weights.argmax(1)]
    np.testing.assert_array_equal(heavy, np.arange(36))
    np.testing.assert_allclose(vp.weights.max(1), 1.0, atol=1e-9)


def test_a_grasped_virtual_point_moves_with_its_triangle(cloth):
    rest = cloth.positions(cloth.initial_state)
    centre = rest[cloth.elements[21]].mean(0)[None]                 # a triangle's centroid
    vp = VirtualPoints(rest, cloth.elements, centre)
    np.testing.assert_allclose(vp.weights, 1 / 3, atol=1e-9)
    sim = DragSimulator(cloth, DragConfig(substeps=2, settle=0.0))
    move = np.array([0.01, -0.005, 0.004])
    res = sim.run(cloth.initial_state, vp, np.zeros((1, 2), int), np.tile(move, (1, 2, 1)))
    assert not res.stability.unstable[0], res.stability.reason
    for t in range(2):
        at = vp.positions(cloth.positions(res.decision_states[0, t]))[0]
        # the grasped point travels with the picker: repeat substeps of the move each decision
        np.testing.assert_allclose(at - centre[0], (t + 1) * 8 * move, atol=1.5e-3)
    # its triangle kept its shape (held rigidly), while the sheet around it deformed
    tri = vp.triangles[0]
    before, after = rest[tri], cloth.positions(res.decision_states[0, 1])[tri]
    np.testing.assert_allclose(np.linalg.norm(after[1:] - after[0], axis=1),
                               np.linalg.norm(before[1:] - before[0], axis=1), rtol=0.02)


def test_gaussian_cem_finds_the_minimum_of_a_bowl_in_a_box():
    target = torch.tensor([0.3, -0.7, 0.9], dtype=torch.float64)

    def cost(x):
        return ((x - target) ** 2).sum(1)

    cem = GaussianCEM(GaussianCEMConfig(population=64, elites=6, iterations=25))
    a = cem.plan(cost, -np.ones(3), np.ones(3), torch.Generator().manual_seed(3))
    b = cem.plan(cost, -np.ones(3), np.ones(3), torch.Generator().manual_seed(3))
    np.testing.assert_array_equal(a.best, b.best)                  # the seed fixes it
    assert np.linalg.norm(a.best - target.numpy()) < 0.05
    assert a.cost == pytest.approx(float(cost(torch.from_numpy(a.best)[None])[0]))
    assert np.all(np.diff(a.cost_history) <= 0)                    # the best never worsens
