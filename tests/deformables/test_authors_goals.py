"""Key particles of the key-particle paper's authors' own goals: their SoftGym / FleX files
(``../shared/external/ac_softagent``, described in that folder's README; float32, y up, the
sheet rotated in the plane). The diagonal fold (90 x 90) and the side fold (100 x 100) reduce to
the paper's triangle counts (4 and 6) and its key counts in every triangulation of the grid,
with the keys where the authors' are; their straight rope keeps only its two ends. Skipped when
the folder is absent (a user's clone has no ``../shared``)."""

from pathlib import Path

import numpy as np
import pytest

from deformables.cloth import cloth_key_particles
from deformables.goals import CLOTH_REFERENCE_KEYS, TRIANGULATIONS, grid_faces
from deformables.rope import rope_key_particles

EXTERNAL = Path(__file__).resolve().parents[2] / ".." / "shared" / "external" / "ac_softagent"
pytestmark = pytest.mark.skipif(not EXTERNAL.is_dir(), reason=(
    "the authors' files (../shared/external/ac_softagent) are not beside the project"))

#: task: (the authors' folder, particles per side, the paper's triangle count; external README)
FOLDS = {"cloth_diagonal": ("cloth_diagonal_folding", 90, 4),
         "cloth_side": ("cloth_side_folding", 100, 6)}
#: the authors' filter radius between key points (metres; external README)
AUTHORS_FILTER_M = 0.05


def _within(points: np.ndarray, others: np.ndarray, radius: float) -> bool:
    """Whether every point of ``points`` ``(P, 3)`` lies within ``radius`` of one of
    ``others`` ``(Q, 3)``."""
    gaps = np.linalg.norm(points[:, None] - others[None], axis=2).min(axis=1)
    return bool((gaps <= radius).all())


@pytest.mark.parametrize("triangulation", TRIANGULATIONS)
@pytest.mark.parametrize("task", sorted(FOLDS))
def test_the_authors_cloth_goals_reduce_to_the_papers_counts(task, triangulation):
    folder, n, paper_faces = FOLDS[task]
    rest = np.load(EXTERNAL / folder / "particle_pos_ini.npy")        # float32, as given
    goal = np.load(EXTERNAL / folder / "particle_pos_final.npy")
    authors = np.load(EXTERNAL / folder / "key_point_index.npy")
    faces = grid_faces(n, triangulation, rng=np.random.default_rng(0))
    kp = cloth_key_particles(goal, faces, rest_positions=rest)
    assert kp.reached_threshold
    assert (kp.n_elements, kp.n_keys) == (paper_faces, CLOTH_REFERENCE_KEYS[task])
    # on the flat sheet (distances there are geodesic): each of our keys is where one of the
    # authors' is, and each of theirs where one of ours is, to their own filter radius
    ours, theirs = rest[kp.indices].astype(float), rest[authors].astype(float)
    assert _within(ours, theirs, AUTHORS_FILTER_M) and _within(theirs, ours, AUTHORS_FILTER_M)


def test_the_authors_straight_rope_keeps_its_two_ends():
    rope = np.load(EXTERNAL / "rope" / "rope_folding_particles.npy")
    kp = rope_key_particles(rope)
    assert kp.indices.tolist() == [0, len(rope) - 1]


def test_the_authors_crumpled_rope_reduces_below_its_threshold_with_both_ends():
    rope = np.load(EXTERNAL / "rope" / "rope_flatten_particles.npy")
    kp = rope_key_particles(rope)
    assert kp.reached_threshold and kp.error <= kp.threshold
    assert {0, len(rope) - 1} <= set(kp.indices.tolist()) and kp.n_keys < len(rope)
