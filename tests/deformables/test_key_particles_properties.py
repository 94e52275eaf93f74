"""Property tests of the cloth key particles on folded goals made here, not by deformables.goals.

The goals come from a fold generator of this file's own (the folds of deformables.goals as that
module describes them: diagonal, side, reflective, underneath, but none of its code): a flat grid
of particles is folded about lines of the rest sheet with a sharp crease (the folded part
mirrored and lifted by the gap, the crease row left where it was: edges across the crease
stretch) or a rounded one (the sheet rolled, isometrically, over a half ellipse of height gap
and width about the gap, centred on the crease line). Each goal draws, from a generator seeded
by its number:

* fold: the goal number modulo 4 (an equal count per fold);
* resolution: 12-40 particles per side, square or rectangular (the diagonal fold, a corner
  onto the opposite corner, is a diagonal crease only on a square sheet);
* triangulation: one of the four ways to split the grid squares;
* gap: a quarter to two particle spacings (log-uniform); a rounded crease's arc leaves at
  least half of the narrowest flap flat (a crease cannot be wider than the flap it folds);
* crease: sharp or rounded;
* placement: goal and rest sheet each rotated about z and translated (1 m, table height up to
  1 m), and the fold direction and axis drawn;
* noise: none for a third of the goals, else Gaussian, sigma up to 1 mm per coordinate.

The reference key counts are the folds' corners and crease ends: diagonal 4, side 6,
reflective 8, underneath 10 (tests/deformables/test_deformables_cloth_keys.py). CI runs
``GOALS`` = 208 goals, 52 per fold (about 55 s on one core); seeds 15-19 of the generator
(1040 goals) all hold their counts. Folds whose crease cuts the grid at an arbitrary angle
(the diagonal of a rectangle) are not generated: they do not hold (docs/DESIGN-NOTES.md).
"""
from __future__ import annotations

import logging
from collections import Counter

import numpy as np
import pytest

from deformables import ClothConfig, cloth_key_particles
from deformables.layers import estimate_layer_gap, stacking_axis
from deformables.panels import project_on_panels

FOLDS = ("diagonal", "side", "reflective", "underneath")
KEYS = {"diagonal": 4, "side": 6, "reflective": 8, "underneath": 10}
TRIANGULATIONS = ("main", "anti", "checker", "random")
CREASES = ("sharp", "round")
#: goals generated in CI (an equal share per fold)
GOALS = 208
SEED = 15


# ------------------------------------------------------------------------------- generator
def sheet(nu: int, nv: int, spacing: float) -> np.ndarray:
    """Flat grid ``(nu * nv, 3)`` centred on the origin, particle ``iu * nv + iv``."""
    iu, iv = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    return np.stack([(iu.ravel() - (nu - 1) / 2) * spacing, (iv.ravel() - (nv - 1) / 2) * spacing,
                     np.zeros(nu * nv)], axis=1)


def triangles(nu: int, nv: int, kind: str, rng: np.random.Generator) -> np.ndarray:
    """The grid's squares split along (iu, iv)-(iu+1, iv+1) ("main"), the other diagonal
    ("anti"), the two alternating ("checker") or at random; counter-clockwise from +z."""
    iu, iv = np.meshgrid(np.arange(nu - 1), np.arange(nv - 1), indexing="ij")
    iu, iv = iu.ravel(), iv.ravel()
    a, b = iu * nv + iv, (iu + 1) * nv + iv
    c, d = a + 1, b + 1
    if kind == "random":
        main = rng.integers(0, 2, len(a)).astype(bool)
    else:
        main = {"main": np.ones(len(a), bool), "anti": np.zeros(len(a), bool),
                "checker": (iu + iv) % 2 == 1}[kind]
    first = np.where(main[:, None], np.c_[a, b, d], np.c_[a, b, c])
    second = np.where(main[:, None], np.c_[a, d, c], np.c_[b, d, c])
    return np.concatenate([first, second])


def half_ellipse(width: float, height: float, samples: int = 4001):
    """Arc length ``(S,)`` along x = width sin t, z = height (1 - cos t), t in [0, pi], and the
    points' x and z."""
    t = np.linspace(0.0, np.pi, samples)
    x, z = width * np.sin(t), height * (1.0 - np.cos(t))
    return np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(x), np.diff(z)))]), x, z


def fold(points: np.ndarray, movable: np.ndarray, centre: np.ndarray, normal: np.ndarray,
         base: float, up: bool, gap: float, crease: str, width: float) -> np.ndarray:
    """Fold the ``movable`` particles lying on the plane z = ``base`` beyond the rest line
    through ``centre`` with unit ``normal`` (pointing to the part that moves) back over it,
    onto the plane ``base +- gap``."""
    out = points.copy()
    s = (points[:, :2] - centre) @ normal
    sign = 1.0 if up else -1.0
    if crease == "sharp":
        moved = movable & (s > 1e-12)
        out[moved, :2] -= 2.0 * s[moved, None] * normal
        out[moved, 2] = base + sign * gap
        return out
    arc, x, z = half_ellipse(width, gap / 2)
    s = s + arc[-1] / 2                       # the roll starts half an arc before the line
    moved = movable & (s > 1e-12)
    t = s[moved]
    on_arc = t < arc[-1]
    along = np.where(on_arc, np.interp(t, arc, x), -(t - arc[-1]))
    out[moved, :2] += (along - t)[:, None] * normal
    out[moved, 2] = base + sign * np.where(on_arc, np.interp(t, arc, z), gap)
    return out


def turn(points: np.ndarray, angle: float, shift: np.ndarray) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return points @ np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]).T + shift


def make_goal(number: int, seed: int = SEED) -> dict:
    """Goal ``number``: positions, faces, rest positions and what was drawn (module doc)."""
    rng = np.random.default_rng([seed, number])
    kind = FOLDS[number % len(FOLDS)]
    nu = int(rng.integers(12, 41))
    nv = nu if kind == "diagonal" or rng.random() < 0.5 else int(rng.integers(12, 41))
    spacing = rng.uniform(0.25, 0.45) / (max(nu, nv) - 1)
    rest = sheet(nu, nv, spacing)
    triangulation = TRIANGULATIONS[rng.integers(len(TRIANGULATIONS))]
    faces = triangles(nu, nv, triangulation, rng)
    crease = CREASES[rng.integers(len(CREASES))]
    lu, lv = (nu - 1) * spacing, (nv - 1) * spacing
    aspect = rng.uniform(0.75, 1.5)           # a rounded crease's width / height
    high = 2.0
    if crease == "round":
        flap = {"diagonal": np.hypot(lu, lv) / 4, "side": min(lu, lv) / 2}.get(kind,
                                                                              min(lu, lv) / 4)
        high = min(high, flap / 2 / half_ellipse(aspect / 2, 0.5)[0][-1] / spacing)
    gap = spacing * float(np.exp(rng.uniform(np.log(0.25), np.log(max(high, 0.25)))))
    width = gap / 2 * aspect
    everything = np.ones(len(rest), dtype=bool)
    if kind == "diagonal":
        normal = np.array([lv, lu]) * rng.choice([-1.0, 1.0], 2)
        goal = fold(rest, everything, np.zeros(2), normal / np.linalg.norm(normal), 0.0, True,
                    gap, crease, width)
    else:
        axis = np.eye(2)[rng.integers(2)] * rng.choice([-1.0, 1.0])
        length = lu if axis[0] else lv
        # two probe points follow the folds: the rest points of the quarter creases
        quarter = np.array([[*(length / 4 * axis), 0.0], [*(-length / 4 * axis), 0.0]])
        points = fold(np.concatenate([rest, quarter]), np.r_[everything, True, False],
                      np.zeros(2), axis, 0.0, True, gap, crease, width)
        side = np.r_[rest[:, :2] @ axis, 0.0, 0.0]
        if kind in ("reflective", "underneath"):
            points = fold(points, side > 1e-12, points[-2, :2], -axis, gap, True, gap, crease,
                          width)
        if kind == "underneath":
            points = fold(points, side < -1e-12, points[-1, :2], -axis, 0.0, False, gap, crease,
                          width)
        goal = points[:-2]
    goal = turn(goal, rng.uniform(0.0, 2 * np.pi),
                np.r_[rng.uniform(-1.0, 1.0, 2), rng.uniform(0.0, 1.0)])
    rest_placed = turn(rest, rng.uniform(0.0, 2 * np.pi), np.r_[rng.uniform(-1.0, 1.0, 2), 0.0])
    noise = 0.0 if rng.random() < 1 / 3 else rng.uniform(0.0, 1e-3)
    exact = goal
    if noise:
        goal = goal + rng.normal(0.0, noise, goal.shape)
    return dict(fold=kind, positions=goal, exact=exact, faces=faces, rest=rest_placed, nu=nu,
                nv=nv, spacing=spacing, triangulation=triangulation, crease=crease, gap=gap,
                noise=noise, keys=KEYS[kind])


def describe(g: dict) -> str:
    return (f"{g['fold']} {g['nu']}x{g['nv']} {g['triangulation']} {g['crease']} gap "
            f"{g['gap'] / g['spacing']:.2f} spacings ({g['gap'] * 1e3:.2f} mm), noise "
            f"{g['noise'] * 1e3:.2f} mm")


# ------------------------------------------------------------------- the generator itself
def _edge_lengths(points, faces):
    pairs = np.unique(np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1), axis=0)
    return np.linalg.norm(points[pairs[:, 0]] - points[pairs[:, 1]], axis=1)


@pytest.mark.parametrize("number", range(16))
def test_generator_folds_are_what_they_claim(number):
    """Folds keep the edges away from the creases, rounded ones stretch none; the layers are
    gap apart; each fold has its number of layers; a diagonal fold lays a corner
    exactly over the opposite one."""
    g = make_goal(number, seed=99)
    exact = g["exact"]
    ratio = _edge_lengths(exact, g["faces"]) / _edge_lengths(g["rest"], g["faces"])
    assert np.mean(np.isclose(ratio, 1.0, rtol=1e-9)) > 0.75      # away from the creases
    if g["crease"] == "round":
        assert ratio.max() < 1 + 1e-6              # rolling shortens chords, stretches nothing
    height = (exact - exact.min(axis=0))[:, 2] / g["gap"]
    levels = np.unique(np.round(height[np.isclose(height, np.round(height), atol=1e-9)]))
    assert len(levels) == {"diagonal": 2, "side": 2, "reflective": 3, "underneath": 4}[g["fold"]]
    if g["fold"] == "diagonal":
        n = g["nu"]
        corners = exact[[0, n - 1, n * (n - 1), n * n - 1]]
        close = np.linalg.norm(corners[:, None] - corners[None], axis=2)
        np.fill_diagonal(close, np.inf)
        assert np.isclose(close.min(), g["gap"])


def test_the_generated_goals_cover_every_factor():
    drawn = [make_goal(i) for i in range(GOALS)]
    families = Counter(g["fold"] for g in drawn)
    assert families == {fold: GOALS // 4 for fold in FOLDS}
    for fold in FOLDS:
        mine = [g for g in drawn if g["fold"] == fold]
        assert {g["triangulation"] for g in mine} == set(TRIANGULATIONS)
        assert {g["crease"] for g in mine} == set(CREASES)
        assert any(g["noise"] == 0 for g in mine) and any(g["noise"] > 5e-4 for g in mine)
        assert min(g["nu"] for g in mine) <= 14 and max(g["nu"] for g in mine) >= 38
        gaps = [g["gap"] / g["spacing"] for g in mine]
        assert min(gaps) < 0.35 and max(gaps) > 1.0
        if fold != "diagonal":
            assert any(g["nu"] != g["nv"] for g in mine)


# ------------------------------------------------------------------------- the properties
@pytest.mark.parametrize("number", range(GOALS))
def test_key_count_of_a_generated_goal(number, caplog):
    g = make_goal(number)
    with caplog.at_level(logging.WARNING, logger="deformables"):
        result = cloth_key_particles(g["positions"], g["faces"], rest_positions=g["rest"])
    assert result.reached_threshold, describe(g)
    assert result.n_keys == g["keys"], describe(g)
    assert "never fell below" not in caplog.text


@pytest.mark.parametrize("number", range(0, 64, 3))
def test_estimated_layer_gap(number):
    """Exact goals: the gap itself; noisy ones: within the bias of taking the nearest of a few
    noisy neighbours. The stacking axis is z whatever the rotation about z."""
    g = make_goal(number)
    found = estimate_layer_gap(g["positions"], g["faces"], g["spacing"])
    np.testing.assert_allclose(found.axis, [0.0, 0.0, 1.0], atol=0.02 + 3 * g["noise"] / g["gap"])
    if g["noise"] == 0:
        assert found.gap == pytest.approx(g["gap"], rel=1e-6), describe(g)
    else:
        assert g["gap"] - 1.5 * g["noise"] <= found.gap <= g["gap"] * 1.05, describe(g)


def test_stacking_axis_and_keys_of_a_tilted_goal():
    """A goal turned about a horizontal axis (a sheet that is not lying on the table) gives the
    same keys: the stretch follows the layers' normal, not z."""
    g = make_goal(5)
    angle = 0.7
    c, s = np.cos(angle), np.sin(angle)
    tilt = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    tilted = g["positions"] @ tilt.T
    np.testing.assert_allclose(stacking_axis(tilted, g["faces"]), tilt[:, 2] * np.sign(tilt[2, 2]),
                               atol=0.02)
    upright = cloth_key_particles(g["positions"], g["faces"], rest_positions=g["rest"])
    turned = cloth_key_particles(tilted, g["faces"], rest_positions=g["rest"])
    assert turned.n_keys == upright.n_keys == g["keys"]


@pytest.mark.parametrize("n", [21, 30])
@pytest.mark.parametrize("triangulation", ["main", "anti", "checker"])
def test_the_reported_diagonal_fold(n, triangulation):
    """Issue 15's report: a square sheet folded along its diagonal with a sharp crease and the
    top layer lifted by half a particle spacing gave 8-11 keys, or raised ValueError."""
    spacing = 0.3 / (n - 1)
    rest = sheet(n, n, spacing)
    normal = np.array([1.0, 1.0]) / np.sqrt(2.0)
    goal = fold(rest, np.ones(len(rest), bool), np.zeros(2), normal, 0.0, True, spacing / 2,
                "sharp", 0.0)
    result = cloth_key_particles(goal, triangles(n, n, triangulation, None), rest_positions=rest)
    assert result.reached_threshold and result.n_keys == 4
    corners = rest[[0, n - 1, n * (n - 1), n * n - 1]]
    assert np.linalg.norm(rest[result.indices][:, None] - corners[None], axis=2).min(
        axis=0).max() <= spacing * 1.01


def test_the_paper_pipeline_switch():
    paper = ClothConfig.paper()
    assert (paper.error, paper.z_scale, paper.restarts, paper.coarse_faces,
            paper.shared_faces, paper.panels, paper.canonical_triangulation) == (
        "one-sided", 1.0, 1, None, None, "off", False)
    assert ClothConfig.paper(max_faces=20).max_faces == 20


# -------------------------------------------------------------- what the properties rest on
def _side_fold(n: int, gap_spacings: float, crease: str, spacing: float = 0.02):
    rest = sheet(n, n, spacing)
    goal = fold(rest, np.ones(len(rest), bool), np.zeros(2), np.array([1.0, 0.0]), 0.0, True,
                gap_spacings * spacing, crease, gap_spacings * spacing / 2)
    return goal, triangles(n, n, "main", None), rest


def test_a_crease_through_a_row_is_projected_as_one_step():
    """A rounded crease centred on a row (odd n): that row is as far from both layers' panels
    (0.01 mm of noise decides which is nearer, particle by particle); it goes to one of them
    whole, it is not pulled half-way between the layers."""
    goal, faces, rest = _side_fold(21, 0.5, "round")
    goal = goal + np.random.default_rng(0).normal(0.0, 1e-5, goal.shape)
    fit = project_on_panels(goal, rest, faces, 0.01)
    assert fit.n_panels == 2 and fit.projected.all()
    height = fit.positions[:, 2] / 0.01
    assert np.all(np.isclose(height, 0.0, atol=0.01) | np.isclose(height, 1.0, atol=0.01))
    row = np.isclose(rest[:, 0], 0.0)                      # the crease row
    assert len(set(fit.labels[row])) == 1


def test_panels_three_rows_wide_with_a_sharp_crease_are_found():
    """12 x 12 underneath fold, sharp creases, gap 1.1 spacings: each quarter is three rows
    wide and the neighbourhoods of its edge rows straddle a crease; the quadrant fits still
    find the four panels and the projection moves nothing (the goal is exact)."""
    n, spacing, gap = 12, 0.3 / 11, 1.1 * 0.3 / 11
    rest = sheet(n, n, spacing)
    side = rest[:, 0]
    length = (n - 1) * spacing
    quarter = np.array([[length / 4, 0.0, 0.0], [-length / 4, 0.0, 0.0]])
    points = fold(np.concatenate([rest, quarter]), np.r_[np.ones(n * n, bool), True, False],
                  np.zeros(2), np.array([1.0, 0.0]), 0.0, True, gap, "sharp", 0.0)
    points = fold(points, np.r_[side > 1e-12, False, False], points[-2, :2],
                  np.array([-1.0, 0.0]), gap, True, gap, "sharp", 0.0)
    points = fold(points, np.r_[side < -1e-12, False, False], points[-1, :2],
                  np.array([-1.0, 0.0]), 0.0, False, gap, "sharp", 0.0)
    goal, faces = points[:-2], triangles(n, n, "main", None)
    fit = project_on_panels(goal, rest, faces, gap)
    assert fit.n_panels == 4 and fit.noise < 1e-12
    np.testing.assert_allclose(fit.positions, goal, atol=1e-12)
    result = cloth_key_particles(goal, faces, rest_positions=rest)
    assert result.n_keys == 10 and result.reached_threshold


def test_the_layer_gap_is_the_goals_own():
    """The same fold with gaps of a quarter, a half and two spacings: the estimate is the gap
    and the threshold follows it (here under the stretch cap: 10 gaps)."""
    for gap in (0.25, 0.5, 2.0):
        goal, faces, rest = _side_fold(25, gap, "sharp")
        found = estimate_layer_gap(goal, faces, 0.02)
        assert found.gap == pytest.approx(gap * 0.02, rel=1e-9)
        result = cloth_key_particles(goal, faces, rest_positions=rest)
        side = 24 * 0.02
        stretched = min(10 * gap * 0.02, max(gap * 0.02, side / 6))
        assert result.threshold == pytest.approx(0.35 * stretched, rel=1e-6)
        assert result.n_keys == 6


def test_a_rectangle_folded_across_its_short_side_keeps_crease_ends_a_quarter_apart():
    """12 x 40, reflective fold across the 12-particle side: crease ends 2.75 spacings apart.
    The merge radius comes from the shorter side; from the longer one it merged them (6)."""
    nu, nv, spacing = 12, 40, 0.3 / 39
    rest = sheet(nu, nv, spacing)
    gap, length, axis = 0.5 * spacing, (nu - 1) * spacing, np.array([1.0, 0.0])
    quarter = np.array([[length / 4, 0.0, 0.0], [-length / 4, 0.0, 0.0]])
    points = fold(np.concatenate([rest, quarter]), np.r_[np.ones(nu * nv, bool), True, False],
                  np.zeros(2), axis, 0.0, True, gap, "sharp", 0.0)
    points = fold(points, np.r_[rest[:, 0] > 1e-12, False, False], points[-2, :2], -axis, gap,
                  True, gap, "sharp", 0.0)
    result = cloth_key_particles(points[:-2], triangles(nu, nv, "anti", None),
                                 rest_positions=turn(rest, 0.6, np.zeros(3)))
    assert result.n_keys == 8


# ---------------------------------------------------------------- folds as a simulator leaves them
WRINKLED_GOALS = 40
WRINKLE_HEIGHT = 0.015


def wrinkle(g: dict, rng: np.random.Generator, height: float = WRINKLE_HEIGHT) -> np.ndarray:
    """The goal lifted along its stacking axis (z) by three smooth bulges of the surface under
    it (Gaussian, widths 8-20 % of the sheet, heights 30-100 % of ``height``), a function of
    the position over the floor, so that the layers keep their order and their gaps: a fold
    lying on a crumpled underlayer, or sagging and wrinkled panels as the MuJoCo folds leave
    them (docs/RESULTS.md, "Goals made by the simulator": panels turned by tens of degrees)."""
    positions = g["positions"].copy()
    xy = positions[:, :2].copy()
    side = float(np.ptp(g["rest"], axis=0).max())
    for _ in range(3):
        centre = xy[rng.integers(len(xy))]
        width = rng.uniform(0.08, 0.2) * side
        positions[:, 2] += rng.uniform(0.3, 1.0) * height * np.exp(
            -((xy - centre) ** 2).sum(axis=1) / (2.0 * width ** 2))
    return positions


# panels="fold" fits each panel on its own, so the two fits of a bulged pair of layers need not
# meet on their crease line; where they miss by more than the threshold, the model keeps a
# vertex on the crease (one extra key). Measured once on goals 0-199 of this family: 6 do so
# (the default projection misses 15).
_CREASE_KINK = {9}


@pytest.mark.parametrize("number", [
    pytest.param(n, marks=pytest.mark.xfail(strict=True, reason="crease kink, see above"))
    if n in _CREASE_KINK else n for n in range(WRINKLED_GOALS)])
def test_key_count_of_a_wrinkled_goal_under_the_fold_mode(number):
    g = make_goal(number, seed=SEED + 2)
    positions = wrinkle(g, np.random.default_rng([99, number]))
    result = cloth_key_particles(positions, g["faces"], rest_positions=g["rest"],
                                 config=ClothConfig(panels="fold"))
    assert result.reached_threshold, describe(g)
    assert result.n_keys == g["keys"], describe(g)
