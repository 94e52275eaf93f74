"""experiments/key_particles.py, simulated goals: the scripted fold on the MuJoCo cloth, settled,
reduced with the flex's own triangles and the settled flat start as rest sheet."""
import key_particles
import numpy as np
import pytest

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
        fold = r["fold"]
        assert fold["held"] == (fold["n_keys"] == key_particles.CLOTH_REFERENCE_KEYS[r["task"]])
        assert 1 <= fold["n_keys"] <= 64 and fold["n_elements"] >= 2
        assert fold["n_keys_by_merge_deg"]["60"] == fold["n_keys"]      # the default angle
        assert list(fold["n_keys_by_merge_deg"]) == ["30", "45", "60", "90", "120"]
    # the multi-layer folds run with self-collision, as the experiments do
    assert [r["selfcollide"] for r in rows] == [False, False, True, True]


@pytest.mark.xfail(strict=True, reason="with the picker snapping onto each particle (0.06 s at "
                   "any dt), the scripted side, reflective and underneath folds of the 16 x 16 "
                   "default sheet end about 3 cm from the ideal fold and fold mode gives other "
                   "counts than the paper's (issue #15 open)")
def test_goals_the_simulator_folds_give_the_reference_counts_under_the_fold_mode():
    """Issue #15's goals from physics at 16 per side (the default preset, whose scripted
    folds are not flagged there): with ``panels="fold"`` every fold gives the paper's count
    (4 / 6 / 8 / 10) although the settled goals have crease loops and sagging panels
    (docs/RESULTS.md, "Goals made by the simulator")."""
    rows, failed = key_particles.simulated_goals([16], ClothConfig(), ("default",))
    assert failed == {}
    for r in rows:
        assert not r["unstable"], r
        assert r["fold"]["n_keys"] == key_particles.CLOTH_REFERENCE_KEYS[r["task"]], r
        assert r["fold"]["reached_threshold"], r
