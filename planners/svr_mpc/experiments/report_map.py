"""The state-vector-reduction paper's rows of README's map (``dopt.lab.report.map``): a
headline sentence per figure or table, read from the result files."""

from __future__ import annotations

from collections.abc import Callable

from dopt.lab.report.base import Result, as_flag, num, pm
from dopt.lab.report.map import MapRow
from planners.svr_mpc.experiments.report_claims import fig4_files
from planners.svr_mpc.experiments.report_svr import (
    MIN_KEPT_BASELINE,
    SVR,
    _table1_columns,
    kept_baseline,
    orderings,
    paper_preset_table1,
    paper_table1,
    verdict_counts,
)


def table1_line(results: list[Result], preset: str = "authors") -> str | None:
    """The cheapest reduced row per task under the authors' protocol on the problems of
    ``preset`` (``authors``: theirs, ``paper``: ours), or where the summaries have them how
    many SVR rows Holm finds cheaper than baseline and than rand; and Kendall's tau of our
    order against the paper's printed one. A task whose baseline is kept (neither outlier
    nor unstable) in fewer than ``MIN_KEPT_BASELINE`` of its episodes says so instead of
    means over the few seeds left ("n/a" against baseline, "-" for its tau); its verdicts
    against rand stand."""
    _, published = paper_table1(results)
    parts, taus, counts = [], [], {}
    for task in ("clutter", "soft", "soft_rigid"):
        r = paper_preset_table1(results, task, (preset,))
        if r is None:
            continue
        kept = kept_baseline(r.data)
        few = bool(kept and kept[0] < MIN_KEPT_BASELINE * kept[1])
        verdicts = versus_counts(r.data.get("versus"))
        if few and verdicts:          # no baseline to compare with; the verdicts vs rand stand
            verdicts = {**verdicts, "baseline": f"n/a (kept {kept[0]}/{kept[1]})"}
        counts[task] = verdicts
        rows = {k: m["mpc_cost_normalised_mean"] for k, m in r.data["methods"].items()
                if k != "baseline" and isinstance(m.get("mpc_cost_normalised_mean"),
                                                  (int, float))}
        if few:
            parts.append(f"{task} n/a (baseline kept {kept[0]}/{kept[1]})")
        elif rows:
            best = min(rows, key=rows.get)
            parts.append(f"{task} {best} {num(rows[best])}")
        if task in published:
            taus.append("-" if few else
                        num(orderings(*_table1_columns(published[task], r.data))["kendall_tau"]))
    if not parts:
        return None
    refs = [ref for ref in ("baseline", "rand-t5")
            if counts and all(ref in v for v in counts.values())]
    if refs:
        text = (f"SVR cheaper:dearer/n vs {', '.join(refs)} (Holm): "
                + "; ".join(f"{task} {', '.join(v[ref] for ref in refs)}"
                            for task, v in counts.items()))
    else:
        text = "cheapest reduced row / baseline: " + ", ".join(parts)
    if taus:
        text += f"; tau vs paper {' / '.join(taus)}"
    return text


def versus_counts(v: dict | None) -> dict[str, str]:
    """{reference: "a:b/n"}: of a summary's n SVR rows, how many Holm finds cheaper (a) and
    dearer (b) than each reference ({} without ``versus``)."""
    return {ref: f"{c['cheaper']}:{c['dearer']}/{c['n']}" for ref, c in verdict_counts(v).items()}


def fig4_line(results: list[Result], problem: str = "ours") -> str | None:
    """The lowest MPC cost / baseline of the Fig. 4 sweep on ``problem`` and where it lies;
    on the authors' clutter also the scenes per point."""
    files = fig4_files(results, problem)
    if not files:
        return None
    d = files[-1].data
    points = [p for p in d.get("points") or [] if isinstance(p.get("mpc_cost_normalised_mean"),
                                                            (int, float))]
    if not points:
        return None
    best = min(points, key=lambda p: p["mpc_cost_normalised_mean"])
    rhos = sorted({p.get("rho") for p in points})
    scenes = (f"; {min(p.get('n_trials') or 0 for p in points)} scenes per point"
              if problem == "authors" else "")
    cost = pm(num(best["mpc_cost_normalised_mean"]), num(best.get("mpc_cost_normalised_ci90")))
    # every point against the baseline, one Holm family (summaries that hold "versus")
    holm = "".join(f"; Holm: {c['cheaper']}/{c['n']} points cheaper, {c['dearer']} dearer"
                   for c in verdict_counts(d.get("versus")).values())
    return (f"{d.get('task')}: lowest cost / baseline {cost} (90 % CI) at rho "
            f"{as_flag(best.get('rho'))}, theta {best.get('theta')}; {len(rhos)} rho from "
            f"{as_flag(rhos[0])} to {as_flag(rhos[-1])}{scenes}{holm}")


def authors_line(results: list[Result]) -> str | None:
    """The state-vector-reduction mechanism on the authors' problems: |C| at rho 1 and 500
    (theta 10) from their Fig. 4 file, and the contact share of sum-t10-r1 from svr_explain."""
    parts = []
    fig4 = fig4_files(results, "authors")
    if fig4:
        pts = {(p.get("theta"), p.get("rho")): p for p in fig4[-1].data.get("points") or []}
        a, b = pts.get((10, 1.0)), pts.get((10, 500.0))
        if a and b:
            parts.append(f"|C| {num(a.get('n_dofs_mean'), 1)} at rho 1, "
                         f"{num(b.get('n_dofs_mean'), 1)} at rho 500 (theta 10, "
                         f"{a.get('n_trials')} scenes)")
    explain = [r for r in results if r.kind == "svr_explain" and r.data.get("task") == "clutter"
               and r.data.get("problem") == "authors" and r.data.get("push_tail", True)]
    if explain:
        m = (explain[-1].data["rows"].get("sum-t10-r1") or {}).get("mechanism") or {}
        if m:
            parts.append(f"contact kept in {num(100 * m.get('contact_share', 0), 0)} % of "
                         f"optimisations, cylinder travel {num(100 * m.get('travel_median', 0), 0)}"
                         f" cm")
    return "; ".join(parts) or None


def _table1(preset: str) -> Callable[[Result], bool]:
    return lambda r: (r.kind == "table1" and r.data.get("preset") == preset and not r.quick
                      and not r.data.get("derivatives_effect") and r.data.get("cost") != "ee"
                      and r.data.get("clock_ms") is None)


def _table1_used(preset: str) -> Callable[[list[Result]], list[Result]]:
    """The files ``table1_line`` takes its numbers from: one per task."""
    return lambda results: [r for task in ("clutter", "soft", "soft_rigid")
                            if (r := paper_preset_table1(results, task, (preset,)))]


ROWS = (
    MapRow(SVR, "Table 1 on the authors' problems: clutter, soft, soft_rigid",
           "python experiments/mpc.py --task clutter --preset authors --layouts DIR",
           "State-vector reduction, Table 1 beside the paper", table1_line,
           _table1("authors"), "SVR costs less than the baseline", _table1_used("authors")),
    MapRow(SVR, "Table 1 on dopt's own push tasks (a second benchmark)",
           "python experiments/mpc.py --task clutter --preset paper",
           "State-vector reduction, Table 1: iLQR-SVR in asynchronous MPC",
           lambda results: table1_line(results, "paper"), _table1("paper"),
           uses=_table1_used("paper")),
    MapRow(SVR, "Fig. 4 on the authors' clutter: rho and theta",
           "python experiments/rho_sweep.py --task clutter --preset authors --layouts DIR",
           "State-vector reduction, Fig. 4: importance threshold rho and random DoFs theta",
           lambda results: fig4_line(results, "authors"),
           lambda r: (r.kind == "fig4" and not r.quick and r.data.get("problem") == "authors"),
           "The best rho is moderate", lambda results: fig4_files(results, "authors")[-1:]),
    MapRow(SVR, "Fig. 4 on dopt's own clutter (a second benchmark)",
           "python experiments/rho_sweep.py --task clutter --preset paper",
           "State-vector reduction, Fig. 4: importance threshold rho and random DoFs theta",
           fig4_line, lambda r: (r.kind == "fig4" and not r.quick
                                 and r.data.get("problem", "ours") != "authors")),
    MapRow(SVR, "The authors' clutter: SVR engages",
           "python experiments/svr_explain.py --preset authors --layouts DIR",
           "State-vector reduction: which DoFs each method holds, and what rho cuts",
           authors_line, lambda r: (r.kind in ("fig4", "svr_explain") and not r.quick
                                    and r.data.get("problem") == "authors"),
           "A larger rho keeps fewer DoFs"),
)


