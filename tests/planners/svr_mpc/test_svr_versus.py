"""planners.svr_mpc.versus: each SVR row against rand and baseline, seed by seed, one family
under Holm's correction. References: scipy's paired t-test on the log costs, Holm's procedure
worked by hand, and properties any such family must have."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from planners.svr_mpc import versus

ROWS = {"baseline": ("baseline", 0, 1.0), "rand-t5": ("rand", 5, 1.0),
        "sum-t10-r1": ("svr-sum", 10, 1.0), "svd-t10-r500": ("svr-svd", 10, 500.0)}


def records(costs: dict) -> list[dict]:
    """{row name: [cost per seed]} -> trial records as dopt.lab.sweep stores them."""
    out = []
    for row, values in costs.items():
        method, theta, rho = ROWS[row]
        out += [{"params": {"method": method, "theta": theta, "rho": rho, "seed": seed},
                 "result": {"mpc_cost": float(c), "goal_distance_end": 0.01}}
                for seed, c in enumerate(values)]
    return out


def test_p_values_are_the_paired_t_test_on_log_costs_and_holm_by_hand():
    rng = np.random.default_rng(3)
    base = rng.uniform(50, 150, 12)
    costs = {"baseline": base, "rand-t5": base * np.exp(rng.normal(-0.05, 0.1, 12)),
             "sum-t10-r1": base * np.exp(rng.normal(-0.3, 0.1, 12)),
             "svd-t10-r500": base * np.exp(rng.normal(0.0, 0.1, 12))}
    out = versus(records(costs))
    assert out["family_size"] == 4
    expected = {f"{row} vs {ref}": stats.ttest_rel(np.log(costs[row]), np.log(costs[ref])).pvalue
                for row in ("sum-t10-r1", "svd-t10-r500") for ref in ("baseline", "rand-t5")}
    for name, p in expected.items():
        assert out["pairs"][name]["p"] == pytest.approx(p, rel=1e-9)
    # Holm by hand: sort ascending, multiply the k-th smallest by m - k + 1, running maximum
    names = sorted(expected, key=expected.get)
    running = 0.0
    for k, name in enumerate(names):
        running = max(running, min(1.0, (4 - k) * expected[name]))
        assert out["pairs"][name]["p_holm"] == pytest.approx(running, rel=1e-9)
    sum_vs_base = out["pairs"]["sum-t10-r1 vs baseline"]
    assert sum_vs_base["verdict"] == "cheaper" and sum_vs_base["ratio_geomean"] < 0.8
    assert sum_vs_base["better"] == int(np.sum(costs["sum-t10-r1"] < base))


def test_a_row_no_cheaper_than_its_reference_shows_no_difference():
    rng = np.random.default_rng(0)
    base = rng.uniform(50, 150, 30)
    noise = rng.normal(0, 0.2, 15)
    same = base * np.exp(np.concatenate([noise, -noise]))    # log ratios with mean exactly 0
    out = versus(records({"baseline": base, "sum-t10-r1": same}), references=("baseline",))
    pair = out["pairs"]["sum-t10-r1 vs baseline"]
    assert pair["verdict"] == "no difference shown"
    assert pair["ratio_geomean"] == pytest.approx(1.0)
    lo, hi = pair["ratio_ci_simultaneous"]
    assert lo < 1.0 < hi


def test_missing_references_and_unpaired_seeds_are_left_out():
    out = versus(records({"baseline": [1.0, 2.0, 3.0], "sum-t10-r1": [0.5, 1.0, 1.5, 9.0]}))
    assert list(out["pairs"]) == ["sum-t10-r1 vs baseline"]     # no rand row ran
    assert out["pairs"]["sum-t10-r1 vs baseline"]["pairs"] == 3
    # three identical ratios: no spread, no test, no interval, no verdict
    assert out["pairs"]["sum-t10-r1 vs baseline"]["p"] is None
    assert out["pairs"]["sum-t10-r1 vs baseline"]["verdict"] == "no difference shown"
    # two pairs: no test, and no interval that could exclude 1 without a verdict
    two = versus(records({"baseline": [1.0, 2.0], "sum-t10-r1": [0.5, 1.01]}))
    assert two["pairs"]["sum-t10-r1 vs baseline"]["ratio_ci_simultaneous"] is None


def test_outliers_and_unstable_trials_leave_their_pairs_and_are_counted():
    """As in Table 1's means: a pair where either trial is an outlier or unstable is left out."""
    recs = records({"baseline": [1.0, 2.0, 3.0, 4.0, 5.0],
                    "sum-t10-r1": [0.5, 1.1, 1.4, 1.9, 2.6]})
    recs[0]["result"]["unstable"] = True                     # baseline seed 0
    recs[6]["result"]["goal_distance_end"] = 2.0             # SVR seed 1 rolled away
    pair = versus(recs)["pairs"]["sum-t10-r1 vs baseline"]
    assert pair["pairs"] == 3 and pair["excluded"] == 2
    expected = stats.ttest_1samp(np.log([1.4 / 3.0, 1.9 / 4.0, 2.6 / 5.0]), 0.0).pvalue
    assert pair["p"] == pytest.approx(expected, rel=1e-9)


def test_alpha_outside_the_unit_interval_is_refused():
    with pytest.raises(ValueError, match="alpha"):
        versus([], alpha=1.5)


@pytest.mark.parametrize("cost", [0.0, -1.0, float("nan"), float("inf")])
def test_a_cost_a_ratio_cannot_take_is_named(cost):
    with pytest.raises(ValueError, match=r"MPC cost of sum-t10-r1 on seed 1 is .*not a positive"):
        versus(records({"baseline": [1.0, 2.0], "sum-t10-r1": [1.0, cost]}))


log_ratios = st.lists(st.floats(-2.0, 2.0, allow_nan=False), min_size=3, max_size=25)


@settings(max_examples=60, deadline=None, derandomize=True, database=None)
@given(st.lists(log_ratios, min_size=1, max_size=2),
       st.sampled_from([0.01, 0.05, 0.1]))
def test_simultaneous_intervals_agree_with_holm(draws, alpha):
    """Whatever the data: Holm's p is never below the raw p, an interval that excludes 1 comes
    with a verdict (Holm rejects all Bonferroni does), the verdict follows the geometric mean's
    side of 1, and the interval holds the geometric mean."""
    rows = ["sum-t10-r1", "svd-t10-r500"][:len(draws)]
    n = min(len(x) for x in draws)
    base = np.linspace(10.0, 100.0, n)
    costs = {"baseline": base}
    for row, x in zip(rows, draws, strict=True):
        costs[row] = base * np.exp(np.asarray(x[:n]))
    out = versus(records(costs), references=("baseline",), alpha=alpha)
    for pair in out["pairs"].values():
        if pair["p"] is None:
            assert pair["verdict"] == "no difference shown"
            continue
        assert pair["p_holm"] >= pair["p"] - 1e-15
        lo, hi = pair["ratio_ci_simultaneous"]
        assert lo * (1 - 1e-12) <= pair["ratio_geomean"] <= hi * (1 + 1e-12)
        if hi < 1.0 or lo > 1.0:
            assert pair["verdict"] != "no difference shown"
        if pair["verdict"] == "cheaper":
            assert pair["ratio_geomean"] < 1.0
        if pair["verdict"] == "dearer":
            assert pair["ratio_geomean"] > 1.0


def test_fig4_fields_compare_every_grid_point_with_the_baseline_in_one_family():
    """A Fig. 4 grid: one point per (theta, rho), in that order, each normalised by the
    baseline; each point's p is scipy's paired t-test of its log costs against the baseline's,
    Holm-adjusted over the whole grid (m = its size); only the truly cheaper point is found."""
    from planners.svr_mpc import fig4_fields

    def result(cost):
        return {"mpc_cost": float(cost), "goal_distance_end": 0.01, "success": True,
                "opt_ms_mean": 5.0, "dofs_mean": 20.0, "lag_steps_mean": 1.0}

    rng = np.random.default_rng(11)
    base = rng.uniform(50, 150, 10)
    grid = [(10, 500.0), (0, 1.0), (10, 1.0)]             # unordered on purpose
    def null():                     # log ratios with mean exactly 0: no difference
        half = rng.normal(0, 0.1, 5)
        return np.concatenate([half, -half])

    costs = {(10, 500.0): base * np.exp(null()), (0, 1.0): base * np.exp(null()),
             (10, 1.0): base * np.exp(rng.normal(-0.5, 0.1, 10))}
    recs = [{"params": {"method": "baseline", "theta": 0, "rho": 1.0, "seed": s},
             "result": result(c)} for s, c in enumerate(base)]
    for (theta, rho), values in costs.items():
        recs += [{"params": {"method": "svr-sum", "theta": theta, "rho": rho, "seed": s},
                  "result": result(c)} for s, c in enumerate(values)]
    out = fig4_fields(recs, "svr-sum")
    assert [(p["theta"], p["rho"]) for p in out["points"]] == sorted(grid)
    for p in out["points"]:
        ratio = costs[p["theta"], p["rho"]] / base
        assert p["n_trials"] == 10
        assert p["mpc_cost_normalised_mean"] == pytest.approx(ratio.mean(), rel=1e-9)
    v = out["versus"]
    assert v["family_size"] == 3 and v["references"] == ["baseline"]
    p = {g: stats.ttest_rel(np.log(costs[g]), np.log(base)).pvalue for g in grid}
    order = sorted(grid, key=p.get)
    running = 0.0
    for k, g in enumerate(order):
        running = max(running, min(1.0, (3 - k) * p[g]))
        pair = v["pairs"][f"sum-t{g[0]}-r{g[1]:g} vs baseline"]
        assert pair["p"] == pytest.approx(p[g], rel=1e-9)
        assert pair["p_holm"] == pytest.approx(running, rel=1e-9)
    verdicts = {name: x["verdict"] for name, x in v["pairs"].items()}
    assert verdicts == {"sum-t0-r1 vs baseline": "no difference shown",
                        "sum-t10-r1 vs baseline": "cheaper",
                        "sum-t10-r500 vs baseline": "no difference shown"}
    # every point keeps 20 DoFs: Pearson's r of DoFs and cost is undefined, so None (not NaN)
    assert out["cost_dofs_r"] is None
    dofs = {(10, 500.0): 12.0, (0, 1.0): 20.0, (10, 1.0): 7.0}
    for r in recs:
        if r["params"]["method"] == "svr-sum":
            r["result"] = {**r["result"], "dofs_mean": dofs[r["params"]["theta"],
                                                           r["params"]["rho"]]}
    points = fig4_fields(recs, "svr-sum")
    xs = [dofs[p["theta"], p["rho"]] for p in points["points"]]
    ys = [p["mpc_cost_normalised_mean"] for p in points["points"]]
    assert points["cost_dofs_r"] == pytest.approx(stats.pearsonr(xs, ys)[0], rel=1e-12)


def test_unstable_episodes_leave_their_pairs_unless_kept():
    """A pair whose baseline episode is flagged unstable is left out of the comparison (and
    counted in "excluded"); ``keep_unstable`` keeps it and gives the t-test on all pairs;
    an outlier stays out either way."""
    rng = np.random.default_rng(5)
    base = rng.uniform(50, 150, 10)
    costs = {"baseline": base, "sum-t10-r1": base * np.exp(rng.normal(-0.2, 0.05, 10))}
    recs = records(costs)
    for r in recs:
        if r["params"]["method"] == "baseline" and r["params"]["seed"] < 4:
            r["result"]["unstable"] = True
        if r["params"]["method"] == "baseline" and r["params"]["seed"] == 9:
            r["result"]["goal_distance_end"] = 10.0                 # an outlier
    dropped = versus(recs, references=("baseline",))["pairs"]["sum-t10-r1 vs baseline"]
    kept = versus(recs, references=("baseline",),
                  keep_unstable=True)["pairs"]["sum-t10-r1 vs baseline"]
    assert (dropped["pairs"], dropped["excluded"]) == (5, 5)
    assert (kept["pairs"], kept["excluded"]) == (9, 1)
    seeds = list(range(9))
    assert kept["p"] == pytest.approx(stats.ttest_rel(
        np.log(costs["sum-t10-r1"][seeds]), np.log(base[seeds])).pvalue, rel=1e-9)
