"""The summary figures that test the paper's argument: does the cost order by lag
(``lag_cost_tau``), how cost follows |C| over Fig. 4's points (``fig4_fields``' cost_dofs_r),
and how far the authors' goal cylinder travelled (``authors_travel``, on files written here)."""

import numpy as np
import pytest

from planners.svr_mpc.authors_data import authors_travel
from planners.svr_mpc.summary import lag_cost_tau


def row(lag, cost):
    return {"lag_steps_mean": lag, "mpc_cost_normalised_mean": cost}


def test_costs_that_follow_lag_give_tau_one_and_reversed_minus_one():
    rows = {f"r{i}": row(lag, 0.8 + 0.01 * lag) for i, lag in enumerate([5, 20, 40, 60])}
    assert lag_cost_tau(rows)["tau"] == pytest.approx(1.0)
    rows = {f"r{i}": row(lag, 1.0 - 0.01 * lag) for i, lag in enumerate([5, 20, 40, 60])}
    assert lag_cost_tau(rows)["tau"] == pytest.approx(-1.0)


def test_the_unoptimised_row_and_missing_costs_stay_out():
    rows = {"a": row(1, 0.9), "b": row(2, 0.95), "unoptimised": row(0, 5.0),
            "c": row(3, float("nan"))}
    out = lag_cost_tau(rows)
    assert out == {"tau": None, "p": None, "rows": 2}


HEAD = ("Final cost,Final dist,Average dofs,Average optimisation time (ms),Average percent "
        "derivs,Average time derivs (ms),Average time BP (ms),Average time FP (ms),"
        "Average surprise\n")


def write_scene(folder, i, start_xy, goal_xy):
    """A layout file of 75 numbers: the goal cylinder at ``start_xy``, its target ``goal_xy``."""
    v = np.zeros(75)
    v[7:9] = start_xy
    v[55:57] = goal_xy
    (folder / f"{i}.csv").write_text(",".join(f"{x:g}" for x in v) + ",\n")


def test_travel_is_start_distance_minus_final_distance(tmp_path):
    layouts = tmp_path / "layouts"
    layouts.mkdir()
    starts = [0.30, 0.28, 0.29]
    for i, d in enumerate(starts):              # start (0.4, 0), goal d away at 45 degrees
        write_scene(layouts, i, (0.4, 0.0), (0.4 + d / np.sqrt(2), d / np.sqrt(2)))
    task = tmp_path / "MPC_push_mcl"
    runs = {"iLQR/a": ([0.20, 0.10, 0.15], 900), "iLQR/b": ([0.05, 0.05, 0.05], 300),
            "iLQR_SVR/c": ([0.0, 0.28, 0.09], 200)}
    for name, (final, ms) in runs.items():
        folder = task / name
        folder.mkdir(parents=True)
        folder.joinpath("summary.csv").write_text(HEAD + "".join(
            f"100,{f},20,{ms},100,0,0,0,0\n" for f in final))
        folder.joinpath("summary.yaml").write_text(
            "num_dofs_readd: 5\nK_matrix_threshold: 1000000\nEigen vector method: false\n")
    out = authors_travel(task, layouts)
    assert out["baseline"]["travel_median"] == pytest.approx(np.median([0.10, 0.18, 0.14]))
    assert out["naive"]["final_distance_median"] == pytest.approx(0.05)
    assert out["rand-t5"]["travel_median"] == pytest.approx(0.20)
    assert authors_travel(task)["baseline"] == {"travel_median": None,
                                                "final_distance_median": 0.15, "n_episodes": 3}
    (layouts / "2.csv").unlink()
    with pytest.raises(ValueError, match="no scene 2.csv"):
        authors_travel(task, layouts)
