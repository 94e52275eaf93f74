"""The state-vector-reduction authors' own run summaries as a result file, for side-by-side
tables: Table 1 rows and the Fig. 4 curve of their data.

Reads their summary table (tab-separated, one line per MPC run: task, method, theta_readd,
K_threshold, svd, n_runs, final_cost_mean, final_cost_median, final_dist_mean, avg_dofs,
opt_ms, ...) and writes, per task (clutter, soft, soft_rigid), the rows of their Table 1 by
our names (``planners.svr_mpc.TABLE1_ROWS``; their ``svd`` flag picks svd or sum, theta and
rho are theta_readd and K_threshold) with the ratio of each row's median final cost to the
baseline's (the statistic their Table 1 follows), and for clutter the Fig. 4 points (svr-sum
at every theta_readd and K_threshold). Their baseline is the plain iLQR run with the longest
optimisation time (all DoFs); a second plain iLQR run per task is not identified in the data
and is listed as "unidentified". Rows of Table 1 the data does not hold (rand, naive) are
absent. The output records the input's path and SHA-256.

    python experiments/paper_reference.py --tsv ../shared/notes/paper-data-svr-summary.tsv \\
        --record docs/results/paper-svr.json
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import json
import sys
from pathlib import Path

from cli_args import EPILOG, guarded, output_file

from planners.svr_mpc import row_name

TASKS = {"MPC_push_mcl": "clutter", "MPC_push_soft": "soft",
         "MPC_push_soft_rigid": "soft_rigid"}
TABLE1 = ("baseline", "svd-t10-r1", "svd-t10-r500", "svd-t5-r1", "sum-t10-r1",
          "sum-t10-r500", "sum-t5-r1")


def parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="paper_reference.py", description=__doc__, epilog=EPILOG,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--tsv", type=Path, required=True, help="the authors' summary table")
    ap.add_argument("--record", type=output_file, required=True, metavar="PATH",
                    help="the result file to write (docs/results/...)")
    return ap


def read(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f, delimiter="\t"))


def reference(lines: list[dict]) -> dict:
    """{task: {"rows": {row: stats}, "fig4": [points], "unidentified": [stats]}}."""
    out: dict = {}
    for task_key, task in TASKS.items():
        runs = [r for r in lines if r["task"] == task_key]
        plain = sorted((r for r in runs if r["method"] == "iLQR"),
                       key=lambda r: -float(r["opt_ms"]))
        if not plain:
            continue
        base = plain[0]
        base_median = float(base["final_cost_median"])

        def stats(r: dict, base_median: float = base_median) -> dict:
            return {"n_runs": int(r["n_runs"]), "horizon": int(r["horizon"]),
                    "final_cost_mean": float(r["final_cost_mean"]),
                    "final_cost_median": float(r["final_cost_median"]),
                    "median_ratio": float(r["final_cost_median"]) / base_median,
                    "final_dist_mean": float(r["final_dist_mean"]),
                    "avg_dofs": float(r["avg_dofs"]), "opt_ms": float(r["opt_ms"]),
                    "run_dir": r["run_dir"]}

        rows = {"baseline": stats(base)}
        fig4 = []
        for r in runs:
            if r["method"] != "iLQR_SVR":
                continue
            theta, rho = int(r["theta_readd"]), float(r["K_threshold"])
            method = "svr-svd" if r["svd"] == "true" else "svr-sum"
            name = row_name(method, theta, rho)
            if name in TABLE1:
                rows[name] = stats(r)
            if task == "clutter" and method == "svr-sum":
                fig4.append({"theta": theta, "rho": rho, **stats(r)})
        out[task] = {"rows": {k: rows[k] for k in TABLE1 if k in rows},
                     "fig4": sorted(fig4, key=lambda p: (p["theta"], p["rho"])),
                     "unidentified": [stats(r) for r in plain[1:]]}
    return out


@guarded("paper_reference.py")
def main(argv=None) -> int:
    args = parser().parse_args(argv)
    data = args.tsv.read_bytes()
    summary = {"experiment": "paper_svr", "source": str(args.tsv),
               "source_sha256": hashlib.sha256(data).hexdigest(),
               "tasks": reference(read(args.tsv))}
    from dopt.provenance import provenance

    summary["provenance"] = provenance(["experiments/paper_reference.py",
                                        *(sys.argv[1:] if argv is None else argv)])
    args.record.parent.mkdir(parents=True, exist_ok=True)
    args.record.write_text(json.dumps(summary, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
