"""The state-vector-reduction paper's page (docs/STATE-VECTOR-REDUCTION.md,
``dopt.lab.report.pages``): its pictures and its tables beside the paper's."""

from __future__ import annotations

from pathlib import Path

from dopt.lab.report.base import Result, link, num, pm, source, table
from dopt.lab.report.pages import Page
from planners.svr_mpc.experiments.report_claims import fig4_files
from planners.svr_mpc.experiments.report_svr import (
    SVR,
    TASKS,
    fig4_against_paper,
    paper_preset_table1,
    paper_table1,
)


def _whose(d: dict) -> str:
    """Whose problem a Fig. 4 summary ran: "the authors'" or "our"."""
    return "the authors'" if d.get("problem") == "authors" else "our"


def svr_tables(results: list[Result], page: Path) -> list[str]:
    """Table 1 on the authors' problems beside the paper's printed one, and Fig. 4 beside
    the authors' runs."""
    ref, published = paper_table1(results)
    lines = []
    for task in TASKS:
        r = paper_preset_table1(results, task, ("authors",))
        if r is None or task not in published:
            continue
        ms = r.data["methods"]
        rows = [[row, pm(num(p["mpc_cost"]), num(p.get("mpc_cost_ci90"), 3)),
                 pm(num(m.get("mpc_cost_normalised_mean")),
                    num(m.get("mpc_cost_normalised_ci90"))),
                 f"{num(p.get('n_dofs'), 1)} / {num(m.get('n_dofs_mean'), 1)}",
                 f"{num(p.get('opt_ms'), 0)} / {num(m.get('opt_ms_mean'), 0)}"]
                for row, p in published[task].items() if (m := ms.get(row)) is not None]
        lines += [f"### Table 1, {task}: the paper's beside ours", "",
                  *table(["row", "paper MPC cost", "our MPC cost", "DoFs paper / ours",
                          "opt. ms paper / ours"], rows), "",
                  f"Sources: {source(r, page)} (the authors' problems), {source(ref, page)} "
                  "(the paper's printed table).", ""]
    if lines:
        lines[:0] = ["MPC cost normalised by the baseline's (mean ± 90 % interval), "
                     "optimisation time and DoFs, on the authors' problems.", ""]
    beside = [f"- {link(r, page)}: {line}" for problem in ("authors", "ours")
              for r in fig4_files(results, problem)[-1:] if ref is not None
              if (line := fig4_against_paper(r.data, ref.data))]
    if beside:
        lines += ["### Fig. 4 beside the authors' runs", "",
                  "Kendall tau-b of our points' order against theirs on the median cost, and of "
                  "each side's cost against its mean |C|:", "", *beside, ""]
    return lines


PAGE = Page(SVR, "STATE-VECTOR-REDUCTION.md",
            "State-vector reduction: the paper's claims beside our runs",
            "D. Russell, R. Papallas, M. Dogar, *Online State Vector Reduction During Model "
            "Predictive Control with Gradient-Based Trajectory Optimisation*, WAFR 2024",
            (("push-clutter.png", "iLQR-SVR MPC pushes the green cylinder to its goal "
                                  "through clutter"),),
            {"fig4": lambda d: f"Fig. 4 on {_whose(d)} {d.get('task')}: MPC cost / "
                               "baseline and mean |C| against rho, ours (solid) and the "
                               "authors' (dashed)"},
            svr_tables)
