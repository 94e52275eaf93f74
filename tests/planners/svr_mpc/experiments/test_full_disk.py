"""A full disk never cuts the MPC experiments' table CSV short (#92): a rewrite with no room
keeps the old file whole and the error names it (the lab's files:
tests/dopt/lab/test_full_disk.py)."""

from planners.svr_mpc.experiments import outputs
from tests.dopt.lab.run_files import rewrite_on_a_full_disk


def table_methods(n_rows: int) -> dict:
    row = {"mpc_cost_normalised_mean": 1.0, "mpc_cost_normalised_ci90": 0.1,
           "mpc_cost_normalised_median": 1.0, "mpc_cost_median_ratio": 1.0, "opt_ms_mean": 5.0,
           "n_dofs_mean": 3.0, "lag_steps_mean": 1.0, "success_rate": 0.5,
           "goal_distance_end_median": 0.01, "outliers": 0, "n_trials": 20}
    return {f"row-{i:04d}-with-a-long-name": row for i in range(n_rows)}


def table_csv(out, big: bool):
    outputs.write_table(out, "push", table_methods(200 if big else 1))


def test_a_rewrite_on_a_full_disk_keeps_the_old_table_and_names_it(tmp_path, monkeypatch):
    rewrite_on_a_full_disk(tmp_path, monkeypatch, table_csv, "table1.csv")
