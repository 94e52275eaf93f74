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

With ``--paper`` (the paper's text), also its published Table 1 ("published"): per task and
row (all nine, by our names) the MPC cost mean and 90 % CI as printed (normalised by the
baseline's; clutter with outliers removed), the optimisation time and the DoFs, read from the
table's text; the file records that source's path and SHA-256 too.

    python experiments/paper_reference.py --tsv ../shared/notes/paper-data-svr-summary.tsv \\
        --paper ../shared/seeds/state_vector_reduction_mpc.txt --record docs/results/paper-svr.json
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import json
import re
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
    ap.add_argument("--paper", type=Path, default=None,
                    help="the paper's text, for its published Table 1")
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


#: the published table's columns, in order
PUBLISHED_TASKS = ("clutter", "soft", "soft_rigid")
#: a published method label -> our row name
_METHOD = re.compile(r"^iLQR-(Baseline|Rand|Naive|SVR-SVD|SVR-Sum)\b(.*)$")
_THETA_RHO = re.compile(r"theta\s*=\s*(\d+)(?:\s*,\s*\\rho\s*=\s*([\d.]+))?")
_VALUE = re.compile(r"(-?[\d.]+)(?:\s*\\pm\s*([\d.]+))?")
_MEASURES = {"MPC cost": "mpc_cost", "Opt time (ms)": "opt_ms", "Num DoFs": "n_dofs"}


def published_table1(text: str) -> dict:
    """The paper's printed Table 1: {task: {row: {"mpc_cost", "mpc_cost_ci90", "opt_ms",
    "opt_ms_ci90", "n_dofs", "n_dofs_ci90"}}} (CI None where the table prints a bare number).

    The table is read from tab-separated lines: a method line ("iLQR-SVR-Sum $\\theta = 10,
    \\rho = 1$<TAB>MPC cost<TAB>v<TAB>v<TAB>v") followed by its measure lines.

    Raises:
        ValueError: the text holds no such table, or a row or value cannot be read.
    """
    out: dict = {t: {} for t in PUBLISHED_TASKS}
    row = None
    for line in text.splitlines():
        cells = [c.strip() for c in line.split("\t")]
        if len(cells) < 2 + len(PUBLISHED_TASKS):
            continue
        m = _METHOD.match(cells[0])
        if m:
            row = _row_of(m.group(1), m.group(2))
            cells = cells[1:]
        elif cells[0] == "" and row is not None:
            cells = cells[1:]
        else:
            continue
        measure = next((v for k, v in _MEASURES.items() if cells[0].startswith(k)), None)
        if measure is None:
            raise ValueError(f"unknown measure {cells[0]!r} in Table 1 row {row}")
        for task, cell in zip(PUBLISHED_TASKS, cells[1:1 + len(PUBLISHED_TASKS)], strict=True):
            v = _VALUE.search(re.sub(r"<[^>]+>", "", cell))
            if v is None:
                raise ValueError(f"cannot read {cell!r} ({row}, {measure}, {task})")
            entry = out[task].setdefault(row, {})
            entry[measure] = float(v.group(1))
            entry[f"{measure}_ci90"] = float(v.group(2)) if v.group(2) else None
    if not any(out.values()):
        raise ValueError("no Table 1 found (tab-separated method and measure lines)")
    return out


def _row_of(kind: str, rest: str) -> str:
    if kind == "Baseline":
        return "baseline"
    if kind == "Naive":
        return "naive"
    tr = _THETA_RHO.search(rest)
    if tr is None:
        raise ValueError(f"no theta in the Table 1 method {kind}{rest!r}")
    if kind == "Rand":
        return row_name("rand", int(tr.group(1)), 0.0)
    method = "svr-svd" if kind == "SVR-SVD" else "svr-sum"
    return row_name(method, int(tr.group(1)), float(tr.group(2)))


@guarded("paper_reference.py")
def main(argv=None) -> int:
    args = parser().parse_args(argv)
    data = args.tsv.read_bytes()
    summary = {"experiment": "paper_svr", "source": str(args.tsv),
               "source_sha256": hashlib.sha256(data).hexdigest(),
               "tasks": reference(read(args.tsv))}
    if args.paper is not None:
        text = args.paper.read_bytes()
        summary.update(paper=str(args.paper), paper_sha256=hashlib.sha256(text).hexdigest(),
                       published=published_table1(text.decode()))
    from dopt.provenance import provenance

    summary["provenance"] = provenance(["experiments/paper_reference.py",
                                        *(sys.argv[1:] if argv is None else argv)])
    args.record.parent.mkdir(parents=True, exist_ok=True)
    args.record.write_text(json.dumps(summary, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
