"""Key particles of the key-particle paper's authors' own goals: their SoftGym / FleX files
(``../shared/external/ac_softagent``, described in that folder's README; float32, y up, the
sheet rotated in the plane). The diagonal fold (90 x 90) and the side fold (100 x 100) reduce to
the paper's triangle counts (4 and 6) and its key counts in every triangulation of the grid,
with the keys where the authors' are; their straight rope keeps only its two ends. Skipped when
the folder is absent (a user's clone has no ``../shared``)."""


import numpy as np
import pytest

from deformables.authors import AUTHORS_CLOTH, keys_agree, load_authors_cloth
from deformables.cloth import cloth_key_particles
from deformables.goals import CLOTH_REFERENCE_KEYS, TRIANGULATIONS, grid_faces
from deformables.rope import rope_key_particles
from tests.external import AC_SOFTAGENT

needs_files = pytest.mark.skipif(not AC_SOFTAGENT.is_dir(), reason=(
    "the authors' files (../shared/external/ac_softagent) are not beside the project"))


@needs_files
@pytest.mark.parametrize("triangulation", TRIANGULATIONS)
@pytest.mark.parametrize("task", sorted(AUTHORS_CLOTH))
def test_the_authors_cloth_goals_reduce_to_the_papers_counts(task, triangulation):
    goal = load_authors_cloth(AC_SOFTAGENT, task)                 # float32, as given
    faces = grid_faces(goal.n, triangulation, rng=np.random.default_rng(0))
    kp = cloth_key_particles(goal.goal, faces, rest_positions=goal.rest)
    assert kp.reached_threshold
    assert (kp.n_elements, kp.n_keys) == (goal.paper_faces, CLOTH_REFERENCE_KEYS[task])
    # each of our keys is where one of the authors' is, and each of theirs where one of ours
    # is, to their own filter radius on the flat sheet
    assert keys_agree(goal.rest, kp.indices, goal.keys)


def test_keys_agree_only_within_the_radius_both_ways():
    rest = np.array([[0.0, 0, 0], [0.04, 0, 0], [0.2, 0, 0], [0.26, 0, 0]])
    assert keys_agree(rest, [0, 2], [1, 2])
    assert not keys_agree(rest, [0, 3], [1, 2])          # 3 is 0.06 m from 2
    assert not keys_agree(rest, [0], [1, 2])              # their 2 has none of ours near


def test_a_bad_authors_folder_is_named(tmp_path):
    with pytest.raises(ValueError, match="particle_pos_ini.npy is missing"):
        load_authors_cloth(tmp_path, "cloth_side")
    with pytest.raises(ValueError, match="no authors' goal for 'cloth_underneath'"):
        load_authors_cloth(tmp_path, "cloth_underneath")


@needs_files
def test_the_authors_straight_rope_keeps_its_two_ends():
    rope = np.load(AC_SOFTAGENT / "rope" / "rope_folding_particles.npy")
    kp = rope_key_particles(rope)
    assert kp.indices.tolist() == [0, len(rope) - 1]


@needs_files
def test_the_authors_crumpled_rope_reduces_below_its_threshold_with_both_ends():
    rope = np.load(AC_SOFTAGENT / "rope" / "rope_flatten_particles.npy")
    kp = rope_key_particles(rope)
    assert kp.reached_threshold and kp.error <= kp.threshold
    assert {0, len(rope) - 1} <= set(kp.indices.tolist()) and kp.n_keys < len(rope)
