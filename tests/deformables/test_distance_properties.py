"""Property tests (hypothesis) of the fast Hausdorff search (deformables/distance.py) against a
plain reference of the same definition: every distance brute force (each point to every
triangle), every nearest cover sample from an unpruned k-d tree, no bounds, no guesses, no cut.

The values the reduction records are defined by the search's order, so the reference follows
the documented search step by step: the probe (``points[::16]``) gives the largest exact
distance of its 32 points farthest from the cover; points no farther than that from the cover
are dropped; ``L`` = their largest cover distance less the covering radius; then points are
resolved 256 at a time in decreasing cover distance until the best reaches the limit or no
point left can beat it. Below the limit that is the exact maximum; at or above it, the lower
bound the threshold test records (``ClothConfig.exact_errors``)."""
import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st
from scipy.spatial import cKDTree

from deformables import distance as dist
from deformables import goals
from deformables.decimation import EmptyDecimationError, decimate

from .test_key_particles_search import brute_force

SLOW = settings(deadline=None, derandomize=True, database=None, max_examples=60,
                suppress_health_check=[HealthCheck.too_slow],
                phases=(Phase.explicit, Phase.reuse, Phase.generate))
FOLDS = ["cloth_flat", "cloth_diagonal", "cloth_side", "cloth_reflective", "cloth_underneath"]


def reference_probe(cover, points, exact, stride=16):
    """The probe's value: the largest exact distance of the 32 points of ``points[::stride]``
    farthest from the cover (the same order as the library's: numpy's argsort). With stride
    256, the scout's value."""
    probe = points[::stride]
    return float(exact(probe[np.argsort(-cKDTree(cover).query(probe)[0])[:32]]).max())


def reference_max(vertices, faces, cover, rho, points, limit=np.inf):
    """The documented value of ``SurfaceDistance.max_distance`` (module docstring)."""

    def exact(q):
        return brute_force(vertices, faces, q)

    best = reference_probe(cover, points, exact)
    if best >= limit:
        return best
    u = cKDTree(cover).query(points)[0]
    far = u > best
    if not far.any():
        return best
    u, points = u[far], points[far]
    best = max(best, float(u.max()) - rho)
    if best >= limit:
        return best
    order = np.argsort(-u, kind="stable")
    for begin in range(0, len(order), 256):
        batch = order[begin:begin + 256]
        batch = batch[u[batch] > best]
        if len(batch) == 0:
            break
        best = max(best, float(exact(points[batch]).max()))
        if best >= limit:
            break
    return best


def _case(fold, n, stretch, noise, size, shake, step, seed):
    """A goal ``(N, 3)``, its faces, a model of it and the sampling step (``step`` spacings):
    the goal decimated to ``size`` faces, its vertices shaken by ``shake`` spacings (models
    near and far)."""
    rng = np.random.default_rng(seed)
    g = goals.make_goal(fold, n=n, rng=rng) if fold != "cloth_flat" else goals.cloth_flat(n=n)
    goal = (g.positions + rng.normal(0.0, noise, g.positions.shape)) * [1.0, 1.0, stretch]
    spacing = float(np.median(np.linalg.norm(goal[g.faces[:, 0]] - goal[g.faces[:, 1]],
                                             axis=1)))
    try:
        v, f = decimate(goal, g.faces, size)
    except EmptyDecimationError:
        return None
    v = v + rng.normal(0.0, shake * spacing, v.shape)
    return goal, g.faces, v, f, spacing * step


cases = st.builds(_case, fold=st.sampled_from(FOLDS), n=st.integers(4, 16),
                  stretch=st.sampled_from([1.0, 4.0, 10.0]),
                  noise=st.sampled_from([0.0, 1e-4, 1e-3]), size=st.integers(2, 16),
                  shake=st.sampled_from([0.0, 0.0, 0.01, 0.3, 2.0]),
                  step=st.floats(0.3, 2.0), seed=st.integers(0, 2 ** 31 - 1))
#: where the limit lies from the probe's value (0) to the exact maximum (1): at the probe's
#: value (it stops there), between (the search stops on the way), at or above the maximum
#: (exact), none
places = st.sampled_from([0.0, 1.0, 2.0, np.inf]) | st.floats(0.0, 1.2)


def _check(vertices, faces, cover, rho, surface, points, place):
    """``surface.max_distance(points)`` is the reference's value for a limit at ``place``;
    below the limit it is the maximum, else a lower bound of it at least the limit. Returns
    the limit and the value."""

    def exact(q):
        return brute_force(vertices, faces, q)

    maximum = float(exact(points).max())
    probe = reference_probe(cover, points, exact)
    limit = np.inf if np.isinf(place) else probe + place * (maximum - probe)
    expected = reference_max(vertices, faces, cover, rho, points, limit)
    assert surface.max_distance(points, limit=limit) == expected
    if expected < limit:
        assert expected == maximum
    else:
        assert limit <= expected <= maximum
    return limit, expected


@settings(SLOW)
@given(case=cases, place=places)
def test_the_search_gives_the_reference_value_both_ways(case, place):
    if case is None:
        return
    goal, faces, v, f, step = case
    samples = dist.sample_surface(v, f, step)
    original = dist.SurfaceDistance(goal, faces)
    goal_step = float(np.median(np.linalg.norm(original.triangles
                                               - np.roll(original.triangles, 1, axis=1),
                                               axis=2)))
    goal_cover = dist.sample_surface(goal, faces, goal_step)
    limit, expected = _check(goal, faces, goal_cover, goal_step / np.sqrt(3), original,
                             samples, place)
    # under a finite limit the scout (rows [::256]) goes first and may stop the search
    scout = (reference_probe(goal_cover, samples, lambda q: brute_force(goal, faces, q), 256)
             if np.isfinite(limit) else -np.inf)
    if scout >= limit:
        assert scout <= float(brute_force(goal, faces, samples).max())
        expected = scout
    assert dist.surface_to_surface(original, v, f, step, limit)[0] == expected

    model = dist.SurfaceDistance(v, f, cover_step=step, cover=samples)
    _check(v, f, samples, step / np.sqrt(3), model, goal, place)
    pair = dist.hausdorff(original, goal, v, f, step, limit=limit)
    assert pair[0] == expected
    if expected < limit:
        assert pair[1] == reference_max(v, f, samples, step / np.sqrt(3), goal, limit)
    else:
        assert np.isnan(pair[1])


@settings(SLOW)
@given(case=cases, stride=st.integers(1, 40))
def test_strided_samples_are_the_rows_of_the_full_sample(case, stride):
    if case is None:
        return
    goal, faces, v, f, step = case
    for vertices, triangles in ((goal, faces), (v, f)):
        full = dist.sample_surface(vertices, triangles, step)
        np.testing.assert_array_equal(dist.sample_surface(vertices, triangles, step, stride),
                                      full[::stride])


@pytest.mark.parametrize("fold", FOLDS[1:])
def test_a_far_model_is_rejected_by_its_scout_or_probe_without_the_full_sample(fold):
    # 24 per side: a sample of a few hundred rows, so the scout has a few points
    goal, faces, v, f, step = _case(fold, 24, 10.0, 0.0, 2, 0.0, 1.0, 0)
    original = dist.SurfaceDistance(goal, faces)
    scout = original.probe_distance(dist.sample_surface(v, f, step, 256))
    probe = original.probe_distance(dist.sample_surface(v, f, step, 16))
    assert scout > 0.0
    value, samples = dist.surface_to_surface(original, v, f, step, limit=scout)
    assert value == scout and samples is None
    if probe > scout:                       # the scout falls short, the probe stops it
        value, samples = dist.surface_to_surface(original, v, f, step, limit=probe)
        assert value == probe and samples is None
    value, samples = dist.surface_to_surface(original, v, f, step,
                                             limit=max(scout, probe) * 1.5)
    np.testing.assert_array_equal(samples, dist.sample_surface(v, f, step))
