"""RESULTS.md's section on the physics against analytic references (``python -m planners.bench
reference``): each preset's error against the catenary, the cantilever and a sagging sheet, and
what it costs against ``default``."""

from __future__ import annotations

from pathlib import Path

from dopt.lab.report.base import Result, num, section, table

#: per check: its error field, the reference it is against, and what the error measures
CHECKS = {"catenary": ("sag_error", "the inextensible catenary (cosseratbench)",
                       "sag of a rope pinned at both ends"),
          "cantilever": ("tip_error", "Euler-Bernoulli F L^3 / 3 EI",
                         "tip deflection of a clamped rope under a small load"),
          "sheet": ("sag_error", "the stretchable catenary of the sheet's membrane",
                    "sag of a sheet pinned along two edges")}


def _pct(x) -> str:
    return "-" if x is None else f"{x * 100:+.2f} %"


def physics_reference_section(results: list[Result], page: Path) -> list[str]:
    def body(r: Result) -> list[str]:
        rows = []
        for row in r.data["rows"]:
            check = CHECKS.get(row["check"])
            if check is None:                       # the cost rows (rope-actions)
                rows.append([row["check"], f"`{row['preset']}`", "-", "-", "-",
                             num(row.get("cost_vs_default"), 2)])
                continue
            field, reference, what = check
            rows.append([f"{row['check']}: {what}", f"`{row['preset']}`", reference,
                         _pct(row.get(field)), num(row.get("shape_error"), 4),
                         num(row.get("cost_vs_default"), 2)])
        return [f"### `{r.name}`", "",
                *table(["check", "preset", "reference", "error", "shape error (of length)",
                        "CPU per simulated second / default"], rows)]

    return section("Physics against analytic references: `python -m planners.bench reference`",
                   "Each physics preset's rope and sheet, built through the planners' own "
                   "scene builders, against analytic references (`planners/bench/"
                   "reference.py`; the rope's stretch comes from the edge constraint's "
                   "softness, not `young`). Error: relative, simulated minus reference; "
                   "cost: CPU time per simulated second against the `default` preset.",
                   results, page, body)
