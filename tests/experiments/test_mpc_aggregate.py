"""Table 1 aggregation: pairing with baseline by seed, outliers, CI."""

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "experiments"))
from mpc_trial import aggregate  # noqa: E402


def rec(method, seed, cost, dist=0.01):
    return {"params": {"method": method, "seed": seed, "rho": 1.0, "theta": 10},
            "result": {"mpc_cost": cost, "goal_distance_end": dist, "opt_ms_mean": 100.0,
                       "dofs_mean": 20.0, "success": dist < 0.02, "lag_steps_mean": 25.0}}


def test_pairs_by_seed_and_excludes_outliers():
    records = [rec("baseline", 0, 100.0), rec("baseline", 1, 200.0), rec("baseline", 2, 50.0),
               rec("svr-sum", 0, 50.0), rec("svr-sum", 1, 150.0),
               rec("svr-sum", 2, 5000.0, dist=1.8)]          # rolled away: an outlier
    out = aggregate(records)
    assert out["baseline"]["mpc_cost_normalised_mean"] == 1.0
    svr = out["svr-sum"]
    assert svr["mpc_cost_normalised_mean"] == pytest.approx((0.5 + 0.75) / 2)
    assert svr["outliers"] == 1 and svr["trials"] == 3
    assert svr["mpc_cost_normalised_median"] == pytest.approx(0.75)   # over all three
    assert svr["mpc_cost_normalised_ci90"] > 0


def test_outlier_baseline_seed_is_not_a_reference():
    records = [rec("baseline", 0, 100.0, dist=2.0), rec("baseline", 1, 100.0),
               rec("naive", 0, 10.0), rec("naive", 1, 80.0)]
    out = aggregate(records)
    assert out["naive"]["mpc_cost_normalised_mean"] == pytest.approx(0.8)
