"""experiments/paper_reference.py: the authors' summary table read into Table 1 rows."""

import paper_reference
import pytest

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
                              line("iLQR_SVR", 5, 100, "false", 700.0, 150.0)]) + "\n")
    ref = paper_reference.reference(paper_reference.read(tsv))["clutter"]
    assert list(ref["rows"]) == ["baseline", "svd-t10-r1", "sum-t5-r1"]
    assert ref["rows"]["baseline"]["opt_ms"] == 480.0
    assert ref["rows"]["svd-t10-r1"]["median_ratio"] == pytest.approx(0.85)
    assert [u["median_ratio"] for u in ref["unidentified"]] == [pytest.approx(0.9)]
    assert [(p["theta"], p["rho"]) for p in ref["fig4"]] == [(5, 1.0), (5, 100.0)]


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
