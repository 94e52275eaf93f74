"""experiments/paper_reference.py: the authors' summary table read into Table 1 rows, and
their per-episode data through their Table 1 statistic."""

import json

import pytest

from planners.svr_mpc.experiments import paper_reference

HEADER = ("task\tmethod\trun_dir\thorizon\ttheta_readd\tK_threshold\tsvd\tn_runs\t"
          "final_cost_mean\tfinal_cost_median\tfinal_dist_mean\tavg_dofs\topt_ms")


def line(method, theta, k, svd, median, opt_ms, task="MPC_push_mcl"):
    return (f"{task}\t{method}\trun\t80\t{theta}\t{k}\t{svd}\t100\t{median * 2}\t{median}\t0.2\t"
            f"20\t{opt_ms}")


def test_rows_are_named_and_normalised_by_the_slowest_plain_ilqr(tmp_path):
    tsv = tmp_path / "d.tsv"
    tsv.write_text("\n".join([HEADER, line("iLQR", "-", "-", "-", 1000.0, 480.0),
                              line("iLQR", "-", "-", "-", 900.0, 210.0),
                              line("iLQR_SVR", 10, 1, "true", 850.0, 300.0),
                              line("iLQR_SVR", 5, 1, "false", 800.0, 200.0),
                              line("iLQR_SVR", 5, 100, "false", 700.0, 150.0),
                              line("iLQR_SVR", 5, 1000000, "false", 950.0, 140.0),
                              line("iLQR_SVR", 10, 1000000, "false", 940.0, 145.0)]) + "\n")
    ref = paper_reference.reference(paper_reference.read(tsv))["clutter"]
    # naive: the second plain run; rand: Sum, theta 5, rho >= 1e6 (theta 10 there is Fig. 4)
    assert list(ref["rows"]) == ["baseline", "rand-t5", "naive", "svd-t10-r1", "sum-t5-r1"]
    assert ref["rows"]["baseline"]["opt_ms"] == 480.0
    assert ref["rows"]["svd-t10-r1"]["median_ratio"] == pytest.approx(0.85)
    assert ref["rows"]["naive"]["median_ratio"] == pytest.approx(0.9)
    assert ref["rows"]["rand-t5"]["median_ratio"] == pytest.approx(0.95)
    assert "unidentified" not in ref
    assert [(p["theta"], p["rho"]) for p in ref["fig4"]] == [(5, 1.0), (5, 100.0), (5, 1e6),
                                                              (10, 1e6)]


def test_a_third_plain_run_is_an_error(tmp_path):
    tsv = tmp_path / "d.tsv"
    tsv.write_text("\n".join([HEADER, *(line("iLQR", "-", "-", "-", 900.0, ms)
                                        for ms in (480.0, 210.0, 200.0))]) + "\n")
    with pytest.raises(ValueError, match="3 plain iLQR runs"):
        paper_reference.reference(paper_reference.read(tsv))


def write_run(folder, costs, ms, dofs, settings=""):
    folder.mkdir(parents=True)
    (folder / "summary.yaml").write_text("optimisation horizon: 80\n" + settings)
    (folder / "summary.csv").write_text(
        "Final cost,Final dist,Average dofs,Average optimisation time (ms)\n"
        + "".join(f"{c},0.1,{dofs},{ms}\n" for c in costs))


def test_paper_data_adds_the_authors_statistic(tmp_path):
    data = tmp_path / "paper_data" / "MPC_push_mcl"
    write_run(data / "iLQR" / "slow", [1.0, 2.0, 3.0, 4.0, 100.0], 480.0, 0)
    write_run(data / "iLQR" / "fast", [2.0, 2.0], 210.0, 0)
    write_run(data / "iLQR_SVR" / "r", [1.0, 1.0], 150.0, 12.5,
              "num_dofs_readd: 5\nK_matrix_threshold: 1000000\nEigen vector method: false\n")
    tsv = tmp_path / "d.tsv"
    tsv.write_text("\n".join([HEADER, line("iLQR", "-", "-", "-", 1000.0, 480.0)]) + "\n")
    record = tmp_path / "out.json"
    assert paper_reference.main(["--tsv", str(tsv), "--paper-data", str(tmp_path / "paper_data"),
                                 "--record", str(record)]) == 0
    out = json.loads(record.read_text())
    assert len(out["paper_data_sha256"]) == 64
    rows = out["authors_statistic"]["clutter"]
    assert list(rows) == ["baseline", "rand-t5", "naive"]
    assert rows["baseline"]["n_kept_cost"] == 4                  # 100 is past the fence
    assert rows["naive"]["cost_mean"] == pytest.approx(2.0 / 2.5)
    assert rows["rand-t5"]["dofs_mean"] == 12.5 and rows["naive"]["dofs_mean"] is None


PUBLISHED = "\n".join([
    "Some prose before the table.",
    "Method / Task\t\tClutter\tSoft\tSoft rigid",
    "iLQR-Baseline\tMPC cost\t$1.00 \\pm 0.034$\t$1.00 \\pm 0.080$\t$1.00 \\pm 0.096$",
    "\tOpt time (ms)\t$485.71 \\pm 5.16$\t$620.97 \\pm 7.35$\t$4322.39 \\pm 366.65$",
    "\tNum DoFs (preset)\t55\t115\t154",
    "iLQR-Rand $\\theta = 5$\tMPC cost\t$0.94 \\pm 0.033$\t$1.14 \\pm 0.104$\t$0.74 \\pm 0.071$",
    "\tNum DoFs (preset)\t12\t12\t12",
    "iLQR-SVR-Sum $\\theta = 10, \\rho = 500$\tMPC cost\t$0.87 \\pm 0.029$\t"
    "<b><math>0.38 \\pm 0.066</math></b>\t$0.70 \\pm 0.071$",
    "\tNum DoFs\t$18.69 \\pm 0.10$\t$18.20 \\pm 0.11$\t$24.09 \\pm 0.46$",
    "Prose after the table.\tnot\ta\trow"])


def test_the_published_table_is_read_by_our_row_names():
    t = paper_reference.published_table1(PUBLISHED)
    assert list(t) == ["clutter", "soft", "soft_rigid"]
    assert list(t["clutter"]) == ["baseline", "rand-t5", "sum-t10-r500"]
    assert t["clutter"]["baseline"] == {"mpc_cost": 1.0, "mpc_cost_ci90": 0.034,
                                        "opt_ms": 485.71, "opt_ms_ci90": 5.16,
                                        "n_dofs": 55.0, "n_dofs_ci90": None}
    assert t["soft"]["sum-t10-r500"]["mpc_cost"] == 0.38       # bold cell, tags stripped
    assert t["soft_rigid"]["sum-t10-r500"]["n_dofs_ci90"] == 0.46
    assert t["soft"]["rand-t5"]["mpc_cost_ci90"] == 0.104


def test_text_without_the_table_is_an_error():
    with pytest.raises(ValueError, match="no Table 1"):
        paper_reference.published_table1("no table here\tat\tall\tin\tthis")
    with pytest.raises(ValueError, match="unknown measure"):
        paper_reference.published_table1("iLQR-Naive\tSpeed\t1\t2\t3")
