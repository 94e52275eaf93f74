"""The state-vector-reduction sections of RESULTS.md: Table 1 (and beside the
paper's, its pairwise orderings judged with Holm's correction), Fig. 4, the SVR explanation, the
(the clocks: report_clock.py, the iLQR bench and the authors' data: report_bench.py)."""

from __future__ import annotations

import math
from pathlib import Path

from dopt.lab.report.base import (
    Result,
    _finite,
    link,
    num,
    pm,
    sci,
    section,
    source_lines,
    span,
    table,
    travel_cell,
)
from dopt.lab.report.stats import (
    CORRECTION,
    FAMILY_ALPHA,
    holm_family,
    kendall_tau_b,
    normal_p_from_intervals,
    pval,
    welch_p_from_intervals,
)
from planners.svr_mpc.experiments.report_choice import choice_lines

# ------------------------------------------------------------------------- table1 (SVR)
#: the paper, as the pages, the catalogue and the map name it
SVR = "state-vector reduction"
#: the Table 1 tasks of the paper, in its order
TASKS = ("clutter", "soft", "soft_rigid")
MPC_HEADER = ["MPC cost / baseline (mean ± CI90)", "median (all)", "opt. time (ms)", "DoFs",
              "lag (steps)", "success", "goal distance (m, median)", "outliers", "unstable",
              "trials"]


def mpc_cells(m: dict) -> list[str]:
    return [pm(num(m.get("mpc_cost_normalised_mean")), num(m.get("mpc_cost_normalised_ci90"))),
            num(m.get("mpc_cost_normalised_median")), num(m.get("opt_ms_mean"), 0),
            num(m.get("n_dofs_mean", m.get("dofs_mean")), 1), num(m.get("lag_steps_mean"), 1),
            num(m.get("success_rate")), num(m.get("goal_distance_end_median"), 3),
            str(m.get("outliers", "?")), str(m.get("n_unstable_trials", "-")),
            str(m.get("n_trials", m.get("trials", "?")))]


def table1_section(results: list[Result], page: Path) -> list[str]:
    def body(r: Result) -> list[str]:
        d = r.data
        lines = [f"### Table 1, {d.get('task')}: `{r.name}`" + (" (quick)" if r.quick else ""),
                 "", protocol_line(d), ""]
        if "row_settings" not in d:
            theta = d.get("theta")
            theta_text = (", ".join(f"{k} {v}" for k, v in theta.items())
                          if isinstance(theta, dict) else str(theta))
            lines[-2] += f" rho {d.get('rho')}; theta: {theta_text}; slowdown {d.get('slowdown')}."
        lines += table(["method", *MPC_HEADER],
                       [[name, *mpc_cells(m)] for name, m in d["methods"].items()])
        pairs = [(m.get("lag_steps_mean"), m.get("mpc_cost_normalised_mean"))
                 for m in d["methods"].values()]
        if len(pairs) >= 5 and all(None not in p for p in pairs):
            tau = kendall_tau_b([p[0] for p in pairs], [p[1] for p in pairs])
            lines += ["", f"Kendall tau of the rows' mean lag and mean normalised cost: "
                          f"{num(tau)} (1: the less a row lags, the less it costs)."]
        lines += versus_lines(d.get("versus")) + choice_lines(d.get("choice"))
        if d.get("versus_unstable_kept"):
            lines += ["", "The same with the episodes flagged unstable kept (how much the "
                      "verdicts owe to the stability bounds):"]
            lines += versus_lines(d["versus_unstable_kept"])[3:]
        fb = d.get("feedback_effect")
        if fb:
            lines += ["", "Feedback vs open loop, paired by seed (MPC cost ratio: geometric mean "
                      "and 90 % CI; pairs where feedback cost less; successes open loop -> "
                      "feedback):", ""]
            lines += table(["method", "cost ratio", "CI90", "feedback better", "successes"],
                           [[name, num(f.get("ratio_geomean")),
                             span(f.get("ratio_ci90")),
                             f"{f.get('better')}/{f.get('pairs')}",
                             f"{f.get('success_open_loop')} -> {f.get('success_feedback')}"]
                            for name, f in fb.items()])
        variants = d.get("derivatives_effect")
        if variants:
            lines += ["", "Derivative variants against the same row with finite differences at "
                      "every timestep, paired by seed (MPC cost ratio: geometric mean and 90 % "
                      "CI; pairs where the variant cost less; agent steps per optimisation and "
                      "optimisation time on the episode's clock, variant / plain):", ""]
            lines += table(["row", "versus", "cost ratio", "CI90", "variant better",
                            "lag (steps)", "opt. time (ms)"],
                           [[name, f["versus"], num(f["ratio_geomean"]),
                             span(f["ratio_ci90"]),
                             f"{f['better']}/{f['pairs']}",
                             f"{num(f['lag_steps_mean'], 1)} / "
                             f"{num(f['versus_lag_steps_mean'], 1)}",
                             f"{num(f['opt_ms_mean'], 0)} / {num(f['versus_opt_ms_mean'], 0)}"]
                            for name, f in variants.items()])
        return lines

    return section("State-vector reduction, Table 1: iLQR-SVR in asynchronous MPC",
                   "MPC cost normalised by the baseline's on the same task instance; mean and "
                   "90 % CI over the trials that are neither outliers (goal object too far from "
                   "the goal at the end) nor unstable (the executed episode broke a stability "
                   "bound; counted in its own column), median over all.", results, page, body)


def versus_lines(v: dict | None) -> list[str]:
    """The table of each SVR row against its references (``planners.svr_mpc.versus``: rand
    and baseline in Table 1, the baseline in Fig. 4); nothing for a summary without it."""
    if not v or not v.get("pairs"):
        return []
    alpha = v["alpha"]
    return ["", f"Each SVR row against {' and '.join(v['references'])}, paired by seed (MPC "
            f"cost ratio: geometric mean and a simultaneous {(1 - alpha) * 100:g} % interval "
            f"over the family of {v['family_size']}; a t-test on the log ratios, {CORRECTION} "
            f"over the family at {alpha * 100:g} %; pairs where the SVR row cost less, "
            f"and those left out because either trial is an outlier or unstable):", "",
            *table(["row", "versus", "cost ratio", "simultaneous interval", "p", "p (Holm)",
                    "SVR better", "verdict"],
                   [[x["row"], x["reference"], num(x["ratio_geomean"]),
                     span(x["ratio_ci_simultaneous"]), pval(x["p"]), pval(x["p_holm"]),
                     f"{x['better']}/{x['pairs']}"
                     + (f" ({x['excluded']} left out)" if x.get("excluded") else ""),
                     x["verdict"]]
                    for x in v["pairs"].values()])]


def verdict_counts(v: dict | None) -> dict[str, dict[str, int]]:
    """{reference: {"cheaper", "dearer", "n"}}: of a summary's SVR rows, how many Holm finds
    cheaper and dearer than each reference, out of n ({} without ``versus``)."""
    counts: dict = {}
    for x in ((v or {}).get("pairs") or {}).values():
        c = counts.setdefault(x["reference"], {"cheaper": 0, "dearer": 0, "n": 0})
        c["n"] += 1
        if x["verdict"] in ("cheaper", "dearer"):
            c[x["verdict"]] += 1
    return {ref: counts[ref] for ref in (v or {}).get("references", []) if ref in counts}


def versus_headline(v: dict | None) -> str:
    """One clause: how many SVR rows are cheaper / dearer than each reference under Holm."""
    parts = [f"against {ref}, {c['cheaper']} of {c['n']} SVR rows cheaper and {c['dearer']} "
             f"dearer" for ref, c in verdict_counts(v).items()]
    return f"; {CORRECTION} at {v['alpha'] * 100:g} %: " + ", ".join(parts) if parts else ""


def protocol_line(d: dict) -> str:
    """How a Table 1 file's trials ran (files without a "preset" ran ours, the only one then)."""
    if "preset" not in d:
        return ("Protocol `ours`: cost with the end-effector term, zero initial plan, real "
                "clock, no control noise.")
    return (f"Protocol `{d['preset']}`: cost `{d.get('cost')}`"
            + (", the authors' set-up motion and push plan" if d.get("warm_start")
               else ", zero initial plan")
            + (" ending braking (`--push-tail off`)"
               if d.get("warm_start") and d.get("push_tail") is False else "")
            + f", {d.get('clock')} clock"
            + (f" ({d.get('nominal_threads'):g} nominal threads)"
               if d.get("clock") == "virtual" else "")
            + (f" (every optimisation {d['clock_ms']:g} ms: every row lags alike)"
               if d.get("clock_ms") is not None else "")
            + f", control noise {d.get('control_noise')}, {d.get('fd')} differences, "
              f"slowdown {d.get('slowdown')}.")


#: the README map reads a Table 1 file's means only where at least this share of its
#: baseline's episodes is kept (neither an outlier nor flagged unstable): a row's mean is over
#: the seeds whose baseline is kept, and over the few unflagged episodes of a mostly flagged
#: baseline it describes a selected handful of seeds, not the task
MIN_KEPT_BASELINE = 0.5


def kept_baseline(data: dict) -> tuple[int, int] | None:
    """(kept, trials) of a Table 1 summary's baseline row: its episodes that are neither
    outliers nor unstable, the seeds every row's normalised mean can be over; None without
    a baseline row or its counts."""
    m = (data.get("methods") or {}).get("baseline")
    n = m and m.get("n_trials", m.get("trials"))
    return (_kept_trials(m), n) if isinstance(n, int) and n > 0 else None


def unstable_headline(data: dict) -> str:
    """"; episodes flagged unstable (left out of the means): row a/n, ..." for the rows with
    any (empty without)."""
    flagged = [f"{name} {m['n_unstable_trials']}/{m.get('n_trials', m.get('trials'))}"
               for name, m in (data.get("methods") or {}).items()
               if m.get("n_unstable_trials")]
    return ("; episodes flagged unstable (left out of the means): " + ", ".join(flagged)
            if flagged else "")


def table1_headline(r: Result) -> str:
    if r.data.get("derivatives_effect"):
        return "; ".join(
            f"{name} / {f['versus']}: MPC cost {num(f['ratio_geomean'])} "
            f"({span(f['ratio_ci90'])}), lag {num(f['lag_steps_mean'], 1)} "
            f"/ {num(f['versus_lag_steps_mean'], 1)} steps, opt. time "
            f"{num(f['opt_ms_mean'], 0)} / {num(f['versus_opt_ms_mean'], 0)} ms "
            f"({f['pairs']} seeds)" for name, f in r.data["derivatives_effect"].items())
    parts = []
    trials = 0
    for name, m in r.data["methods"].items():
        trials = max(trials, m.get("n_trials", m.get("trials")) or 0)
        cost = pm(num(m.get("mpc_cost_normalised_mean")), num(m.get("mpc_cost_normalised_ci90")))
        parts.append(f"{name} {cost} ({num(m.get('opt_ms_mean'), 0)} ms, "
                     f"{num(m.get('n_dofs_mean', m.get('dofs_mean')), 1)} DoFs)")
    cost_used = f", cost `{r.data['cost']}`" if r.data.get("cost") else ""
    return (f"protocol `{r.data.get('preset', 'ours')}`{cost_used}; MPC cost / baseline "
            f"(opt. time, DoFs): " + "; ".join(parts)
            + f" ({trials} trial{'s' if trials != 1 else ''} each)"
            + unstable_headline(r.data) + versus_headline(r.data.get("versus")))


# ------------------------------------------------------------- table1 beside the paper
def paper_table1(results: list[Result]) -> tuple[Result | None, dict]:
    """The authors' reference file with the paper's published Table 1 (the newest), and that
    table ({task: {row: {"mpc_cost", "mpc_cost_ci90", ...}}}); (None, {}) without one."""
    refs = [r for r in results if r.kind == "paper_svr" and r.data.get("published")]
    return (refs[-1], refs[-1].data["published"]) if refs else (None, {})


def paper_preset_table1(results: list[Result], task: str,
                        presets: tuple[str, ...] = ("authors", "paper")) -> Result | None:
    """The Table 1 file of ``task`` run under the authors' protocol (not quick), if any: the
    newest (by the date its trials' run recorded) of the first of ``presets`` that has one
    (by default on the authors' problems, preset ``authors``, where there is one, else on
    ours, ``paper``), with an SVR row (not a run of other optimisers' rows only)."""
    for preset in presets:
        chosen = [r for r in results if r.kind == "table1" and r.data.get("task") == task
                  and r.data.get("preset") == preset and not r.quick
                  and r.data.get("cost") != "ee"          # our cost term, not the paper's
                  and not r.data.get("derivatives_effect") and r.data.get("clock_ms") is None
                  and any(k.startswith(("sum-", "svd-")) for k in r.data.get("methods", {}))]
        if chosen:                       # the newest run (by its own date)
            return max(chosen, key=lambda r: str(r.origin.get("date", "")))
    return None


def orderings(paper: dict, ours: dict) -> dict:
    """How two Table 1 columns order the same rows by MPC cost. ``paper``: {row: (mean, CI90
    half-width)}, a normal interval (the authors' statistic, 1.645 std / sqrt(n)); ``ours``:
    {row: (mean, CI90 half-width[, trials])}, a Student-t interval over that many trials
    (without the count: taken as normal). Rows without both means are left out. Returns
    {"rows": the common rows, "paper_order", "our_order" (cheapest first), "kendall_tau",
    "reversed": [(a, b)] pairs the paper puts a below b and we put b below a,
    "reversed_separate": those of them whose intervals are separate in both columns,
    "holm": {column: {(a, b): (p, Holm-adjusted p, ordered apart)}} over each column's
    pairs (a z-test on the paper's column, Welch's on ours, from the means, intervals and
    counts; one family per column, family-wise ``FAMILY_ALPHA``), "reversed_holm": the
    reversed pairs ordered apart in both columns under it}."""
    rows = [k for k in paper if k in ours and _finite(paper[k][0]) and _finite(ours[k][0])]
    rev, sep = [], []
    p_paper, p_ours = {}, {}
    for i, a in enumerate(rows):
        for b in rows[i + 1:]:
            (pa, pca), (pb, pcb) = paper[a][:2], paper[b][:2]
            (oa, oca), (ob, ocb) = ours[a][:2], ours[b][:2]
            p_paper[a, b] = normal_p_from_intervals(paper[a], paper[b], 0.90)
            p_ours[a, b] = _our_p(ours[a], ours[b])
            if (pa - pb) * (oa - ob) < 0:
                lo, hi = (a, b) if pa < pb else (b, a)
                rev.append((lo, hi))
                if (abs(pa - pb) > (pca or 0) + (pcb or 0)
                        and abs(oa - ob) > (oca or 0) + (ocb or 0)):
                    sep.append((lo, hi))
    holm = {"paper": holm_family(p_paper), "ours": holm_family(p_ours)}

    def apart(a, b) -> bool:
        key = (a, b) if (a, b) in p_paper else (b, a)
        return all(key in h and h[key][2] for h in holm.values())
    tau = kendall_tau_b([paper[k][0] for k in rows], [ours[k][0] for k in rows])
    return {"rows": rows, "paper_order": sorted(rows, key=lambda k: paper[k][0]),
            "our_order": sorted(rows, key=lambda k: ours[k][0]), "kendall_tau": tau,
            "reversed": rev, "reversed_separate": sep, "holm": holm,
            "reversed_holm": [(a, b) for a, b in rev if apart(a, b)]}


def _our_p(a: tuple, b: tuple) -> float | None:
    """The p-value of our column's pair: Welch's from the t intervals and trial counts, a
    z-test where a count is missing."""
    if len(a) > 2 and len(b) > 2 and a[2] is not None and b[2] is not None:
        return welch_p_from_intervals(a, b, 0.90)
    return normal_p_from_intervals(a, b, 0.90)


def _table1_columns(pub: dict, d: dict) -> tuple[dict, dict]:
    """The paper's column {row: (mean, CI90)} and ours {row: (mean, CI90, trials the mean is
    over: neither outliers nor unstable)}."""
    paper = {row: (v["mpc_cost"], v.get("mpc_cost_ci90")) for row, v in pub.items()}
    ours = {row: (m.get("mpc_cost_normalised_mean"), m.get("mpc_cost_normalised_ci90"),
                  _kept_trials(m)) for row, m in d["methods"].items()}
    return paper, ours


def _kept_trials(m: dict) -> int | None:
    """The trials a row's normalised mean is over: its trials less its outliers and unstable
    ones (a seed its baseline lost is not known here: at most that many)."""
    n = m.get("n_trials", m.get("trials"))
    if not isinstance(n, int):
        return None
    return n - int(m.get("outliers") or 0) - int(m.get("n_unstable_trials") or 0)


def ordering_sentence(o: dict) -> str:
    """One line on how our rows order against the paper's."""
    apart = "; ".join(f"{a} < {b}" for a, b in o["reversed_holm"]) or "none"
    n_pairs = len(o["rows"]) * (len(o["rows"]) - 1) // 2
    return (f"Kendall tau {num(o['kendall_tau'])} over {len(o['rows'])} rows; "
            f"{len(o['reversed'])} of {n_pairs} pairs in the opposite order, "
            f"{len(o['reversed_holm'])} of them ordered apart in both columns under "
            f"{CORRECTION} over each column's {n_pairs} pairs (family-wise "
            f"{FAMILY_ALPHA * 100:g} %; the paper's column by a z-test on its normal 90 % "
            f"intervals, ours by Welch's test on our t intervals; paper's order: {apart})")


def table1_vs_paper_section(results: list[Result], page: Path) -> list[str]:
    """Each task's Table 1 under the authors' protocol beside the paper's printed Table 1 and
    the authors' data, with the orderings compared (empty without both files)."""
    ref, published = paper_table1(results)
    ours = {t: paper_preset_table1(results, t) for t in published}
    if ref is None or not any(ours.values()):
        return []
    lines = ["## State-vector reduction, Table 1 beside the paper", "",
             "Per row: the paper's printed MPC cost (normalised by its baseline's; mean ± 90 % "
             "CI, clutter without outliers), ours under `--preset authors` (else `paper`; "
             "mean ± 90 % CI of the per-seed cost / baseline, outliers left out; the median of "
             "the per-seed ratios; "
             "the geometric mean of the per-seed ratios with its 90 % CI), the authors' data's "
             "median final cost over baseline's (a robust summary; their own statistic, the fenced "
             "mean, is the paper's column), DoFs and "
             "optimisation time. Paired ratios and medians are ours only: the paper prints "
             "means.", ""]
    for task, r in ours.items():
        if r is None:
            continue
        d = r.data
        pub, data_rows = published[task], ref.data["tasks"].get(task, {}).get("rows", {})
        paired_ = d.get("paired") or {}
        rows = []
        for row, p in pub.items():
            m = d["methods"].get(row, {})
            pr = paired_.get(row) or {}
            ci = pr.get("ratio_ci90") or []
            rows.append([row, pm(num(p["mpc_cost"]), num(p.get("mpc_cost_ci90"), 3)),
                         pm(num(m.get("mpc_cost_normalised_mean")),
                            num(m.get("mpc_cost_normalised_ci90"))),
                         num(m.get("mpc_cost_median_ratio")),
                         num(pr.get("ratio_geomean")) + (f" [{num(ci[0])}, {num(ci[1])}]"
                                                         if len(ci) == 2 else ""),
                         num((data_rows.get(row) or {}).get("median_ratio")),
                         f"{num(p.get('n_dofs'), 1)} / "
                         f"{num(m.get('n_dofs_mean', m.get('dofs_mean')), 1)}",
                         f"{num(p.get('opt_ms'), 0)} / {num(m.get('opt_ms_mean'), 0)}",
                         travel_cell((d.get("authors_rows") or {}).get(row), m)])
        o = orderings(*_table1_columns(pub, d))
        alike = equal_lag_table1(results, task)
        lines += [f"### {task}: `{r.name}` beside the paper", "",
                  *table(["row", "paper MPC cost", "ours mean", "ours median ratio",
                          "ours paired geomean [CI90]", "authors' data median ratio",
                          "DoFs paper / ours", "opt. ms paper / ours",
                          "goal object travel, cm: authors / ours"], rows), "",
                  f"Cheapest first, paper: {', '.join(o['paper_order'])}; ours: "
                  f"{', '.join(o['our_order'])}.", "", ordering_sentence(o) + ".", "",
                  *equal_lag_lines(alike, pub),
                  *source_lines([r, ref] + ([alike] if alike else []), page), ""]
    return lines[:-1]


def equal_lag_table1(results: list[Result], task: str, like: Result | None = None):
    """The Table 1 file of ``task`` on the authors' problems with every row lagging alike (a
    fixed model clock, ``clock_ms``), if any: the last by name; given ``like`` (a run on the
    clock), of those run by its executor the newest by its trials' date."""
    chosen = [r for r in results if r.kind == "table1" and r.data.get("task") == task
              and r.data.get("preset") == "authors" and not r.quick
              and r.data.get("clock_ms") is not None and (like is None or r.data.get(
                  "executor") == like.data.get("executor"))]
    key = (lambda r: 0) if like is None else (lambda r: str(r.origin.get("date", "")))
    return sorted(chosen, key=key)[-1] if chosen else None


def equal_lag_lines(r: Result | None, pub: dict) -> list[str]:
    """What is left between the rows when every row lags alike: their order, the paper's
    Kendall tau and the Holm verdicts against baseline and rand (nothing without a file)."""
    if r is None:
        return []
    d = r.data
    o = orderings(*_table1_columns(pub, d))
    n = max((m.get("n_trials", m.get("trials")) or 0) for m in d["methods"].values())
    costs = ", ".join(f"{row} {num(m.get('mpc_cost_normalised_mean'))}"
                      for row, m in sorted(d["methods"].items(),
                                           key=lambda kv: kv[1].get("mpc_cost_normalised_mean")
                                           if _finite(kv[1].get("mpc_cost_normalised_mean"))
                                           else math.inf))
    return [f"Every row lagging alike (`{r.name}`: every optimisation {d['clock_ms']:g} ms on "
            f"the model clock, {n} scenes), cheapest first (mean cost / baseline): {costs}; "
            f"Kendall tau against the paper's order {num(o['kendall_tau'])}"
            + versus_headline(d.get("versus")) + ".", ""]


# --------------------------------------------------------------------------- fig4 (SVR)
def fig4_section(results: list[Result], page: Path) -> list[str]:
    def body(r: Result) -> list[str]:
        d = r.data
        points = sorted(d.get("points") or [], key=lambda p: (p.get("theta"), p.get("rho")))
        lines = [f"### Fig. 4, {d.get('task')}, {d.get('method')}: `{r.name}`"
                 + (" (quick)" if r.quick else ""), ""]
        if not points:
            return lines + ["No points (every trial failed?)."]
        # the sweep's rho_sweep.png, copied beside the docs under the summary's name
        image = page.parent / "images" / f"{r.path.stem}.png"
        if image.exists():
            lines += [f"![Fig. 4, {d.get('task')}: MPC cost / baseline and mean |C| against rho, "
                      f"ours (solid, 90 % CI bands) and the authors' (dashed)]"
                      f"(images/{image.name})", ""]
        return lines + table(["rho", "theta", *MPC_HEADER],
                             [[str(p.get("rho")), str(p.get("theta")), *mpc_cells(p)]
                              for p in points]) + versus_lines(d.get("versus"))

    return section("State-vector reduction, Fig. 4: importance threshold rho and random DoFs "
                   "theta", None, results, page, body)


def fig4_against_paper(d: dict, paper: dict) -> str | None:
    """One line on a Fig. 4 summary ``d`` beside the authors' runs of the same grid (``paper``:
    the paper_svr file's data, its "fig4" points of the task), on the statistic both have, the
    median MPC cost over the baseline's median: Kendall tau-b of our points' costs against
    theirs, and of each side's costs against its mean |C| (positive: the fewer DoFs, the
    cheaper). None with fewer than two common points."""
    theirs = {(p.get("theta"), p.get("rho")): p
              for p in paper.get("tasks", {}).get(d.get("task"), {}).get("fig4", [])}
    common = []
    for p in d.get("points") or []:
        t = theirs.get((p.get("theta"), p.get("rho")))
        if t and all(_finite(x) for x in (p.get("mpc_cost_median_ratio"), p.get("n_dofs_mean"),
                                         t.get("median_ratio"), t.get("avg_dofs"))):
            common.append((p, t))
    if len(common) < 2:
        return None
    ours = [p["mpc_cost_median_ratio"] for p, _ in common]
    their = [t["median_ratio"] for _, t in common]
    return (f"`{d.get('task')}`, {len(common)} points in common: our points' order against "
            f"theirs {num(kendall_tau_b(their, ours))}; cost against mean |C| "
            f"{num(kendall_tau_b([p['n_dofs_mean'] for p, _ in common], ours))} here, "
            f"{num(kendall_tau_b([t['avg_dofs'] for _, t in common], their))} in their runs.")


def fig4_vs_paper_section(results: list[Result], page: Path) -> list[str]:
    """Each Fig. 4 summary (not quick) beside the authors' runs of the same grid
    (``fig4_against_paper``; empty without the paper_svr file or a common point)."""
    refs = [r for r in results if r.kind == "paper_svr"]
    if not refs:
        return []
    lines = [f"- {link(r, page)}: {line}" for r in results if r.kind == "fig4" and not r.quick
             if (line := fig4_against_paper(r.data, refs[-1].data))]
    if not lines:
        return []
    return ["## State-vector reduction, Fig. 4 beside the authors' runs", "",
            f"Per Fig. 4 summary, against the authors' runs of the same (rho, theta) points "
            f"({link(refs[-1], page)}), on the statistic both have, the median MPC cost over "
            f"the baseline's median: Kendall tau-b of the two orders of the points, and of "
            f"each side's cost against its mean |C| (positive: the fewer DoFs, the cheaper).",
            "", *lines]


def fig4_headline(r: Result) -> str:
    points = [p for p in r.data.get("points") or []
              if _finite(p.get("mpc_cost_normalised_mean"))]
    if not points:
        return f"{r.data.get('method')}: no finite point"
    best = min(points, key=lambda p: p["mpc_cost_normalised_mean"])
    trials = sum(p.get("n_trials") or 0 for p in r.data.get("points") or [])
    cost = pm(num(best["mpc_cost_normalised_mean"]), num(best.get("mpc_cost_normalised_ci90")))
    return (f"{r.data.get('method')}, {len(r.data.get('points'))} (rho, theta) points, "
            f"{trials} trials; lowest MPC cost / baseline {cost} at rho {best.get('rho')}, "
            f"theta {best.get('theta')} ({num(best.get('n_dofs_mean'), 1)} DoFs)"
            + versus_headline(r.data.get("versus")))


HELD_LEGEND = ("; goal held: the share of those optimisations whose C holds both the goal "
               "object's x and y, and the median dJ/J of those and of the rest; rho 1 cuts "
               "the goal: the share of the SVR optimisations holding both whose least goal "
               "importance is below 1, where the new nominal touches the object and where "
               "it does not")


def held_cells(m: dict) -> list[str]:
    """The mechanism table's cells of ``svr_explain.goal_held_split``."""
    return [num(m.get("goal_held_share_away")),
            f"{sci(m.get('rel_improvement_median_away_held'))} / "
            f"{sci(m.get('rel_improvement_median_away_dropped'))}",
            f"{num(m.get('goal_cut_share_contact'))} / "
            f"{num(m.get('goal_cut_share_no_contact'))}"]


def svr_explain_section(results: list[Result], page: Path) -> list[str]:
    def body(r: Result) -> list[str]:
        d = r.data
        rows, mech = [], []
        fine = any("lt_0.1" in (row.get("importance_share") or {}) for row in d["rows"].values())
        shares = ("zero", "lt_0.1", "0.1_to_1", "1_to_500", "ge_500") if fine else \
            ("zero", "lt_1", "1_to_500", "ge_500")
        goal = any("goal_importance" in row for row in d["rows"].values())
        held = any("goal_held_share_away" in (row.get("mechanism") or {})
                   for row in d["rows"].values())
        for name, row in d["rows"].items():
            share = row.get("importance_share") or {}
            n_dofs = [v for v in row["n_dofs"] if v is not None]
            g = row.get("goal_importance") or {}
            rows.append([name, str(row["n_trials"]), num(sum(n_dofs) / len(n_dofs) if n_dofs
                                                         else None, 1),
                         num(row["goal_share_mean"]), *(num(share.get(k)) for k in shares),
                         str(row["importance"]["n"]),
                         *([f"{sci(g.get('first_median'))} / {sci(g.get('later_median'))}"]
                           if goal else [])])
            if m := row.get("mechanism"):
                mech.append([name, sci(m.get("rel_improvement_median_away")),
                             num(m.get("accepted_share")), num(m.get("contact_share")),
                             sci(m.get("mu_median")), num(m.get("travel_median"), 3),
                             num(m.get("goal_distance_end_median"), 3),
                             f"{num(m.get('lag_steps_median'), 1)} / {m.get('horizon')}",
                             *(held_cells(m) if held else [])])
        labels = {"zero": "= 0", "lt_0.1": "(0, 0.1)", "0.1_to_1": "[0.1, 1)", "lt_1": "< 1",
                  "1_to_500": "[1, 500)", "ge_500": ">= 500"}
        out = [f"### {d.get('task')}: `{r.name}`", "", protocol_line(d), "",
               *table(["row", "trials", "mean size of C", "goal DoFs in C",
                       *(f"importance {labels[k]}" for k in shares), "values",
                       *(["goal importance, first / later"] if goal else [])], rows)]
        if goal:
            out += ["", "Goal importance: the least importance of the goal object's x, y DoFs "
                    "(the first that rho cuts), median over episodes at the first optimisation "
                    "(every DoF in C) and over the later optimisations that held both."]
        if mech:
            out += ["", "Whether the optimiser engages (dJ/J: the median relative improvement "
                    "of an optimisation while the goal object is more than 5 cm from the goal; "
                    "contact: the share of optimisations whose new nominal touches the pushed "
                    "object; travel and end distance: medians over episodes, m"
                    + (HELD_LEGEND if held else "") + "):", "",
                    *table(["row", "dJ/J", "accepted", "contact", "mu", "travel",
                            "end distance", "lag / T",
                            *(["goal held", "dJ/J held / dropped",
                               "rho 1 cuts the goal: contact / none"] if held else [])], mech)]
        return out

    return section("State-vector reduction: which DoFs each method holds, and what rho cuts",
                   "Per row: mean |C| and the share of the goal object's x, y DoFs in C per "
                   "optimisation (over the episode, then over seeds); for SVR, the importances "
                   "of the non-robot DoFs in C before the cut, pooled over optimisations and "
                   "seeds.", results, page, body)
