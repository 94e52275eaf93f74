"""The authors' clutter layouts checked for sense before a scene is built from one
(``dopt.tasks.push.authors.check_layout``): a goal on the goal cylinder (once a NaN start from
a division by zero), objects that overlap at their start poses (once thrown up to 1 m while
the scene settled, and the episode ran on that scene), an object or goal off the table, a goal
beyond the arm's reach (1000 km was accepted): each refused with a ValueError naming the file
and what is wrong. Every one of the authors' own 100 layouts passes.

The layout files here are written by this test (``_layout``): a goal cylinder, seven
obstacles far apart on a grid, the goal ahead; the overlap rule is checked against the
analytic distance of two upright cylinders' axes."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dopt.tasks import build_push_task
from dopt.tasks.push import authors
from tests.external import LAYOUTS

#: where this test's layouts put things (m): the goal cylinder (radius 0.05), the goal
CYLINDER_XY, GOAL_XY = (0.45, 0.0), (0.70, 0.05)
#: the seven obstacles, 0.25 m apart and 0.2 m or more from the pushing path
OBSTACLES_XY = [(0.30, 0.30), (0.55, 0.30), (0.80, 0.30), (0.30, -0.30), (0.55, -0.30),
                (0.80, -0.30), (0.95, 0.0)]


def _layout(tmp_path, cylinder=CYLINDER_XY, goal=GOAL_XY, obstacles=OBSTACLES_XY,
            name="0.csv"):
    """A layout file as the authors write them: 7 joint angles, 8 poses of 6 (x y z r p y),
    20 targets (the goal's xy first), comma-separated with a trailing comma."""
    poses = [[*cylinder, 0.06, 0, 0, 0]] + [[*xy, 0.06, 0, 0, 0.3] for xy in obstacles]
    targets = [*goal, 0, 0] + [c for xy in obstacles for c in xy] + [0, 0]
    values = [0.0] * 7 + [v for p in poses for v in p] + targets
    assert len(values) == 75
    path = tmp_path / name
    path.write_text(",".join(repr(float(v)) for v in values) + ",\n")
    return path


def test_a_sound_layout_passes_and_builds(tmp_path):
    path = _layout(tmp_path)
    authors.check_layout(path)
    task = build_push_task("clutter", "authors", 0, tmp_path)
    assert np.all(np.isfinite(task.initial_state))


@pytest.mark.parametrize("change, words", [
    (dict(goal=CYLINDER_XY), "on the goal cylinder"),
    (dict(goal=(CYLINDER_XY[0] + 0.01, 0.0)), "on the goal cylinder"),
    (dict(obstacles=[(0.47, 0.02), *OBSTACLES_XY[1:]]), "overlap"),
    (dict(obstacles=[OBSTACLES_XY[1], *OBSTACLES_XY[1:]]), "overlap"),
    (dict(goal=(1e6, 0.0)), "off the table"),
    (dict(obstacles=[(0.3, 5.0), *OBSTACLES_XY[1:]]), "off the table"),
    (dict(goal=(1.5, 0.0)), "beyond the arm's reach"),
    (dict(cylinder=(0.45, 1.2), goal=(0.45, 1.5)), "beyond the arm's reach"),
])
def test_a_senseless_layout_is_refused_naming_the_file(tmp_path, change, words):
    path = _layout(tmp_path, **change)
    with pytest.raises(ValueError, match=words) as exc:
        authors.check_layout(path)
    assert str(path) in str(exc.value)
    with pytest.raises(ValueError, match=words):             # the builder checks it too
        build_push_task("clutter", "authors", 0, tmp_path)


@settings(max_examples=25, deadline=None, derandomize=True)
@given(angle=st.floats(0.0, 2 * math.pi), gap=st.floats(-0.09, 0.05))
def test_overlap_is_refused_exactly_when_the_cylinders_intersect(tmp_path_factory, angle, gap):
    """Obstacle 1 (a cylinder of radius 0.05 m) placed ``gap`` m from the goal cylinder
    (radius 0.05 m) at ``angle``: refused iff the axes are closer than the radii's sum (0.1 m);
    gaps within 0.1 mm of touching are not asked about."""
    if abs(gap) < 1e-4:
        return
    centre = np.add(CYLINDER_XY, (0.10 + gap) * np.array([math.cos(angle), math.sin(angle)]))
    # keep the pushing path and the goal clear of it, so only the overlap can be the problem
    if np.linalg.norm(centre - np.array(GOAL_XY)) < 0.1 or (
            abs(centre[1]) < 0.06 and centre[0] < CYLINDER_XY[0]):
        return
    path = _layout(tmp_path_factory.mktemp("l"), obstacles=[tuple(centre), *OBSTACLES_XY[1:]])
    if gap < 0:
        with pytest.raises(ValueError, match="overlap"):
            authors.check_layout(path)
    else:
        authors.check_layout(path)


@pytest.mark.skipif(not LAYOUTS.is_dir(), reason=f"the authors' layouts are not here ({LAYOUTS})")
def test_every_one_of_the_authors_layouts_passes():
    files = sorted(LAYOUTS.glob("*.csv"), key=lambda p: int(p.stem))
    assert len(files) == 100
    for path in files:
        authors.check_layout(path)
