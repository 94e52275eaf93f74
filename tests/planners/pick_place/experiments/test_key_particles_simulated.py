"""experiments/key_particles.py, simulated goals: each fold made on the MuJoCo cloth by the line
grasp, settled, reduced with the flex's own triangles and the settled flat start as rest sheet
(the counts at 16 per side are tested on the library in
tests/dopt/tasks/pick/test_fold_goals.py)."""
import numpy as np

from deformables import ClothConfig
from planners.pick_place.experiments import key_particles


def test_simulated_goals_rows_are_consistent():
    rows, failed = key_particles.simulated_goals([8], ClothConfig())
    assert failed == {}
    assert [r["task"] for r in rows] == list(key_particles.CLOTH_TASKS)
    for r in rows:
        assert r["n"] == 8 and r["physics"] == "default" and r["selfcollide"]
        assert r["held"] == (r["n_keys"] == key_particles.CLOTH_REFERENCE_KEYS[r["task"]])
        assert 1 <= r["n_keys"] <= 64 and r["n_elements"] >= 2
        assert 0 < r["fold_error_mm"] <= r["fold_error_max_mm"] < 300
        assert len(r["held_particles"]) == {"cloth_reflective": 2,
                                            "cloth_underneath": 3}.get(r["task"], 1)
        assert r["layer_gap_mm"] is None or r["layer_gap_mm"] > 0
        assert bool(r["unstable_reason"]) == r["unstable"]
        assert np.isfinite(r["seconds"]) and r["seconds"] > 0
        fold = r["fold"]
        assert fold["held"] == (fold["n_keys"] == key_particles.CLOTH_REFERENCE_KEYS[r["task"]])
        assert 1 <= fold["n_keys"] <= 64 and fold["n_elements"] >= 2
        assert fold["n_keys_by_merge_deg"]["60"] == fold["n_keys"]      # the default angle
        assert list(fold["n_keys_by_merge_deg"]) == ["30", "45", "60", "90", "120"]
