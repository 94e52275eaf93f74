"""experiments/svr_explain.py (planners.svr_mpc.experiments.explain): the importance counts
and the timelines it reports, and one short episode end to end."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from planners.svr_mpc.experiments import explain

ROOT = Path(__file__).resolve().parents[4]


def test_importance_counts_split_at_the_rho_cuts_and_decades():
    values = [0.0, 0.0, 1e-9, 0.5, 1.0, 499.0, 500.0, 3e7]
    c = explain.importance_counts(values)
    assert c["n"] == 8 and c["zero"] == 2 and c["below"] == 1 and c["above"] == 1
    assert (c["lt_1"], c["1_to_500"], c["ge_500"]) == (4, 2, 2)
    assert c["decades"]["-1"] == 1 and c["decades"]["0"] == 1 and c["decades"]["2"] == 2
    assert sum(c["decades"].values()) + c["zero"] + c["below"] + c["above"] == c["n"]
    # the share bins: 0 | (0, 0.1) | [0.1, 1) | [1, 500) | >= 500, every value in one
    assert c["bins"] == {"zero": 2, "lt_0.1": 1, "0.1_to_1": 1, "1_to_500": 2, "ge_500": 2}


def test_timelines_average_over_seeds_per_bin():
    def rec(seed, steps, n_dofs, share):
        return {"params": {"method": "svr-sum", "theta": 10, "rho": 1.0, "seed": seed},
                "result": {"steps": 100, "opt_step": steps, "n_dofs": n_dofs,
                           "goal_share": share,
                           "importance": explain.importance_counts([0.0, 2.0]),
                           "rel_improvement": [0.1, 1e-6], "goal_distance_at_opt": [0.2, 0.01],
                           "alpha": [1.0, 0.0], "mu": [0.1, 1.0], "contact_steps": [3, 0],
                           "travel": 0.1 + seed, "goal_distance_end": 0.01,
                           "lag_steps_mean": 10.0, "horizon": 80}}
    rows = explain.summarize_rows(
        [rec(0, [0, 60], [55, 20], [1.0, 0.0]), rec(1, [10, 90], [45, 10], [0.5, 0.5])], bins=2)
    r = rows["sum-t10-r1"]
    assert r["bin_edges"] == [0.0, 50.0, 100.0]
    assert r["n_dofs"] == pytest.approx([50.0, 15.0])
    assert r["goal_share"] == pytest.approx([0.75, 0.25])
    assert r["importance_share"]["zero"] == pytest.approx(0.5)
    assert r["n_trials"] == 2
    mech = r["mechanism"]
    # dJ/J only while the object was more than 5 cm away: the 0.1 of each seed
    assert mech["n_optimisations_away"] == 2 and mech["rel_improvement_median_away"] == 0.1
    assert mech["accepted_share"] == 0.5 and mech["contact_share"] == 0.5
    assert mech["travel_median"] == pytest.approx(0.6) and mech["horizon"] == 80


def test_goal_importance_is_the_least_of_the_goal_dofs_held_whole():
    # an optimisation's record: its active set and each DoF's importance (None: not SVR)
    h = {"dofs": [0, 1, 7, 8, 9], "importance": [5.0, 6.0, 30.0, 0.2, 4.0]}
    assert explain.goal_importances(h, np.array([8, 7])) == [0.2, 30.0]
    assert explain.goal_importances(h, np.array([12, 13])) == []
    assert explain.goal_importances({"dofs": [0, 7], "importance": None}, [7]) is None
    # episode 1 holds both goal DoFs first (least 3), then one of them (skipped), then both
    # (least 40); episode 2 both first (least 9), then none; a rand episode has no importances
    ep1 = [[3.0, 700.0], [50.0], [40.0, 41.0]]
    ep2 = [[9.0, 10.0], []]
    s = explain.goal_importance_summary(
        [{"goal_importance": ep1}, {"goal_importance": ep2}, {"goal_importance": [None]}])
    assert s["first_median"] == 6.0 and (s["first_min"], s["first_max"]) == (3.0, 9.0)
    assert s["later_median"] == 40.0 and s["later_held_share"] == pytest.approx(1 / 3)
    # rows without importances, or trials recorded before the field, have no summary
    assert explain.goal_importance_summary([{"goal_importance": [None, None]}]) is None
    assert explain.goal_importance_summary([{}]) is None


def test_goal_held_split_separates_optimisations_by_whether_c_holds_the_goal():
    # five optimisations: the goal object away (> 5 cm) in the first four; C holds both goal
    # DoFs in the 1st, 3rd and 5th; SVR importances with and without a touching nominal
    res = {"goal_share": [1.0, 0.5, 1.0, 0.0, 1.0],
           "rel_improvement": [1e-2, 1e-6, 3e-2, 2e-6, 5e-1],
           "goal_distance_at_opt": [0.2, 0.2, 0.1, 0.06, 0.01],
           "goal_importance": [[700.0, 900.0], [4.0], [0.5, 30.0], [], [1e-16, 2.0]],
           "contact_steps": [10, 0, 4, 0, 0]}
    s = explain.goal_held_split([res])
    assert s["goal_held_share_away"] == 0.5                # 2 of the 4 away
    assert s["rel_improvement_median_away_held"] == pytest.approx(2e-2)
    assert s["rel_improvement_median_away_dropped"] == pytest.approx(1.5e-6)
    # held with importances: (contact, least 700), (contact, least 0.5), (none, least 1e-16)
    assert s["goal_cut_share_contact"] == 0.5 and s["goal_cut_share_no_contact"] == 1.0
    assert s["n_goal_importances"] == {"contact": 2, "no_contact": 1}
    # a row without importances (rand, baseline, older trials) has no cut shares
    plain = dict(res, goal_importance=[None] * 5)
    assert explain.goal_held_split([plain])["goal_cut_share_contact"] is None
    older = {k: v for k, v in res.items() if k != "goal_importance"}
    assert explain.goal_held_split([older])["goal_held_share_away"] == 0.5


def test_short_run_writes_summary_and_plot(tmp_path):
    out = tmp_path / "ex"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run([sys.executable, str(ROOT / "experiments" / "svr_explain.py"),
                           "--preset", "paper", "--rows", "rand-t5,sum-t10-r1", "--trials", "1",
                           "--timeout", "60", "--bins", "3", "--out", str(out)],
                          capture_output=True, text=True, env=env, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    d = json.loads((out / "summary.json").read_text())
    assert d["experiment"] == "svr_explain" and set(d["rows"]) == {"rand-t5", "sum-t10-r1"}
    assert d["rows"]["rand-t5"]["importance_share"] is None        # rand has no importance
    svr = d["rows"]["sum-t10-r1"]
    assert svr["importance"]["n"] > 0 and 0 <= svr["goal_share_mean"] <= 1
    assert np.isclose(sum(svr["importance_share"].values()), 1)
    assert set(svr["importance_share"]) == set(explain.SHARE_BINS)
    mech = svr["mechanism"]
    assert 0 <= mech["contact_share"] <= 1 and mech["travel_median"] >= 0
    # the first optimisation holds every DoF, so the goal's importance there is recorded
    assert svr["goal_importance"]["first_median"] >= 0
    assert "goal_importance" not in d["rows"]["rand-t5"]
    assert (out / "svr_explain.png").stat().st_size > 10_000
    # the first seed keeps its controls (--keep-controls' default): dopt-view's MPC source
    # claims each trial and its replay ends on the recorded final state
    from planners.view import MPC
    for path in (out / "trials").glob("*.json"):
        record = json.loads(path.read_text())
        assert MPC.claims(path, record) and len(record["result"]["controls"]) == 60
        assert MPC.load(path).replay_error <= 1e-9
    assert f"dopt-view {out}" in proc.stdout and str(out / "svr_explain.png") in proc.stdout
