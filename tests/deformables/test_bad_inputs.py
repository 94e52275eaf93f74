"""Every bad input of deformables gets a clear error naming the argument, and no failure passes
as a result: robust rope thresholds and ends (outliers, gaps, coarse ropes, property tests on
random polylines), non-manifold cloth meshes and rest shapes that do not match the goal."""
import logging

import numpy as np
import pytest

from deformables import (
    ClothConfig,
    RopeConfig,
    cloth_key_particles,
    goal_sequence,
    goals,
    make_goal,
    rope_key_particles,
)
from deformables.layers import estimate_layer_gap
from deformables.panels import panel_weights, project_on_panels, rigid_fit


# ------------------------------------------------------------------------ rope geometry
def polyline_rope(lengths, turns, n, rng=None, noise=0.0):
    """A rope of ``n`` evenly spaced particles along a planar polyline with segment
    ``lengths`` (in particle spacings, summing to n - 1) turning by ``turns`` (rad) at its
    corners, placed by a random rotation and translation when ``rng`` is given, with uniform
    noise of at most ``noise`` metres per coordinate. The spacing is 1 cm.

    Returns positions (n, 3), the corners' chain positions (in particles, between particles in
    general) and the unit normal of the polyline's plane."""
    lengths = np.asarray(lengths, float)
    heading = np.concatenate([[0.0], np.cumsum(turns)])
    steps = lengths[:, None] * 0.01 * np.c_[np.cos(heading), np.sin(heading)]
    vertices = np.concatenate([[[0.0, 0.0]], np.cumsum(steps, axis=0)])
    at = np.concatenate([[0.0], np.cumsum(lengths)])
    chain = np.arange(n, dtype=float)
    p = np.c_[np.stack([np.interp(chain, at, vertices[:, d]) for d in range(2)], axis=1),
              np.zeros(n)]
    normal = np.array([0.0, 0.0, 1.0])
    if rng is not None:
        rotation, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        p = p @ rotation.T + rng.uniform(-1.0, 1.0, 3)
        normal = rotation @ normal
        p += rng.uniform(-noise, noise, p.shape)
    return p, at[1:-1], normal


def corner_cost(corners, turns, features, n):
    """Roughly what dropping each corner costs Alg. 1, in thresholds: the triangle a corner
    spans with its neighbouring features (ends, other corners, ``features``), over the rope's
    length, over the default threshold of half a spacing (a b sin(turn) / (n - 1), lengths in
    spacings)."""
    every = np.sort(np.concatenate([[0, n - 1], corners, features]))
    cost = []
    for c, t in zip(corners, turns, strict=True):
        before, after = every[every < c - 1e-9].max(), every[every > c + 1e-9].min()
        cost.append((c - before) * (after - c) * abs(np.sin(t)) / (n - 1))
    return np.array(cost)


def random_segments(rng, n, min_turn=0.0, max_turn=np.radians(170)):
    """2-5 segments of random relative lengths (summing to n - 1 spacings), random turns of
    magnitude in [min_turn, max_turn] and random sign."""
    count = int(rng.integers(2, 6))
    lengths = rng.uniform(0.5, 1.5, count)
    lengths *= (n - 1) / lengths.sum()
    turns = rng.uniform(min_turn, max_turn, count - 1) * rng.choice([-1.0, 1.0], count - 1)
    return lengths, turns


def assert_ends_and_corners(keys, n, corners):
    assert keys[0] == 0 and keys[-1] == n - 1, keys
    for c in corners:
        assert np.min(np.abs(keys - c)) <= 1, (keys, corners)


L_SHAPE = ([23.0, 16.0], [np.pi / 2])                       # 40 particles, corner at 23
Z_SHAPE = ([12.0, 15.0, 12.0], [np.radians(143), -np.radians(143)])   # corners at 12, 27


@pytest.mark.parametrize("shape, outlier", [(L_SHAPE, 10), (L_SHAPE, 32), (Z_SHAPE, 6),
                                            (Z_SHAPE, 20), (Z_SHAPE, 33)])
def test_an_outlier_particle_keeps_the_ends_and_corners_and_becomes_a_key(shape, outlier):
    """One particle 2 m off the rope used to inflate the threshold 9x (mean spacing) and take
    the samples placed by arc length: the keys lost the ends and corners."""
    lengths, turns = shape
    p, corners, normal = polyline_rope(lengths, turns, 40)
    clean = rope_key_particles(p)
    assert_ends_and_corners(clean.indices, 40, corners)
    p[outlier] += 2.0 * normal
    result = rope_key_particles(p)
    assert_ends_and_corners(result.indices, 40, corners)
    assert outlier in result.indices
    assert result.threshold == pytest.approx(clean.threshold)     # median spacing: unmoved


@pytest.mark.parametrize("shape, split", [(L_SHAPE, 10), (Z_SHAPE, 20), (Z_SHAPE, 33)])
def test_a_gap_in_the_chain_keeps_the_ends_and_corners(shape, split):
    lengths, turns = shape
    p, corners, normal = polyline_rope(lengths, turns, 40)
    threshold = rope_key_particles(p).threshold
    p[split:] += 5.0 * np.array([1.0, 0.0, 0.0])
    result = rope_key_particles(p)
    assert_ends_and_corners(result.indices, 40, corners)
    assert {split - 1, split} <= set(result.indices.tolist())
    assert result.threshold == pytest.approx(threshold)


@pytest.mark.parametrize("n", [4, 5, 6, 7])   # n=3 cannot hold its 4 corners (below)
def test_a_coarse_fold_keeps_both_ends(n):
    """A 5-particle crossed triangle used to give keys [1, 3], neither an end."""
    keys = rope_key_particles(goals.rope_crossed_triangle(n=n).positions).indices
    assert keys[0] == 0 and keys[-1] == n - 1


def test_threshold_is_half_the_median_spacing():
    """A straight rope of 21 edges of 1 cm and 18 of 1.8 cm: half the median spacing (5 mm),
    not of the mean (7 mm), and its two ends."""
    x = np.concatenate([[0.0], np.cumsum([0.01] * 21 + [0.018] * 18)])
    result = rope_key_particles(np.c_[x, np.zeros((40, 2))])
    assert result.threshold == pytest.approx(0.005)
    np.testing.assert_array_equal(result.indices, [0, 39])


def test_random_ropes_always_keep_both_ends():
    """120 random polylines: 2-5 segments, any turn up to 170 degrees, 5-80 particles,
    random rigid placement, noise up to 1 mm."""
    rng = np.random.default_rng(20240601)
    for _ in range(120):
        n = int(rng.integers(5, 81))
        lengths, turns = random_segments(rng, n)
        p, _, _ = polyline_rope(lengths, turns, n, rng, noise=rng.uniform(0.0, 1e-3))
        keys = rope_key_particles(p).indices
        assert keys[0] == 0 and keys[-1] == n - 1, (n, keys)
        assert np.all(np.diff(keys) > 0) and keys.dtype == np.int64


def test_random_ropes_keep_every_sharp_corner():
    """120 random polylines whose corners all turn by 30-150 degrees and are features Alg. 1
    must keep (dropping any costs at least two thresholds, see ``corner_cost``): a key within
    one particle of every corner. Mean-error fitting (Eq. 3) may legitimately drop a corner
    that costs less, or shift a sharp corner's key by a particle or two to help an unresolved
    gentle neighbour, so those ropes are redrawn."""
    rng = np.random.default_rng(7)
    ropes = 0
    while ropes < 120:
        n = int(rng.integers(5, 81))
        lengths, turns = random_segments(rng, n, np.radians(30), np.radians(150))
        corners = np.cumsum(lengths)[:-1]
        if corner_cost(corners, turns, [], n).min() < 2.0:
            continue
        ropes += 1
        p, corners, _ = polyline_rope(lengths, turns, n, rng, noise=rng.uniform(0.0, 1e-3))
        assert_ends_and_corners(rope_key_particles(p).indices, n, corners)


def test_random_ropes_with_an_outlier_or_a_gap_keep_ends_and_corners():
    """120 random ropes, every other one with a particle 2 m off its plane, the others with
    the chain cut and moved 5 m: ends, corners (costing >= 3 thresholds with the outlier or
    gap as a feature) and the outlier or the gap's two particles are keys."""
    rng = np.random.default_rng(11)
    ropes = 0
    while ropes < 120:
        n = int(rng.integers(12, 81))
        lengths, turns = random_segments(rng, n, np.radians(30), np.radians(150))
        corners = np.cumsum(lengths)[:-1]
        at = int(rng.integers(3, n - 3))
        outlier = ropes % 2 == 0
        features = [at - 1, at, at + 1] if outlier else [at - 1, at]
        if (np.min(np.abs(corners[:, None] - np.array(features)[None])) < 1.5
                or corner_cost(corners, turns, features, n).min() < 3.0):
            continue
        ropes += 1
        p, corners, normal = polyline_rope(lengths, turns, n, rng, noise=rng.uniform(0.0, 1e-3))
        if outlier:
            p[at] += 2.0 * normal
        else:
            p[at:] += 5.0 * normal
        keys = rope_key_particles(p).indices
        assert_ends_and_corners(keys, n, corners)
        assert set(features[1:2] if outlier else features) <= set(keys.tolist()), (at, keys)


# ------------------------------------------------------------------------ cloth meshes
@pytest.fixture(scope="module")
def side8():
    return goals.cloth_side(n=8)


def test_a_fin_face_is_reduced_with_a_non_manifold_warning(side8, caplog):
    g = side8
    fin = np.vstack([g.faces, [[g.faces[10][0], g.faces[10][1], 40]]])
    with caplog.at_level(logging.WARNING, logger="deformables.validation"):
        result = cloth_key_particles(g.positions, fin, rest_positions=g.rest_positions)
    assert "non-manifold: 1 edges shared by more than two faces" in caplog.text
    assert result.n_keys >= 4


def test_two_sheets_meeting_at_a_vertex_are_reported(caplog):
    """A bowtie: a second 4 x 4 sheet whose corner is the first sheet's last corner."""
    first = goals.cloth_flat(n=4)
    rest = np.vstack([first.rest_positions, goals.cloth_rest(4)[1:] + [0.3, 0.3, 0.0]])
    second = goals.grid_faces(4) + 15                   # its vertex 0 -> the first sheet's 15
    faces = np.vstack([first.faces, second])
    with caplog.at_level(logging.WARNING, logger="deformables.validation"):
        cloth_key_particles(rest, faces, rest_positions=rest)
    assert "0 edges shared by more than two faces" in caplog.text
    assert "1 vertices where separate sheets meet (first: 15)" in caplog.text


def test_a_manifold_goal_gives_no_warning(side8, caplog):
    with caplog.at_level(logging.WARNING, logger="deformables.validation"):
        cloth_key_particles(side8.positions, side8.faces, rest_positions=side8.rest_positions)
    assert caplog.text == ""


@pytest.mark.parametrize("rest", ["permuted", "other sheet", "millimetres"])
def test_rest_positions_that_do_not_match_the_goal_are_named(side8, rest):
    """A wrong rest mapping used to be blamed on 'zero-area faces' or passed silently."""
    r = np.array(side8.rest_positions)
    wrong = {"permuted": r[np.random.default_rng(0).permutation(len(r))],
             "other sheet": goals.cloth_rest(8, side=1.0),
             "millimetres": r * 1e3}[rest]
    with pytest.raises(ValueError, match="rest_positions do not match positions"):
        cloth_key_particles(side8.positions, side8.faces, rest_positions=wrong)


def test_a_goal_particle_off_the_sheet_is_warned_about(side8, caplog):
    """A fold never stretches an edge; a goal particle 20 cm off the sheet does."""
    p = np.array(side8.positions)
    p[20, 2] += 0.2
    with caplog.at_level(logging.WARNING, logger="deformables.validation"):
        cloth_key_particles(p, side8.faces, rest_positions=side8.rest_positions,
                            config=ClothConfig(max_faces=60))
    assert "goal edges are more than 3 times their rest length (most: edge" in caplog.text


def test_particles_in_no_face_raise(side8):
    with pytest.raises(ValueError, match="particles belong to no face"):
        cloth_key_particles(side8.positions, side8.faces[:60],
                            rest_positions=side8.rest_positions)


# ------------------------------------------------------------------ argument checks
ROPE = goals.rope_crossed_triangle(n=20).positions


@pytest.mark.parametrize("positions, error, match", [
    (None, TypeError, "positions must be an array"),
    ("abc", TypeError, "positions must be a numeric array"),
    (ROPE > 0, TypeError, "positions must be a numeric array"),
    ([[0, 0, 0], [1, 0]], ValueError, "positions is not a rectangular array"),
    (ROPE[None], ValueError, r"positions must have shape \(N, 3\)"),
    (ROPE[:, :2], ValueError, r"positions must have shape \(N, 3\)"),
    (ROPE.ravel(), ValueError, r"positions must have shape \(N, 3\)"),
    (np.where(np.arange(20)[:, None] == 4, np.nan, ROPE), ValueError, "positions has 1 .*NaN"),
    (np.where(np.arange(20)[:, None] == 4, np.inf, ROPE), ValueError, "positions has 1 .*inf"),
])
def test_rope_positions(positions, error, match):
    with pytest.raises(error, match=match):
        rope_key_particles(positions)


@pytest.mark.parametrize("kwargs, error, match", [
    (dict(threshold=np.nan), ValueError, "threshold must be a positive finite"),
    (dict(threshold=np.inf), ValueError, "threshold must be a positive finite"),
    (dict(threshold=0.0), ValueError, "threshold must be a positive finite"),
    (dict(threshold=True), TypeError, "threshold must be a number"),
    (dict(threshold="0.01"), TypeError, "threshold must be a number"),
    (dict(threshold=np.array([0.1, 0.2])), TypeError, "threshold must be a number"),
    (dict(config={"fit": "fixed"}), TypeError, "config must be a RopeConfig"),
])
def test_rope_threshold_and_config(kwargs, error, match):
    with pytest.raises(error, match=match):
        rope_key_particles(ROPE, **kwargs)


@pytest.mark.parametrize("kwargs, error, match", [
    (dict(fit="spline"), ValueError, "unknown rope fit"),
    (dict(fit=None), ValueError, "unknown rope fit"),
    (dict(n_samples=1.5), TypeError, "RopeConfig.n_samples must be an int"),
    (dict(n_samples=True), TypeError, "RopeConfig.n_samples must be an int"),
    (dict(n_samples=1), ValueError, "RopeConfig.n_samples must be at least 20"),
    (dict(n_samples=19), ValueError, "RopeConfig.n_samples must be at least 20, got 19"),
    (dict(threshold_spacings=np.nan), ValueError, "RopeConfig.threshold_spacings"),
    (dict(threshold_spacings=-0.5), ValueError, "RopeConfig.threshold_spacings"),
    (dict(threshold_spacings="0.5"), TypeError, "RopeConfig.threshold_spacings"),
    (dict(max_vertices=2.5), TypeError, "RopeConfig.max_vertices must be an int"),
    (dict(max_vertices=1), ValueError, "RopeConfig.max_vertices must be at least 2"),
])
def test_rope_config_fields(kwargs, error, match):
    with pytest.raises(error, match=match):
        RopeConfig(**kwargs)


CLOTH = goals.cloth_side(n=6)


def _faces(kind):
    f = np.array(CLOTH.faces)
    return {"float": f + 0.5, "bool": f > 3, "str": "abc", "none": None, "1d": f.ravel(),
            "2 columns": f[:, :2], "out of range": np.where(f == 7, 36, f),
            "negative": np.where(f == 7, -1, f), "empty": f[:0]}[kind]


@pytest.mark.parametrize("kind, error, match", [
    ("float", ValueError, "faces must hold integer vertex indices"),
    ("bool", TypeError, "faces must be a numeric array"),
    ("str", TypeError, "faces must be a numeric array"),
    ("none", TypeError, "faces must be an array"),
    ("1d", ValueError, r"faces must have shape \(F, 3\)"),
    ("2 columns", ValueError, r"faces must have shape \(F, 3\)"),
    ("out of range", ValueError, "faces index particles out of range"),
    ("negative", ValueError, "faces index particles out of range"),
    ("empty", ValueError, "faces is empty"),
])
def test_cloth_faces(kind, error, match):
    with pytest.raises(error, match=match):
        cloth_key_particles(CLOTH.positions, _faces(kind), rest_positions=CLOTH.rest_positions)


@pytest.mark.parametrize("kwargs, error, match", [
    (dict(positions=np.full((36, 3), np.nan)), ValueError, "positions has 36 .*NaN"),
    (dict(positions=CLOTH.positions[:, :2]), ValueError, r"positions must have shape"),
    (dict(positions="x"), TypeError, "positions must be a numeric array"),
    (dict(rest_positions=np.full((36, 3), np.inf)), ValueError, "rest_positions has 36"),
    (dict(rest_positions=CLOTH.rest_positions[:30]), ValueError, "rest_positions .* differ"),
    (dict(rest_positions=CLOTH.rest_positions > 0), TypeError, "rest_positions must be a num"),
    (dict(threshold=-1.0), ValueError, "threshold must be a positive finite"),
    (dict(threshold="1"), TypeError, "threshold must be a number"),
    (dict(config={}), TypeError, "config must be a ClothConfig"),
    (dict(rest_positions=None, config=ClothConfig(panels="fold")), ValueError,
     r"panels='fold'\) needs rest_positions"),
])
def test_cloth_arrays_threshold_and_config(kwargs, error, match):
    args = dict(positions=CLOTH.positions, faces=CLOTH.faces,
                rest_positions=CLOTH.rest_positions)
    args.update(kwargs)
    with pytest.raises(error, match=match):
        cloth_key_particles(**args)


@pytest.mark.parametrize("kwargs, error, match", [
    (dict(backend=None), ValueError, "unknown decimation backend"),
    (dict(panels="yes"), ValueError, "panels must be one of"),
    (dict(z_scale=np.nan), ValueError, "ClothConfig.z_scale"),
    (dict(z_scale=True), TypeError, "ClothConfig.z_scale must be a number"),
    (dict(layer_gap=0.0), ValueError, "ClothConfig.layer_gap"),
    (dict(geodesic_radius="0.1"), TypeError, "ClothConfig.geodesic_radius"),
    (dict(max_faces=10.5), TypeError, "ClothConfig.max_faces must be an int"),
    (dict(max_faces=1), ValueError, "max_faces must be at least 2"),
    (dict(restarts=True), TypeError, "ClothConfig.restarts must be an int"),
    (dict(restart_seed=-1), ValueError, "ClothConfig.restart_seed must be >= 0"),
    (dict(coarse_faces=300.0), TypeError, "ClothConfig.coarse_faces must be an int"),
    (dict(shared_faces=2000.0), TypeError, "ClothConfig.shared_faces must be an int"),
    (dict(shared_faces=200), ValueError, r"shared_faces \(200\) must exceed coarse_faces"),
    (dict(coarse_faces=None, shared_faces=40), ValueError, "must exceed max_faces"),
    (dict(exact_errors=1), TypeError, "ClothConfig.exact_errors must be a bool"),
    (dict(canonical_triangulation="yes"), TypeError, "ClothConfig.canonical_triangulation"),
    (dict(error="two-sided"), ValueError, "ClothConfig.error must be one of"),
    (dict(layer_gap="5 mm"), TypeError, "ClothConfig.layer_gap must be a number"),
    (dict(max_stretched_gap=0.0), ValueError, "ClothConfig.max_stretched_gap"),
    (dict(flat_gap_spacings=-1.0), ValueError, "ClothConfig.flat_gap_spacings"),
    (dict(coarse_faces=None, max_faces=1), ValueError, "max_faces must be at least 2"),
    (dict(strict="yes"), TypeError, "ClothConfig.strict must be a bool"),
])
def test_cloth_config_fields(kwargs, error, match):
    with pytest.raises(error, match=match):
        ClothConfig(**kwargs)


@pytest.mark.parametrize("name, kwargs, error, match", [
    ("rope_knot", {}, ValueError, "unknown goal 'rope_knot'"),
    (None, {}, ValueError, "unknown goal None"),
    ("rope_fold", dict(n=2), ValueError, "at least 3 particles"),
    ("rope_fold", dict(n=5.5), TypeError, "n must be an int"),
    ("rope_fold", dict(n=True), TypeError, "n must be an int"),
    ("rope_straighten", dict(n="40"), TypeError, "n must be an int"),
    ("rope_fold", dict(length=np.nan), ValueError, "length must be a positive"),
    ("rope_fold", dict(length=-1.0), ValueError, "length must be a positive"),
    ("rope_fold", dict(length="0.5"), TypeError, "length must be a number"),
    ("rope_fold", dict(legs=(1.0, 1.0)), ValueError, "legs must be three positive"),
    ("rope_fold", dict(cross_at=2.0), ValueError, "cross_at must be <= 1"),
    ("rope_fold", dict(overshoot=np.nan), ValueError, "overshoot must be finite"),
    ("rope_fold", dict(overshoot=1.0), ValueError, "overshoot must be < 1"),
    ("rope_fold", dict(knots=3), TypeError, "knots"),
    ("rope_straighten", dict(angle=np.nan), ValueError, "angle must be finite"),
    ("cloth_side", dict(n=1), ValueError, "at least 2 particles per side"),
    ("cloth_side", dict(n=8.5), TypeError, "n must be an int"),
    ("cloth_side", dict(side=np.nan), ValueError, "side must be finite"),
    ("cloth_side", dict(side=-0.3), ValueError, "side must be a positive"),
    ("cloth_side", dict(gap=-0.005), ValueError, "gap must be > 0"),
    ("cloth_side", dict(gap=np.nan), ValueError, "gap must be finite"),
    ("cloth_side", dict(triangulation="diagonal"), ValueError, "unknown triangulation"),
    ("cloth_side", dict(triangulation="random"), ValueError, "needs a numpy.random.Generator"),
    ("cloth_side", dict(triangulation="random", rng=3), TypeError, "rng must be a numpy"),
])
def test_make_goal(name, kwargs, error, match):
    with pytest.raises(error, match=match):
        make_goal(name, **kwargs)


@pytest.mark.parametrize("name, kwargs, error, match", [
    ("cloth_origami", {}, ValueError, "unknown goal"),
    ("cloth_reflective", dict(n=2.5), TypeError, "n must be an int"),
    ("cloth_underneath", dict(gap=0.0), ValueError, "gap must be > 0"),
])
def test_goal_sequence(name, kwargs, error, match):
    with pytest.raises(error, match=match):
        goal_sequence(name, **kwargs)


@pytest.mark.parametrize("call, error, match", [
    (lambda: goals.rope_crumpled(3), TypeError, "rng must be a numpy.random.Generator"),
    (lambda: goals.rope_crumpled(np.random.default_rng(0), turn=np.nan), ValueError, "turn"),
    (lambda: goals.rope_crumpled(np.random.default_rng(0), turn=-0.1), ValueError, "turn"),
    (lambda: goals.rope_crumpled(np.random.default_rng(0), smooth=0), ValueError, "smooth"),
    (lambda: goals.grid_faces(1), ValueError, "at least 2 particles per side"),
    (lambda: goals.grid_faces(4.0), TypeError, "n must be an int"),
    (lambda: goals.cloth_rest(4, side="0.3"), TypeError, "side must be a number"),
])
def test_goal_factories(call, error, match):
    with pytest.raises(error, match=match):
        call()


# ------------------------------------------------------------------------------ panels
G = goals.cloth_diagonal(n=8)


@pytest.mark.parametrize("kwargs, error, match", [
    (dict(goal=np.full((64, 3), np.nan)), ValueError, "goal has 64 particles with NaN"),
    (dict(goal=G.positions[:10]), ValueError, r"rest \(64, 3\) and goal \(10, 3\) differ"),
    (dict(rest="x"), TypeError, "rest must be a numeric array"),
    (dict(faces=G.faces + 100), ValueError, "faces index particles out of range"),
    (dict(faces=G.faces + 0.5), ValueError, "faces must hold integer"),
    (dict(layer_gap=-1.0), ValueError, "layer_gap must be > 0"),
    (dict(layer_gap=np.nan), ValueError, "layer_gap must be finite"),
    (dict(neighbours=0), ValueError, "neighbours must be >= 3"),
    (dict(neighbours=9.0), TypeError, "neighbours must be an int"),
    (dict(angle_deg=np.nan), ValueError, "angle_deg must be finite"),
    (dict(angle_deg=270.0), ValueError, "angle_deg must be <= 180"),
    (dict(min_fraction=2.0), ValueError, "min_fraction must be <= 1"),
    (dict(min_width=-1.0), ValueError, "min_width must be >= 0"),
    (dict(crease_width=np.nan), ValueError, "crease_width must be finite"),
    (dict(tolerance=-1.0), ValueError, "tolerance must be >= 0"),
    (dict(min_noise="0"), TypeError, "min_noise must be a number"),
    (dict(tolerance=-np.inf), ValueError, "tolerance must be finite"),
    (dict(tolerance=np.nan), ValueError, "tolerance must be finite"),
    (dict(merge_deg="60"), TypeError, "merge_deg must be a number"),
])
def test_project_on_panels(kwargs, error, match):
    args = dict(goal=G.positions, rest=G.rest_positions, faces=G.faces, layer_gap=0.005)
    args.update(kwargs)
    with pytest.raises(error, match=match):
        project_on_panels(**args)


@pytest.mark.parametrize("kwargs, error, match", [
    (dict(positions=np.full((64, 3), np.nan)), ValueError, "positions has 64 particles"),
    (dict(faces=G.faces[:, :2]), ValueError, r"faces must have shape \(F, 3\)"),
    (dict(spacing=0.0), ValueError, "spacing must be > 0"),
    (dict(spacing="1"), TypeError, "spacing must be a number"),
    (dict(axis=np.zeros(3)), ValueError, "axis must be a finite non-zero"),
    (dict(axis=np.ones(2)), ValueError, "axis must be a finite non-zero"),
    (dict(rings=0), ValueError, "rings must be >= 1"),
    (dict(max_gap=-1.0), ValueError, "max_gap must be > 0"),
    (dict(reach=np.inf), ValueError, "reach must be finite"),
    (dict(max_tilt_deg=120.0), ValueError, "max_tilt_deg must be <= 90"),
    (dict(min_stacked=1.5), ValueError, "min_stacked must be <= 1"),
])
def test_estimate_layer_gap(kwargs, error, match):
    args = dict(positions=G.positions, faces=G.faces, spacing=0.04)
    args.update(kwargs)
    with pytest.raises(error, match=match):
        estimate_layer_gap(**args)


def test_a_single_layer_has_no_layer_gap_and_reduces_with_the_flat_fallback():
    flat = goals.cloth_flat(n=12)
    assert not estimate_layer_gap(flat.positions, flat.faces, 0.3 / 11).found
    result = cloth_key_particles(flat.positions, flat.faces, rest_positions=flat.rest_positions)
    assert result.reached_threshold and result.n_elements == 2 and result.n_keys == 4
    gap = 0.5 * 0.3 / 11                                   # half a spacing
    assert result.threshold == pytest.approx(0.35 * min(10 * gap, max(gap, 0.3 / 6)))


@pytest.mark.parametrize("weights, match", [
    (np.ones((1, 3)), r"weights must have shape \(1, 4\)"),
    (-np.ones((1, 4)), "weights must be finite, >= 0 and not all 0"),
    (np.zeros((1, 4)), "weights must be finite, >= 0 and not all 0"),
])
def test_rigid_fit_weights(weights, match):
    with pytest.raises(ValueError, match=match):
        rigid_fit(np.eye(4, 3)[None], np.eye(4, 3)[None], weights)


def test_project_on_panels_takes_lists():
    fit = project_on_panels(G.positions.tolist(), G.rest_positions.tolist(), G.faces.tolist(),
                            0.005)
    assert fit.n_panels == 2


@pytest.mark.parametrize("rest, goal, error, match", [
    (np.zeros((2, 4, 3)), np.zeros((2, 5, 3)), ValueError, "goal must have the shape of rest"),
    (np.zeros((4, 3)), np.zeros((4, 3)), ValueError, r"rest must have shape \(B, k, 3\)"),
    (np.zeros((0, 4, 3)), np.zeros((0, 4, 3)), ValueError, r"rest must have shape \(B, k, 3\)"),
    (np.full((1, 4, 3), np.nan), np.zeros((1, 4, 3)), ValueError, "rest contains NaN/inf"),
    (np.zeros((1, 4, 3)), np.full((1, 4, 3), np.inf), ValueError, "goal contains NaN/inf"),
    (np.zeros((1, 4, 3), bool), np.zeros((1, 4, 3)), TypeError, "rest must be a numeric"),
])
def test_rigid_fit(rest, goal, error, match):
    with pytest.raises(error, match=match):
        rigid_fit(rest, goal)


@pytest.mark.parametrize("kwargs, error, match", [
    (dict(labels=np.full(64, 5)), ValueError, r"labels must lie in \[0, 2\)"),
    (dict(labels=np.full(64, -1)), ValueError, r"labels must lie in \[0, 2\)"),
    (dict(labels=np.zeros(64)), TypeError, "labels must be integer panel indices"),
    (dict(labels=np.zeros(10, int)), ValueError, r"labels must have shape \(64,\)"),
    (dict(n_panels=0), ValueError, "n_panels must be >= 1"),
    (dict(n_panels=2.0), TypeError, "n_panels must be an int"),
    (dict(width=0.0), ValueError, "width must be > 0"),
    (dict(width=np.nan), ValueError, "width must be finite"),
    (dict(l2=-1.0), ValueError, "l2 must be >= 0"),
    (dict(fit=np.ones(64)), ValueError, r"fit must be a \(64,\) bool mask"),
    (dict(fit=np.zeros(64, bool)), ValueError, r"fit must be a \(64,\) bool mask"),
    (dict(miss=np.ones((3, 64))), ValueError, r"miss must be a finite \(2, 64\) array"),
    (dict(miss=np.full((2, 64), np.nan)), ValueError, r"miss must be a finite \(2, 64\)"),
])
def test_panel_weights(kwargs, error, match):
    args = dict(rest=G.rest_positions, labels=(G.rest_positions[:, 0] > 0).astype(int),
                n_panels=2, width=0.01)
    args.update(kwargs)
    with pytest.raises(error, match=match):
        panel_weights(**args)


# ------------------------------------------------------------- sizes against the memory
@pytest.mark.parametrize("make, match", [
    (lambda: make_goal("cloth_diagonal", n=10**5),
     r"n=100000: a cloth of 100000 x 100000 = 1e\+10 particles needs about 37.3 TiB, more "
     r"than this machine's memory"),
    (lambda: goals.grid_faces(10**5), "n=100000: a cloth of"),
    (lambda: goals.cloth_rest(10**5), "n=100000: a cloth of"),
    (lambda: make_goal("rope_fold", n=10**9), "n=1000000000: a rope of 1000000000 particles"),
    (lambda: goals.check_cloth_size(40, "argument --x"), None),
])
def test_a_goal_larger_than_the_memory_is_refused_before_anything_is_allocated(make, match):
    """make_goal(..., n=10**5) once ended in "MemoryError: Unable to allocate 74.5 GiB"."""
    if match is None:
        assert make() == 40
        return
    with pytest.raises(ValueError, match=match):
        make()


def test_the_memory_bound_can_be_set(monkeypatch):
    from dopt.validation import MEMORY_ENV
    monkeypatch.setenv(MEMORY_ENV, str(1e6))
    with pytest.raises(ValueError, match=r"n=40: a cloth of 40 x 40 = 1.6e\+03 particles needs "
                                         r"about 6.25 MiB, more than this machine's memory "
                                         r"\(977 KiB; DOPT_MEMORY_BYTES"):
        make_goal("cloth_side", n=40)


def test_a_fold_with_too_few_particles_for_its_corners_is_refused():
    """n=3 put corners A..D on particles [0, 1, 1, 2]: two corners on one particle; with 4 or
    more each corner has its own particle."""
    from deformables.goals import make_goal
    with pytest.raises(ValueError, match="4 corners A, B, C, D on distinct particles"):
        make_goal("rope_fold", n=3)
    for n in (4, 5, 8, 40):
        assert len(set(make_goal("rope_fold", n=n).corners.tolist())) == 4
