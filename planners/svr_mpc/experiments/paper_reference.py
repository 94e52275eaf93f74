"""The state-vector-reduction authors' own run summaries as a result file, for side-by-side
tables: Table 1 rows and the Fig. 4 curve of their data.

Reads their summary table (tab-separated, one line per MPC run: task, method, theta_readd,
K_threshold, svd, n_runs, final_cost_mean, final_cost_median, final_dist_mean, avg_dofs,
opt_ms, ...) and writes, per task (clutter, soft, soft_rigid), the rows of their Table 1 by
our names (``planners.svr_mpc.TABLE1_ROWS``) with the ratio of each row's median final cost to
the baseline's, and for clutter the Fig. 4 points (svr-sum at every theta_readd and
K_threshold). Their two plain iLQR runs per task are baseline (the slower: all DoFs) and naive
(the other); rand is the Sum run (svd false) with theta 5 and rho at least 1e6 (their 1e6 on
clutter, 1e15 on the soft tasks); the SVD and Sum rows are named by their ``svd`` flag, theta
(theta_readd) and rho (K_threshold). The output records the input's path and SHA-256.

With ``--paper-data`` (their ``PaperData`` folder: ``MPC_push_{mcl,soft,soft_rigid}/{iLQR,
iLQR_SVR}/<run>/summary.csv`` per episode), also the statistic their Table 1 prints
("authors_statistic", ``planners.svr_mpc.authors_data.authors_table1``): per task and row the mean
and 1.645 std / sqrt(n) of the values kept by their outlier fence, costs over the baseline's
kept mean, for the final cost, optimisation time and DoFs; with the folder's path and a
SHA-256 over the run files read. (The median ratio above is not their statistic.)

With ``--paper`` (the paper's text), also its published Table 1 ("published"): per task and
row (all nine, by our names) the MPC cost mean and 90 % CI as printed (normalised by the
baseline's; clutter with outliers removed), the optimisation time and the DoFs, read from the
table's text; the file records that source's path and SHA-256 too.

    python experiments/paper_reference.py --tsv ../shared/notes/paper-data-svr-summary.tsv \\
        --paper ../shared/seeds/state_vector_reduction_mpc.txt \\
        --paper-data ../shared/external/ilqr_svr/paper_data --record docs/results/paper-svr.json
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import re
import sys
from pathlib import Path

from dopt import atomic
from dopt.lab import jsonio
from dopt.lab.cli import EPILOG, ArgumentParser, existing_dir, guarded, output_file
from planners.svr_mpc import TABLE1_ROWS, row_name
from planners.svr_mpc.authors_data import RAND_MIN_RHO, RAND_THETA, TASK_DIRS, authors_table1

TASKS = {"MPC_push_mcl": "clutter", "MPC_push_soft": "soft",
         "MPC_push_soft_rigid": "soft_rigid"}
TABLE1 = tuple(TABLE1_ROWS)


def parser() -> argparse.ArgumentParser:
    ap = ArgumentParser(prog="paper_reference.py", description=__doc__, epilog=EPILOG,
                        formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--tsv", type=Path, required=True, help="the authors' summary table")
    ap.add_argument("--paper", type=Path, default=None,
                    help="the paper's text, for its published Table 1")
    ap.add_argument("--paper-data", type=existing_dir, default=None, metavar="DIR",
                    help="the authors' per-episode PaperData folder (MPC_push_mcl/, ...), for "
                         "their Table 1 statistic")
    ap.add_argument("--record", type=output_file, required=True, metavar="PATH",
                    help="the result file to write (docs/results/...)")
    return ap


def read(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f, delimiter="\t"))


def reference(lines: list[dict]) -> dict:
    """{task: {"rows": {row: stats}, "fig4": [points]}}: per task the Table 1 rows of the
    summary table's lines (``read``) and, on clutter, the Fig. 4 points (every Sum run).

    Baseline is the plain iLQR run with the longest optimisation time (all DoFs), naive the
    second; rand the Sum run with theta ``RAND_THETA`` and rho at least ``RAND_MIN_RHO``.

    Raises:
        ValueError: a task has more than two plain iLQR runs (baseline and naive).
    """
    out: dict = {}
    for task_key, task in TASKS.items():
        runs = [r for r in lines if r["task"] == task_key]
        plain = sorted((r for r in runs if r["method"] == "iLQR"),
                       key=lambda r: -float(r["opt_ms"]))
        if not plain:
            continue
        if len(plain) > 2:
            raise ValueError(f"{task_key}: {len(plain)} plain iLQR runs, expected baseline "
                             "and naive")
        base_median = float(plain[0]["final_cost_median"])

        def stats(r: dict, base_median: float = base_median) -> dict:
            return {"n_runs": int(r["n_runs"]), "horizon": int(r["horizon"]),
                    "final_cost_mean": float(r["final_cost_mean"]),
                    "final_cost_median": float(r["final_cost_median"]),
                    "median_ratio": float(r["final_cost_median"]) / base_median,
                    "final_dist_mean": float(r["final_dist_mean"]),
                    "avg_dofs": float(r["avg_dofs"]), "opt_ms": float(r["opt_ms"]),
                    "run_dir": r["run_dir"]}

        rows = dict(zip(("baseline", "naive"), map(stats, plain), strict=False))
        fig4 = []
        for r in runs:
            if r["method"] != "iLQR_SVR":
                continue
            theta, rho = int(r["theta_readd"]), float(r["K_threshold"])
            method = "svr-svd" if r["svd"] == "true" else "svr-sum"
            name = row_name(method, theta, rho)
            if method == "svr-sum" and theta == RAND_THETA and rho >= RAND_MIN_RHO:
                name = row_name("rand", theta, rho)
            if name in TABLE1:
                rows[name] = stats(r)
            if task == "clutter" and method == "svr-sum":
                fig4.append({"theta": theta, "rho": rho, **stats(r)})
        out[task] = {"rows": {k: rows[k] for k in TABLE1 if k in rows},
                     "fig4": sorted(fig4, key=lambda p: (p["theta"], p["rho"]))}
    return out


def authors_statistic(paper_data: Path) -> dict:
    """{task: ``authors_table1`` of its folder} for the tasks ``paper_data`` holds, and the
    SHA-256 over the run files read ({"tasks": ..., "sha256": ...}).

    Raises:
        ValueError: ``paper_data`` holds none of the tasks' folders (``TASK_DIRS``).
    """
    tasks = {task: Path(paper_data) / d for task, d in TASK_DIRS.items()
             if (Path(paper_data) / d).is_dir()}
    if not tasks:
        raise ValueError(f"{paper_data} holds none of {', '.join(TASK_DIRS.values())}")
    digest = hashlib.sha256()
    for folder in tasks.values():
        for f in sorted(folder.glob("*/*/summary.*")):
            digest.update(f.relative_to(paper_data).as_posix().encode() + b"\0")
            digest.update(f.read_bytes())
    return {"tasks": {task: authors_table1(folder) for task, folder in tasks.items()},
            "sha256": digest.hexdigest()}


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
    """``python experiments/paper_reference.py``: writes --record; 0, or 2 on a bad flag."""
    args = parser().parse_args(argv)
    data = args.tsv.read_bytes()
    summary = {"experiment": "paper_svr", "source": str(args.tsv),
               "source_sha256": hashlib.sha256(data).hexdigest(),
               "tasks": reference(read(args.tsv))}
    if args.paper is not None:
        text = args.paper.read_bytes()
        summary.update(paper=str(args.paper), paper_sha256=hashlib.sha256(text).hexdigest(),
                       published=published_table1(text.decode()))
    if args.paper_data is not None:
        stat = authors_statistic(args.paper_data)
        summary.update(paper_data=str(args.paper_data), paper_data_sha256=stat["sha256"],
                       authors_statistic=stat["tasks"])
    from dopt.lab.provenance import provenance

    summary["provenance"] = provenance(["experiments/paper_reference.py",
                                        *(sys.argv[1:] if argv is None else argv)])
    atomic.write_text(args.record, jsonio.dumps(summary, indent=2))
    return 0
