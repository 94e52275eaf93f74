"""The iLQR benchmark's section and the authors' data (``paper_svr``) of RESULTS.md."""

from __future__ import annotations

from pathlib import Path

from dopt.lab.report.base import Result, num, section, table


def ilqr_bench_section(results: list[Result], page: Path) -> list[str]:
    def body(r: Result) -> list[str]:
        return [f"### {r.data.get('task')}: `{r.name}`", "",
                *table(["method", "derivatives", "box QP", "ms / iteration", "vs every",
                        "derivative share", "FD timesteps", "error (mean)", "error (median)",
                        "DoFs"],
                       [[row["method"], row["keypoints"], "yes" if row["box_qp"] else "no",
                         num(row["ms_per_iteration"], 0), num(row.get("vs_every")),
                         num(row["derivative_share"]),
                         f"{num(row['fd_steps'], 1)} / {row['horizon']}",
                         num(row["interp_error"], 4), num(row.get("interp_error_median"), 4),
                         num(row["n_dofs"], 1)]
                        for row in r.data["rows"]])]

    return section("iLQR iteration: derivatives over time and the box-QP backward pass",
                   "One iLQR(-SVR) iteration per method and derivative variant, same run: "
                   "finite differences at every timestep, every K-th (skipK) or at adaptive key "
                   "points, A and B linear between; `vs every`: time over the same method's at "
                   "every timestep; error: relative Frobenius error of the interpolated [A B] "
                   "against every-timestep differences on the last nominal, mean and median over t "
                   "(they differ where a few timesteps in contact, whose A and B change from "
                   "one step to the next, carry the whole error).",
                   results, page, body)


def paper_svr_section(results: list[Result], page: Path) -> list[str]:
    def body(r: Result) -> list[str]:
        lines: list[str] = []
        for task, t in r.data["tasks"].items():
            # plain iLQR runs record 0 DoFs in their data (not tracked): shown as "-"
            rows = [[name, str(v["n_runs"]), num(v["median_ratio"]),
                     num(v["final_dist_mean"], 3), num(v["avg_dofs"], 1) if v["avg_dofs"]
                     else "-", num(v["opt_ms"], 0)] for name, v in t["rows"].items()]
            rows += [["(unidentified iLQR run)", str(v["n_runs"]), num(v["median_ratio"]),
                      num(v["final_dist_mean"], 3), "-", num(v["opt_ms"], 0)]
                     for v in t.get("unidentified", [])]
            lines += [f"### {task}", "",
                      *table(["row", "runs", "median cost / baseline",
                              "final goal distance (m)", "DoFs", "opt. time (ms)"], rows), ""]
        return lines[:-1]

    return section("The state-vector-reduction authors' own data",
                   "Their run summaries (`experiments/paper_reference.py`): per Table 1 row the "
                   "runs, the median final cost over the baseline's (a robust summary; their "
                   "Table 1's statistic is the fenced mean, "
                   "`dopt.lab.stats.authors_mean_ci`, which "
                   "reproduces the printed table), mean final goal distance, mean DoFs and "
                   "optimisation time, rows named by their settings here (rand and naive are "
                   "identified by `planners.svr_mpc.authors_data.authors_rows`: rand the Sum run "
                   "with theta 5 and rho >= 1e6, naive the faster plain iLQR run).",
                   results, page, body)
