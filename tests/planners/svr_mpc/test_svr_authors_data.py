"""planners/svr_mpc/authors_data.py and dopt.lab.stats.authors_*: the state-vector-reduction
authors' Table 1 statistic, on hand-computed arrays and on their own per-episode files (which must
reproduce their printed Table 1)."""

from pathlib import Path

import numpy as np
import pytest

from dopt.lab.stats import authors_kept, authors_mean_ci
from planners.svr_mpc.authors_data import (
    TASK_DIRS,
    authors_rows,
    authors_statistic,
    authors_table1,
)
from planners.svr_mpc.experiments import paper_reference

SHARED = Path(__file__).resolve().parents[3] / ".." / "shared"
PAPER_DATA = SHARED / "external" / "ilqr_svr" / "paper_data"
PAPER_TEXT = SHARED / "seeds" / "state_vector_reduction_mpc.txt"

# --- the rule on small arrays, by hand --------------------------------------------------


def test_the_fence_is_the_linear_06_quantile_plus_15_times_its_distance_to_the_minimum():
    # n = 5: the 0.6 quantile sits at index 2.4 -> 3 + 0.4 (4 - 3) = 3.4;
    # fence 3.4 + 1.5 (3.4 - 1) = 7.0: 100 goes
    np.testing.assert_array_equal(authors_kept([1.0, 2.0, 3.0, 4.0, 100.0]), [1, 2, 3, 4])
    # kept: mean 2.5, sample std sqrt(5/3) (ddof 1); 1.645 sqrt(5/3) / sqrt(4)
    mean, ci = authors_mean_ci([1.0, 2.0, 3.0, 4.0, 100.0])
    assert mean == pytest.approx(2.5)
    assert ci == pytest.approx(1.645 * np.sqrt(5 / 3) / 2)


def test_the_fence_is_inclusive_and_negative_values_go_but_set_the_minimum():
    # n = 6: the 0.6 quantile is x[3] = 4; fence 4 + 1.5 (4 - 0) = 10, kept itself
    np.testing.assert_array_equal(authors_kept([0, 1, 2, 4, 9, 10]), [0, 1, 2, 4, 9, 10])
    np.testing.assert_array_equal(authors_kept([0, 1, 2, 4, 9, 10.5]), [0, 1, 2, 4, 9])
    # the minimum -1 widens the fence (3.4 + 1.5 * 4.4 = 10) but -1 is below 0
    np.testing.assert_array_equal(authors_kept([-1.0, 2, 3, 4, 9.5]), [2, 3, 4, 9.5])
    # input order is kept
    np.testing.assert_array_equal(authors_kept([3.0, 1.0, 2.0]), [3.0, 1.0, 2.0])


def test_constant_and_single_values():
    assert authors_mean_ci([3.0, 3.0, 3.0]) == (3.0, 0.0)
    mean, ci = authors_mean_ci([7.0])
    assert mean == 7.0 and np.isnan(ci)


@pytest.mark.parametrize("values, match", [
    ([], "no values"),
    ([1.0, float("nan")], "non-finite"),
    ([1.0, float("inf"), 2.0], "non-finite"),
    ([[1.0, 2.0], [3.0, 4.0]], r"shape \(n,\)"),
])
def test_bad_input_is_named(values, match):
    with pytest.raises(ValueError, match=match):
        authors_kept(values)
    with pytest.raises(ValueError, match=match):
        authors_mean_ci(values)


def test_nothing_kept_is_an_error():
    with pytest.raises(ValueError, match="no value kept"):
        authors_mean_ci([-3.0, -2.0, -1.0])


# --- our trials through the same statistic ------------------------------------------------


def rec(method, seed, cost, ms=100.0, dofs=20.0, theta=10, rho=1.0):
    return {"params": {"method": method, "seed": seed, "theta": theta, "rho": rho},
            "result": {"mpc_cost": cost, "opt_ms_mean": ms, "dofs_mean": dofs}}


def test_our_records_are_grouped_by_row_and_costs_normalised_by_baselines_kept_mean():
    records = [rec("baseline", s, c, ms=400.0, dofs=55.0)
               for s, c in enumerate([1.0, 2.0, 3.0, 4.0, 100.0])]
    records += [rec("svr-sum", s, c) for s, c in enumerate([1.0, 1.0, 2.0, 2.0])]
    out = authors_statistic(records)
    assert list(out) == ["baseline", "sum-t10-r1"]
    assert out["baseline"]["cost_mean"] == pytest.approx(1.0)     # 2.5 / 2.5
    assert out["baseline"]["cost_kept_mean"] == pytest.approx(2.5)
    assert out["baseline"]["n_kept_cost"] == 4 and out["baseline"]["n_episodes"] == 5
    assert out["sum-t10-r1"]["cost_mean"] == pytest.approx(1.5 / 2.5)
    ci = 1.645 * np.std([1.0, 1.0, 2.0, 2.0], ddof=1) / 2
    assert out["sum-t10-r1"]["cost_ci"] == pytest.approx(ci / 2.5)
    assert out["sum-t10-r1"]["time_mean"] == 100.0 and out["sum-t10-r1"]["time_ci"] == 0.0
    assert out["baseline"]["dofs_mean"] == 55.0
    # no baseline row: the costs cannot be normalised
    alone = authors_statistic(records[5:])
    assert alone["sum-t10-r1"]["cost_mean"] is None
    assert alone["sum-t10-r1"]["cost_kept_mean"] == pytest.approx(1.5)


def test_a_record_that_is_not_a_finished_trial_is_named():
    with pytest.raises(ValueError, match="record 1"):
        authors_statistic([rec("baseline", 0, 1.0), {"params": rec("naive", 1, 1.0)["params"]}])


# --- the authors' own files against their printed Table 1 --------------------------------

needs_data = pytest.mark.skipif(
    not (PAPER_DATA.is_dir() and PAPER_TEXT.is_file()),
    reason="the authors' data (../shared/external/ilqr_svr/paper_data) or the paper's text "
           "(../shared/seeds) is absent: a clone without ../shared")

#: the printed table's decimals: cost mean 0.94, cost CI 0.033, time 485.71 +- 5.16, DoFs
DECIMALS = {"mpc_cost": (2, 3), "opt_ms": (2, 2), "n_dofs": (2, 2)}
MEASURES = {"mpc_cost": "cost", "opt_ms": "time", "n_dofs": "dofs"}


def comparison(units: float) -> dict:
    """{(task, row, measure): whether our mean and CI are both within ``units`` of the last
    printed digit of the paper's} for every printed "mean +- CI" cell."""
    published = paper_reference.published_table1(PAPER_TEXT.read_text())
    out = {}
    for task, folder in TASK_DIRS.items():
        ours = authors_table1(PAPER_DATA / folder)
        for row, printed in published[task].items():
            for measure, name in MEASURES.items():
                if printed[f"{measure}_ci90"] is None:    # a bare preset DoF count
                    continue
                d_mean, d_ci = DECIMALS[measure]
                out[task, row, measure] = (
                    abs(ours[row][f"{name}_mean"] - printed[measure]) <= units * 10**-d_mean
                    and abs(ours[row][f"{name}_ci"] - printed[f"{measure}_ci90"])
                    <= units * 10**-d_ci)
    return out


@needs_data
def test_the_rows_are_identified_from_the_run_settings():
    rows = authors_rows(PAPER_DATA / "MPC_push_mcl")
    assert list(rows) == ["baseline", "rand-t5", "naive", "svd-t10-r1", "svd-t10-r500",
                          "svd-t5-r1", "sum-t10-r1", "sum-t10-r500", "sum-t5-r1"]
    assert rows["baseline"]["run_dir"].endswith("20240611_1105")      # the slow plain run
    assert rows["naive"]["run_dir"].endswith("20240611_1150")
    assert rows["rand-t5"]["settings"]["K_matrix_threshold"] == "1000000"
    soft = authors_rows(PAPER_DATA / "MPC_push_soft")
    assert soft["rand-t5"]["settings"]["K_matrix_threshold"] == "1000000000000000"


@needs_data
def test_the_statistic_reproduces_53_of_54_printed_cost_and_time_cells():
    """Within one unit of the printed last digit, every cost and time cell (27 + 27) but one,
    and every DoF cell (18), match: the exception, soft_rigid Sum theta 10 rho 500's time CI,
    is printed with the SVD theta 10 rho 500 row's value (32.55; its own is 71.53)."""
    cells = comparison(units=1.0)
    cost_time = {k: ok for k, ok in cells.items() if k[2] != "n_dofs"}
    assert len(cost_time) == 54
    assert [k for k, ok in cost_time.items() if not ok] == \
        [("soft_rigid", "sum-t10-r500", "opt_ms")]
    dofs = {k: ok for k, ok in cells.items() if k[2] == "n_dofs"}
    assert len(dofs) == 18 and all(dofs.values())
    published = paper_reference.published_table1(PAPER_TEXT.read_text())["soft_rigid"]
    ours = authors_table1(PAPER_DATA / "MPC_push_soft_rigid")
    assert published["sum-t10-r500"]["opt_ms_ci90"] == published["svd-t10-r500"]["opt_ms_ci90"]
    assert ours["svd-t10-r500"]["time_ci"] == pytest.approx(32.55, abs=0.005)
    assert ours["sum-t10-r500"]["time_ci"] == pytest.approx(71.53, abs=0.005)
    assert ours["sum-t10-r500"]["time_mean"] == pytest.approx(997.71, abs=0.005)


@needs_data
def test_rounded_to_the_printed_digit_three_more_cells_differ_by_one_unit():
    """Rounded half-up to the printed digit, three further cells miss by one unit: two where
    the authors' script prints 4 decimals first (0.04146 -> 0.0415 -> 0.042; 10.91495 ->
    10.9150 -> 10.92) and soft_rigid baseline's cost CI (0.0953 printed 0.096)."""
    misses = [k for k, ok in comparison(units=0.5).items() if not ok]
    assert misses == [("clutter", "sum-t5-r1", "mpc_cost"), ("soft", "sum-t10-r1", "opt_ms"),
                      ("soft_rigid", "baseline", "mpc_cost"),
                      ("soft_rigid", "sum-t10-r500", "opt_ms")]


@needs_data
def test_plain_ilqr_dofs_are_not_logged_and_costs_are_relative_to_baseline():
    for folder in TASK_DIRS.values():
        table = authors_table1(PAPER_DATA / folder)
        assert table["baseline"]["cost_mean"] == pytest.approx(1.0)
        assert table["naive"]["dofs_mean"] is None and table["baseline"]["dofs_ci"] is None
        assert all(r["n_kept_cost"] <= r["n_episodes"] for r in table.values())


def test_a_folder_without_runs_is_named(tmp_path):
    with pytest.raises(ValueError, match="no iLQR/ folder"):
        authors_rows(tmp_path)
    (tmp_path / "iLQR" / "a").mkdir(parents=True)
    (tmp_path / "iLQR_SVR").mkdir()
    with pytest.raises(ValueError, match="1 runs, expected 2"):
        authors_rows(tmp_path)
