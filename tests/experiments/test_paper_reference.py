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
