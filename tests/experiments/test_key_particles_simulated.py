"""experiments/key_particles.py, simulated goals: the scripted fold on the MuJoCo cloth, settled,
reduced with the flex's own triangles and the settled flat start as rest sheet."""
import key_particles
import numpy as np

from deformables import ClothConfig


def test_simulated_goals_rows_are_consistent():
    rows, failed = key_particles.simulated_goals([8], ClothConfig())
    assert failed == {}
    assert [r["task"] for r in rows] == list(key_particles.CLOTH_TASKS)
    for r in rows:
        assert r["n"] == 8 and r["physics"] == "default"
        assert r["held"] == (r["n_keys"] == key_particles.CLOTH_REFERENCE_KEYS[r["task"]])
        assert 1 <= r["n_keys"] <= 64 and r["n_elements"] >= 2
        assert np.isfinite(r["scripted_cost_mm"]) and r["scripted_cost_mm"] > 0
        assert r["layer_gap_mm"] is None or r["layer_gap_mm"] > 0
        assert bool(r["unstable_reason"]) == r["unstable"]
    # the multi-layer folds run with self-collision, as the experiments do
    assert [r["selfcollide"] for r in rows] == [False, False, True, True]
