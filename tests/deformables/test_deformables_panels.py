"""Panel projection of noisy folded-cloth goals (deformables.panels)."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from deformables import ClothConfig, goals
from deformables.panels import project_on_panels, rigid_fit

# flat panels of each fold (a Z-fold has three layers, the underneath fold four)
PANELS = {"cloth_flat": 1, "cloth_diagonal": 2, "cloth_side": 2, "cloth_reflective": 3,
          "cloth_underneath": 4}


def test_rigid_fit_matches_scipy_align_vectors_on_noisy_sets():
    rng = np.random.default_rng(0)
    rest = rng.normal(size=(5, 12, 3))
    truth = Rotation.random(5, random_state=1)
    goal = np.stack([truth[b].apply(rest[b]) for b in range(5)]) + rng.normal(size=(5, 1, 3))
    goal += rng.normal(0.0, 0.05, goal.shape)
    rot, shift, rms = rigid_fit(rest, goal)
    for b in range(5):
        centred_goal = goal[b] - goal[b].mean(axis=0)
        centred_rest = rest[b] - rest[b].mean(axis=0)
        reference, _ = Rotation.align_vectors(centred_goal, centred_rest)
        np.testing.assert_allclose(rot[b], reference.as_matrix(), atol=1e-9)
        np.testing.assert_allclose(np.linalg.det(rot[b]), 1.0, atol=1e-12)
        fitted = rest[b] @ rot[b].T + shift[b]
        np.testing.assert_allclose(rms[b], np.sqrt(((fitted - goal[b]) ** 2).sum(1).mean()))


def test_rigid_fit_of_planar_sets_is_a_rotation_not_a_reflection():
    rng = np.random.default_rng(2)
    rest = np.c_[rng.normal(size=(1, 20, 2))[0], np.zeros(20)][None]
    flip = Rotation.from_euler("x", 180, degrees=True)          # the fold of a flat panel
    rot, shift, rms = rigid_fit(rest, flip.apply(rest[0])[None] + [0.0, 0.0, 0.005])
    np.testing.assert_allclose(rot[0], flip.as_matrix(), atol=1e-12)
    np.testing.assert_allclose(shift[0], [0.0, 0.0, 0.005], atol=1e-12)
    assert rms[0] < 1e-12


@pytest.mark.parametrize("name", sorted(PANELS))
@pytest.mark.parametrize("n, triangulation", [(16, "random"), (25, "mujoco"), (40, "anti")])
def test_projection_finds_the_folds_panels_and_removes_most_of_the_noise(name, n, triangulation):
    rng = np.random.default_rng(n)
    g = goals.make_goal(name, n=n, triangulation=triangulation, rng=rng)
    sigma = 1e-3
    noisy = g.positions + rng.normal(0.0, sigma, g.positions.shape)
    fit = project_on_panels(noisy, g.rest_positions, g.faces, g.layer_gap)
    assert fit.n_panels == PANELS[name]
    assert 0.5 * sigma < fit.noise < 2 * sigma
    # away from the creases (rest distance > 2 spacings from a particle of another panel)
    spacing = 0.3 / (n - 1)
    other = fit.labels[:, None] != fit.labels[None]
    gap_to_other = np.where(other, np.linalg.norm(
        g.rest_positions[:, None] - g.rest_positions[None], axis=2), np.inf).min(axis=1)
    inner = fit.projected & (gap_to_other > 2 * spacing)
    assert inner.mean() > 0.3          # the four quarters of a 16 x 16 underneath fold: 0.44
    before = np.sqrt(((noisy - g.positions)[inner] ** 2).sum(1).mean())
    after = np.sqrt(((fit.positions - g.positions)[inner] ** 2).sum(1).mean())
    assert after < before / 5


def test_a_clean_goal_is_projected_onto_itself_away_from_the_crease():
    g = goals.cloth_side(n=25)
    fit = project_on_panels(g.positions, g.rest_positions, g.faces, g.layer_gap)
    assert fit.noise < 1e-9
    # at 25 per side no particle lies on the crease's arc (rest 0 < x < 7.9 mm) and the fitted
    # line runs between two columns, farther than the blend's reach: the projection is exact
    np.testing.assert_allclose(fit.positions, g.positions, atol=1e-9)
    x = g.rest_positions[:, 0]
    under, over = fit.labels[x < 0], fit.labels[x > np.pi * g.layer_gap / 2]   # past the arc
    assert len(set(under)) == len(set(over)) == 1 and under[0] != over[0]


def test_an_exact_fold_with_panels_three_particles_wide_reads_as_noise_free():
    g = goals.cloth_underneath(n=12)
    fit = project_on_panels(g.positions, g.rest_positions, g.faces, g.layer_gap)
    assert fit.n_panels == 4
    assert fit.noise < 1e-9


def test_min_noise_leaves_an_exact_goal_as_given_and_projects_a_noisy_one():
    g = goals.cloth_diagonal(n=16)
    exact = project_on_panels(g.positions, g.rest_positions, g.faces, g.layer_gap, min_noise=5e-5)
    assert not exact.projected.any() and (exact.labels == -1).all()
    assert exact.positions is g.positions and exact.n_panels == 2
    noisy = g.positions + np.random.default_rng(3).normal(0.0, 1e-4, g.positions.shape)
    fit = project_on_panels(noisy, g.rest_positions, g.faces, g.layer_gap, min_noise=5e-5)
    assert fit.noise > 5e-5 and fit.projected.all()


def test_a_region_no_panel_explains_keeps_its_measured_positions():
    g = goals.cloth_flat(n=25)
    bumped = g.positions.copy()
    r = np.linalg.norm(g.rest_positions[:, :2] - [0.08, 0.08], axis=1)
    bump = r < 0.04
    bumped[bump, 2] += 0.03 * np.cos(np.pi * r[bump] / 0.08)    # a 3 cm dome, not flat
    bumped += np.random.default_rng(0).normal(0.0, 2e-4, bumped.shape)
    fit = project_on_panels(bumped, g.rest_positions, g.faces, g.layer_gap)
    top = bump & (bumped[:, 2] > 0.01)
    assert top.sum() > 10
    assert not fit.projected[top].any()
    np.testing.assert_array_equal(fit.positions[top], bumped[top])
    assert fit.projected[r > 0.08].all()


def test_panel_mode_is_checked():
    with pytest.raises(ValueError, match="panels"):
        ClothConfig(panels="yes")


def _hinged_sheet(turn_deg: float, n: int = 20, spacing: float = 0.015):
    """A flat n x n sheet bent sharply along x = 0 by ``turn_deg`` (the half x > 0 turns
    about the y axis): rest, goal and faces."""
    u, v = np.meshgrid(np.arange(n) - (n - 1) / 2, np.arange(n) - (n - 1) / 2, indexing="ij")
    rest = np.c_[u.ravel(), v.ravel(), np.zeros(n * n)] * spacing
    turned = Rotation.from_euler("y", -turn_deg, degrees=True).apply(rest)
    goal = np.where((rest[:, 0] > 0)[:, None], turned, rest)
    i = np.arange(n - 1)[:, None] * n + np.arange(n - 1)[None]
    faces = np.r_[np.c_[i.ravel(), i.ravel() + n, i.ravel() + 1],
                  np.c_[i.ravel() + 1, i.ravel() + n, i.ravel() + n + 1]]
    return rest, goal, faces


@pytest.mark.parametrize("turn_deg, merged", [(40.0, True), (50.0, True), (90.0, False),
                                              (179.0, False)])
def test_merging_joins_a_wrinkle_and_keeps_a_fold(turn_deg, merged):
    """Two halves turned by 40-50 degrees are two panels (local fits differ by more than
    ``angle_deg`` = 30) that ``merge_deg`` = 60 joins into one; a right-angle or a flat fold
    stays two."""
    rest, goal, faces = _hinged_sheet(turn_deg)
    assert project_on_panels(goal, rest, faces, 0.005).n_panels == 2
    fit = project_on_panels(goal, rest, faces, 0.005, merge_deg=60.0, tolerance=np.inf)
    assert fit.n_panels == (1 if merged else 2)
    assert fit.projected.all()
    if merged:      # one rigid fit of a bent sheet: every particle moved onto one plane
        normal = np.linalg.svd(fit.positions - fit.positions.mean(axis=0))[2][2]
        assert np.abs((fit.positions - fit.positions.mean(axis=0)) @ normal).max() < 1e-9


def test_fold_mode_rejects_bad_merge_angles():
    rest, goal, faces = _hinged_sheet(40.0, n=6)
    for bad in (0.0, -5.0, 181.0, float("nan")):
        with pytest.raises(ValueError, match="merge_deg"):
            project_on_panels(goal, rest, faces, 0.005, merge_deg=bad)
    with pytest.raises(ValueError, match="fold_merge_deg"):
        ClothConfig(panels="fold", fold_merge_deg=0.0)
    with pytest.raises(ValueError, match="panels must be one of"):
        ClothConfig(panels="folded")
