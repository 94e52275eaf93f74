"""The key-particle paper's Fig. 7 in RESULTS.md: the results table, each file's
detail, and the paper's claims checked on the recorded files (``fig7_claims``), each family of
Simple-vs-other comparisons judged with Holm's correction (``dopt.lab.report.stats``).
"""

from __future__ import annotations

import statistics
from pathlib import Path

from dopt.lab.report.base import (
    Result,
    _and,
    _finite,
    failed_lines,
    link,
    mm,
    num,
    pm,
    source,
    source_lines,
    table,
)
from dopt.lab.report.stats import (
    CORRECTION,
    FAMILY_ALPHA,
    holm_family,
    pval,
    welch_p,
    welch_p_from_intervals,
)
from planners.pick_place.experiments.report_idle import idle_plans_line, trial_records
from planners.pick_place.experiments.report_paper import (
    _label,
    _methods_in_order,
    _panel,
    _panel_rank,
)
from planners.pick_place.scaling import fold_costs
from planners.pick_place.tasks import pick_task

#: how the claims' sentences name the correction (RESULTS.md and the README)
HOLM_NOTE = (f"Holm p: Welch's p-value of the difference adjusted by {CORRECTION} over its "
             "family, the setup's Simple-vs-Original/Random differences on the cloth folds or "
             "on the rope panels, judged at a family-wise 5 %")
#: the Simple-vs-other comparisons of Fig. 7's claims, in the order the lines give them
OTHERS = ("original", "random")


# --------------------------------------------------------------------------- fig7 (KP)
def fig7_cell(e: dict | None) -> str:
    if not e:
        return "-"
    return pm(mm(e.get("final_cost_mean")), mm(e.get("final_cost_ci95")))


def fig7_section(results: list[Result], page: Path) -> list[str]:
    results = sorted(results, key=lambda r: (_panel_rank(r.data.get("task"),
                                                         r.data.get("goal")), r.name))
    methods = _methods_in_order(results)
    lines = ["## Key particles, Fig. 7: final cost of pick-and-place", "",
             "Mean particle distance to the goal after the whole plan (Eq. 2), in mm: mean ± "
             "95 % CI half-width over the seeds (no interval with one seed). Candidates: the "
             "particles each planner may pick (last stage).", ""]
    header = ["Fig. 7", *[_label(m) for m in methods], "seeds", "candidates", "source"]
    # seeds and candidates: one per method present, in the columns' order
    rows = []
    for r in results:
        ms = r.data["methods"]
        seeds = [str(ms[m].get("n", "?")) for m in methods if m in ms]
        rows.append([f"{_panel(r)} ({fig7_setup(r)})" + (" (quick)" if r.quick else ""),
                     *[fig7_cell(ms.get(m)) for m in methods],
                     seeds[0] if len(set(seeds)) == 1 else " / ".join(seeds),
                     " / ".join(str(ms[m].get("n_candidates", "?")) for m in methods
                                if m in ms),
                     source(r, page)])
    lines += table(header, rows)
    claims = fig7_claims_lines(results, page)
    if claims:
        lines += ["", "The paper's claims on these files (Simple's 95 % interval wholly below "
                      "the other's: separate; difference: the other's mean minus Simple's ± "
                      "its Welch 95 % interval, which excludes zero where the half-width is "
                      f"smaller; the gaps likewise; {HOLM_NOTE}):", "", *claims]
    for r in results:
        lines += ["", *fig7_detail(r, page, results)]
    return lines


def _fig7_physics(d: dict) -> str:
    """The preset name and, where the summary records it, what it meant (a preset's fields
    change between commits: a summary without them names its commit)."""
    name = (d.get("settings") or {}).get("physics", "default")
    scene = (d.get("physics") or {}).get("scene")
    if not scene:
        commit = str((d.get("provenance") or {}).get("git_commit") or "?")[:8]
        return f"preset {name} as defined at {commit}"
    what = [f"dt {scene['timestep'] * 1000:g} ms"]
    if "young" in scene:
        what.insert(0, f"{scene['young']:.2g} Pa")
    if "triangulation" in scene:
        what.append(f"{scene['triangulation']} triangles")
    energy = ((d.get("physics") or {}).get("stability") or {}).get("max_energy_gain")
    what.append(f"energy bound {energy:g} J/kg" if energy is not None
                else "no energy bound in the verdict")
    return f"preset {name} ({', '.join(what)})"


def fold_reference(settings: dict) -> str:
    """For a multi-layer cloth fold, the sentence that sizes its last fold: the flat sheet's
    and the previous fold's goal's cost to its goal (a plan that leaves the prepared start as
    it is ends near the latter); "" for other settings."""
    try:
        if settings.get("task") != "cloth":
            return ""
        flat, previous = fold_costs(str(settings["goal"]), int(settings["n"]),
                                     float(settings["side"]))
    except (KeyError, TypeError, ValueError, AttributeError):
        return ""
    if previous is None:
        return ""
    return (f"The last fold's share: the flat sheet lies {mm(flat)} mm from this goal, the "
            f"previous fold's goal {mm(previous)} mm: a plan that leaves the previous fold as "
            "it is ends near there.")


def fold_notes(settings: dict, records) -> list[str]:
    """The lines under a Fig. 7 table, each after a blank line: the last fold's share
    (``fold_reference`` of the trials' ``settings``) and the plans that pick nothing among
    ``records``, (method, trial result) pairs (``report_idle.idle_plans_line``)."""
    notes = [fold_reference(settings), idle_plans_line(records)]
    return [x for n in notes if n for x in ("", n)]


def fig7_detail(r: Result, page: Path, results: list[Result]) -> list[str]:
    d = r.data
    s = d.get("settings") or {}
    cem = s.get("cem") or {}
    lines = [f"### Fig. 7 {_panel(r)}, {fig7_setup(r)}: `{r.name}`", ""]
    if s:
        lines += [f"Settings: {s.get('task')} {s.get('goal')}, n {s.get('n')}, bound "
                  f"{s.get('bound')} m, self-collision {'on' if s.get('selfcollide') else 'off'}, "
                  f"physics {_fig7_physics(d)}"
                  + "".join(f", {label} {s[k]}" for k, label in (
                      ("planning_physics", "CEM plans on preset"),
                      ("picker_speed", "picker speed (m/s)"),
                      ("picker_move", "picker move"),
                      ("rest_speed", "samples settle until at rest below (m/s)"),
                      ("max_stretch", "stretch limit"),
                      ("fold_start", "fold start")) if s.get(k) is not None)
                  + f"; CEM population {cem.get('population')}, elites {cem.get('elites')}, "
                  f"{cem.get('iterations')} iterations per stage, horizon {cem.get('horizon')}."
                  + (f" Trials' wall time {num(d['trials_wall_s'], 0)} s in total."
                     if "trials_wall_s" in d else
                     f" Wall time {num(d.get('wall_s'), 0)} s." if "wall_s" in d else ""), ""]
    rope_ratio = any("end_to_end_ratio_mean" in e for e in d["methods"].values())
    # the paper's rope metrics (m in the file): name in the summary -> column
    extra = {k: c for k, c in (("straighten_error", "|end-to-end - length| (mm)"),
                               ("matching_distance", "matching distance (mm)"))
             if any(f"{k}_mean" in e for e in d["methods"].values())}
    infeasible = any(e.get("n_infeasible_rollouts") for e in d["methods"].values())
    last = any(e.get("last_improvements") for e in d["methods"].values())
    header = ["method", "final cost (mm)", "per seed (mm)", "seeds", "candidates",
              "s / CEM iteration", "unstable trials", "unstable rollouts"] + (
        [f"last improvement (iteration of {cem.get('iterations')})"] if last else []) + (
        ["infeasible rollouts (stretch)"] if infeasible else []) + (
        ["end-to-end / length"] if rope_ratio else []) + list(extra.values())
    rows = []
    for m, e in d["methods"].items():
        row = [_label(m), fig7_cell(e),
               ", ".join(mm(c) for c in e.get("final_costs", [])),
               ", ".join(str(x) for x in e.get("seeds", [])) + f" (n = {e.get('n')})",
               str(e.get("n_candidates", "?")), num(e.get("s_per_iteration"), 2),
               _unstable_trials(e),
               f"{e['n_unstable_rollouts']} / {e['n_rollouts']}" if "n_rollouts" in e
               else "not judged"]
        if last:
            row.append(_last_improvement(e))
        if infeasible:
            row.append(f"{e.get('n_infeasible_rollouts', 0)} / {e.get('n_rollouts', '?')}")
        if rope_ratio:
            row.append(pm(num(e.get("end_to_end_ratio_mean")),
                          num(e.get("end_to_end_ratio_ci95"))))
        for k in extra:
            mean, ci = e.get(f"{k}_mean"), e.get(f"{k}_ci95")
            row.append(pm(num(None if mean is None else 1e3 * mean, 1),
                          num(None if ci is None else 1e3 * ci, 1)))
        rows.append(row)
    lines += table(header, rows)
    info = r.notes.get("trials")
    lines += fold_notes(s, trial_records(info.files if info is not None else []))
    lines += fig7_against_protocol(r, results, page)
    return lines + [""] + source_lines([r], page) + failed_lines(r)


def _last_improvement(e: dict) -> str:
    """The CEM iteration after which the last stage's best cost last fell: its range and
    median over the seeds ("-" for the scripted policy)."""
    its = [i for i in e.get("last_improvements") or [] if i is not None]
    if not its:
        return "-"
    return f"{min(its)}-{max(its)} (median {statistics.median(its):g})"


def fig7_against_protocol(r: Result, results: list[Result], page: Path) -> list[str]:
    """For a file with departures from its protocol: each method's score on the panel's paper
    metric (``PAPER_METRICS``; else the mean particle distance) against the file of the same
    panel and protocol without departures, seed by seed (lower on k of the n seeds both ran);
    empty otherwise."""
    if not fig7_departures(r):
        return []
    def key(f: Result) -> tuple:
        return f.data.get("task"), f.data.get("goal"), f.data.get("protocol", "ours")

    base = [b for b in results if b.kind == "fig7" and not b.quick and not fig7_departures(b)
            and key(b) == key(r)]
    if not base:
        return []
    b = base[0]
    out = []
    for m, e in r.data["methods"].items():
        other = b.data["methods"].get(m)
        if not other:
            continue
        # the panel's paper metric where both files hold it per seed
        metric = paper_metric(r, "s", e, other)
        mine = dict(zip(e.get("seeds", []), e.get(f"{metric}s", []), strict=False))
        theirs = dict(zip(other.get("seeds", []), other.get(f"{metric}s", []), strict=False))
        shared = sorted(set(mine) & set(theirs))
        if shared:
            lower = sum(mine[k] < theirs[k] for k in shared)
            secs = ((e.get("s_per_iteration"), other.get("s_per_iteration"))
                    if _finite(e.get("s_per_iteration"))
                    and _finite(other.get("s_per_iteration")) else None)
            out.append(f"{_label(m)} at {fig7_departures(r)}: {METRIC_NAMES[metric]} lower "
                       f"than under preset {r.data.get('protocol', 'ours')} as it stands "
                       f"({link(b, page)}) on {lower} of the {len(shared)} seeds both "
                       f"ran" + (f"; {num(secs[0], 1)} s per CEM iteration against "
                                 f"{num(secs[1], 1)} ({num(secs[0] / secs[1])} times)"
                                 if secs else "") + ".")
    return ["", *out] if out else []


def _unstable_trials(e: dict) -> str:
    """Unstable executed plans of a Fig. 7 method (left out of the mean), or "not judged" for
    a file written before the stability verdict existed."""
    if "n_unstable_trials" not in e:
        return "not judged"
    n = e["n_unstable_trials"]
    return f"{n} (seeds {', '.join(map(str, e['unstable_seeds']))})" if n else "0"



def fig7_headline(r: Result) -> str:
    ms = r.data["methods"]
    parts = []
    for i, m in enumerate(_methods_in_order([r])):
        e = ms[m]
        text = (f"{_label(m)} {fig7_cell(e)} mm" if i == 0
                else f"{_label(m).replace('CEM(', '').rstrip(')')} {mm(e.get('final_cost_mean'))}")
        if "end_to_end_ratio_mean" in e and i == 0:
            text += f", end-to-end {num(e['end_to_end_ratio_mean'])} L"
        parts.append(text)
    seeds = max((e.get("n") or 0) for e in ms.values()) if ms else 0
    return ", ".join(parts) + f" ({seeds} seed{'s' if seeds != 1 else ''})"


#: the paper's order of the cloth folds by difficulty (Sec. IV-C.2)
CLOTH_DIFFICULTY = ("diagonal", "side", "reflective", "underneath")


#: the paper's score of each Fig. 7 panel (Sec. IV-B), where it is not the mean particle
#: distance ("final_cost"): rope straightening |end-to-end distance - length|, rope folding
#: the bipartite-matching distance; and how a claim line names it
PAPER_METRICS = {("rope", "straighten"): "straighten_error",
                 ("rope", "fold"): "matching_distance"}
METRIC_NAMES = {"final_cost": "mean particle distance",
                "straighten_error": "|end-to-end - length|",
                "matching_distance": "matching distance"}


def paper_metric(r: Result, field: str, *entries: dict | None) -> str:
    """The paper's metric of a Fig. 7 file's panel (``PAPER_METRICS``) where every method entry
    to compare holds it as ``<metric><field>`` ("_mean", or "s": per seed); otherwise the
    mean particle distance."""
    metric = PAPER_METRICS.get((r.data.get("task"), r.data.get("goal")), "final_cost")
    return metric if all(e and f"{metric}{field}" in e for e in entries) else "final_cost"


def comparison(a: dict | None, b: dict | None, metric: str = "final_cost") -> str:
    """Whether method a's ``metric`` (its ``<metric>_mean`` and ``_ci95``) is below b's:
    "yes (separate)" when a's 95 % interval lies wholly below b's, "yes (overlap)",
    "no (overlap)", "no (separate)"; "n/a" without both means."""
    if not a or not b or not (_finite(a.get(f"{metric}_mean"))
                              and _finite(b.get(f"{metric}_mean"))):
        return "n/a"
    ma, mb = a[f"{metric}_mean"], b[f"{metric}_mean"]
    ca, cb = a.get(f"{metric}_ci95"), b.get(f"{metric}_ci95")
    separate = _finite(ca) and _finite(cb) and abs(ma - mb) > ca + cb
    return f"{'yes' if ma < mb else 'no'} ({'separate' if separate else 'overlap'})"


def difference(a: dict | None, b: dict | None, metric: str = "final_cost") -> float | None:
    """The half-width of the Welch 95 % interval of b's ``metric`` mean minus a's, as b's
    entry records it against CEM(Simple) (``<metric>_minus_simple_ci95``, ``a`` being Simple's
    entry); None where the file has none. Around the means' difference it says whether the
    two methods differ where their own intervals (``comparison``) overlap."""
    half = (b or {}).get(f"{metric}_minus_simple_ci95") if a else None
    return half if _finite(half) else None


def _claim(a: dict | None, b: dict | None, metric: str, holm: tuple | None = None) -> str:
    """``comparison`` with the difference b - a and its Welch interval, where recorded, and
    the difference's Holm-adjusted p-value within its family (``holm``: (p, adjusted p,
    rejected), ``fig7_claims``): "yes (overlap; difference 12.9 ± 11.7 mm, Holm p 0.068)"."""
    c = comparison(a, b, metric)
    half = difference(a, b, metric) if c != "n/a" else None
    if half is None:
        return c
    diff = b[f"{metric}_mean"] - a[f"{metric}_mean"]
    adjusted = f", Holm p {pval(holm[1])}" if holm else ""
    return f"{c[:-1]}; difference {mm(diff)} ± {mm(half)} mm{adjusted})"


def _stable_values(e: dict, metric: str) -> list[float] | None:
    """The per-seed ``metric`` of an entry's stable trials (``<metric>s`` by ``seeds``, less
    ``unstable_seeds``: the values its mean is over); None where the entry does not hold
    them."""
    values, seeds = e.get(f"{metric}s"), e.get("seeds")
    if not isinstance(values, list) or not isinstance(seeds, list) or len(values) != len(seeds):
        return None
    unstable = set(e.get("unstable_seeds") or ())
    out = [v for seed, v in zip(seeds, values, strict=True) if seed not in unstable]
    return out if all(_finite(v) for v in out) else None


def difference_p(a: dict | None, b: dict | None, metric: str = "final_cost") -> float | None:
    """Welch's two-sided p-value of b's ``metric`` mean minus a's (the test of the interval
    ``difference`` gives): from the stable trials' per-seed values where both entries hold
    them, else from each entry's mean, 95 % half-width and count of stable trials; None
    without two values on each side."""
    if not a or not b:
        return None
    xa, xb = _stable_values(a, metric), _stable_values(b, metric)
    if xa is not None and xb is not None:
        return welch_p(xa, xb)

    def side(e: dict) -> tuple:
        return e.get(f"{metric}_mean"), e.get(f"{metric}_ci95"), e.get("n_stable", e.get("n"))
    return welch_p_from_intervals(side(a), side(b), 0.95)


def fig7_departures(r: Result) -> str:
    """The settings a Fig. 7 file changed from its protocol's preset (its "departures",
    ``PickPlaceSettings.departures``), e.g. "population 200, elites 20"; "" when none (or a
    file from before the field was recorded: its command names any flags)."""
    return ", ".join(f"{k.rsplit('.', 1)[-1].replace('_', ' ')} {v}"
                     for k, v in (r.data.get("departures") or {}).items())


def _departs(r: Result) -> bool:
    """A Fig. 7 file whose flags changed its protocol's settings."""
    return r.kind == "fig7" and bool(fig7_departures(r))


def fig7_setup(r: Result) -> str:
    """The protocol a Fig. 7 file ran ("preset paper", "preset ours") and its
    departures: files of one setup are one experiment, judged together."""
    dep = fig7_departures(r)
    return f"preset {r.data.get('protocol', 'ours')}" + (f", {dep}" if dep else "")


def _several_stages(goal: str) -> bool:
    """Whether cloth fold ``goal`` has a fold before its last (its start, "prepared" or
    "chained", is then part of the experiment)."""
    try:
        return pick_task("cloth").goal(goal).prepared is not None
    except ValueError:
        return False


def start_labels(cloth: dict) -> dict[str, str]:
    """For one setup's cloth claims (``fig7_claims``' "cloth" entry), each multi-layer fold's
    " (<start> start)" where the folds' starts differ; {} where they agree."""
    start = dict(cloth["starts"])
    if len(set(start.values())) < 2:
        return {}
    return {goal: f" ({s} start)" for goal, s in start.items()}


def fig7_claims(results: list[Result]) -> dict:
    """The paper's Fig. 7 claims checked on the recorded files (not quick), per setup
    (``fig7_setup``: protocol and departures; one panel may be run under several).

    "panels": {"<panel>, <setup>": whether Simple < Original and Simple < Random
    (``comparison``) on the panel's paper metric (``PAPER_METRICS``; a file without it: the
    mean particle distance), the gap Original - Simple of the mean particle distance (m), the
    seeds and the size}; "cloth": per setup with cloth folds, the gaps in the paper's order of
    difficulty, each fold's cloth size, each multi-layer fold's start ("prepared" or "chained")
    and whether the gap grows (None: not judged; a gap at another cloth size, another N_O, or
    from another start is another experiment: judged only when all four folds share one size
    and the multi-layer folds one start)."""
    panels, gaps, starts = {}, {}, {}
    for r in sorted(results, key=lambda r: _panel_rank(r.data.get("task"), r.data.get("goal"))):
        if r.kind != "fig7" or r.quick:
            continue
        ms = r.data["methods"]
        n = (r.data.get("settings") or {}).get("n")
        s, o = ms.get("simple"), ms.get("original")
        gap = (o["final_cost_mean"] - s["final_cost_mean"]
               if s and o and _finite(s.get("final_cost_mean"))
               and _finite(o.get("final_cost_mean")) else None)
        metric = paper_metric(r, "_mean", s)
        setup = fig7_setup(r)
        panels[f"{_panel(r)}, {setup}"] = {
            "file": r, "metric": metric, "setup": setup, "task": r.data.get("task"),
            "goal": r.data.get("goal"), "entries": (s, {m: ms.get(m) for m in OTHERS}),
            "p": {m: difference_p(s, ms.get(m), metric) for m in OTHERS},
            "gap": gap, "seeds": max((e.get("n") or 0) for e in ms.values()),
            "size": (f"{n} x {n} particles" if r.data.get("task") == "cloth"
                     else f"{n} particles") if n else "size ?"}
        if r.data.get("task") == "cloth" and r.data.get("goal") in CLOTH_DIFFICULTY:
            gaps.setdefault(setup, []).append(
                (CLOTH_DIFFICULTY.index(r.data["goal"]), r.data["goal"], gap, n,
                 difference(s, o) if gap is not None else None, r.data.get("trials_wall_s")))
            if _several_stages(r.data["goal"]):
                starts.setdefault(setup, {})[r.data["goal"]] = (
                    (r.data.get("settings") or {}).get("fold_start") or "chained")
    cloth = []
    for setup, folds in gaps.items():
        folds.sort()
        values = [g for _, _, g, _, _, _ in folds]
        sizes = {n for _, _, _, n, _, _ in folds}
        walls = [w for *_, w in folds]
        start = starts.get(setup, {})
        grows = (None if len(values) < len(CLOTH_DIFFICULTY) or len(sizes) != 1
                 or len(set(start.values())) > 1 or any(g is None for g in values)
                 else all(b > a for a, b in zip(values, values[1:], strict=False)))
        halves = [h for *_, h, _ in folds]
        # pairs of folds whose gaps' 95 % intervals are separate; None where a gap or its
        # interval is unknown
        separate = (None if any(g is None or h is None
                                for g, h in zip(values, halves, strict=True))
                    else [(folds[i][1], folds[j][1]) for i in range(len(folds))
                          for j in range(i + 1, len(folds))
                          if abs(values[j] - values[i]) > halves[i] + halves[j]])
        cloth.append({"setup": setup, "gaps": [(goal, g) for _, goal, g, _, _, _ in folds],
                      "gap_ci95": [(goal, h) for _, goal, _, _, h, _ in folds],
                      "separate": separate,
                      "sizes": [(goal, n) for _, goal, _, n, _, _ in folds], "grows": grows,
                      "starts": sorted(start.items(), key=lambda gs: CLOTH_DIFFICULTY.index(gs[0])),
                      # the folds' trials in seconds of one core, where every file says
                      "trials_wall_s": (sum(walls) if all(_finite(w) for w in walls)
                                        else None)})
    families = holm_families(panels)
    for p in panels.values():
        s, others = p.pop("entries")
        for m in OTHERS:
            p[f"simple_vs_{m}"] = _claim(s, others[m], p["metric"], p["holm"].get(m))
    return {"panels": panels, "cloth": cloth, "families": families}


def holm_families(panels: dict) -> list[dict]:
    """Fig. 7's families of comparisons, judged with Holm's correction: per setup, the
    Simple-vs-Original and Simple-vs-Random differences of its cloth folds (eight when all
    four are run) and, apart, those of its rope panels, each with a Welch p-value
    (``difference_p``). Sets each panel's "holm": {method: (p, adjusted p, rejected at
    ``FAMILY_ALPHA``)} and returns per family {"setup", "task", "m", "rejected": [(goal,
    method, adjusted p)], "kept": [...], "uncorrected": differences with p <= alpha alone,
    "bonferroni": those with m p <= alpha, "simple_higher": rejected ones where Simple's
    mean is the higher}."""
    groups: dict = {}
    for key, p in panels.items():
        p["holm"] = {}
        for m in OTHERS:
            if p["p"][m] is not None:
                groups.setdefault((p["setup"], p["task"]), {})[key, m] = p["p"][m]
    out = []
    for (setup, task), family in groups.items():
        judged = holm_family(family, FAMILY_ALPHA)
        rejected, kept, higher = [], [], []
        for (key, m), (_, adjusted, reject) in judged.items():
            panels[key]["holm"][m] = judged[key, m]
            item = (panels[key]["goal"], m, adjusted)
            (rejected if reject else kept).append(item)
            s, others = panels[key]["entries"]
            metric = panels[key]["metric"]
            if reject and others[m][f"{metric}_mean"] < s[f"{metric}_mean"]:
                higher.append(item)
        m_ = len(judged)
        out.append({"setup": setup, "task": task, "m": m_, "rejected": rejected,
                    "kept": kept, "simple_higher": higher,
                    "uncorrected": sum(p <= FAMILY_ALPHA for p, _, _ in judged.values()),
                    "bonferroni": sum(p * m_ <= FAMILY_ALPHA for p, _, _ in judged.values())})
    return out


def holm_lines(families: list[dict]) -> list[str]:
    """One line per family of ``holm_families``: how many differences exclude zero under
    Holm's correction, which do not, and the counts uncorrected and under Bonferroni."""
    lines = []
    for f in families:
        if f["m"] < 2:
            continue
        what = "cloth folds" if f["task"] == "cloth" else f"{f['task']} panels"
        kept = _and([f"{goal} vs {_label(m).replace('CEM(', '').rstrip(')')} (adjusted p "
                     f"{pval(adj)})" for goal, m, adj in f["kept"]]) if f["kept"] else ""
        line = (f"- {f['setup']}, {what}: with {CORRECTION} over the family's {f['m']} "
                f"Simple-vs-Original/Random differences (family-wise {FAMILY_ALPHA:.0%}), "
                f"{len(f['rejected'])} of {f['m']} exclude{'s' if len(f['rejected']) == 1 else ''} "
                "zero"
                + (f"; {kept} {'does' if len(f['kept']) == 1 else 'do'} not" if kept else "")
                + f". Uncorrected, {f['uncorrected']} of {f['m']} do; Bonferroni keeps "
                  f"{f['bonferroni']}.")
        if f["simple_higher"]:
            line += " Simple is the higher in " + _and(
                [f"{goal} vs {_label(m)}" for goal, m, _ in f["simple_higher"]]) + "."
        lines.append(line.replace(" 5%", " 5 %"))
    return lines



def fig7_claims_lines(results: list[Result], page: Path) -> list[str]:
    """The claims as a bulleted list (empty without Fig. 7 files)."""
    c = fig7_claims(results)
    if not c["panels"]:
        return []
    # a file without Original or Random (a run of Simple alone) claims nothing here
    lines = [f"- {panel} ({p['size']}, {p['seeds']} seeds, {METRIC_NAMES[p['metric']]}): "
             f"Simple < Original "
             f"{p['simple_vs_original']}, Simple < Random {p['simple_vs_random']}; "
             f"{source(p['file'], page)}" for panel, p in c["panels"].items()
             if {p["simple_vs_original"], p["simple_vs_random"]} != {"n/a"}]
    for g in c["cloth"]:
        if all(gap is None for _, gap in g["gaps"]):   # no Original in this setup
            continue
        size, half = dict(g["sizes"]), dict(g["gap_ci95"])
        mixed = len(set(size.values())) > 1
        labels = start_labels(g)
        gaps = ", ".join(f"{goal} {mm(gap)}"
                         + (f" ± {mm(half[goal])}" if half[goal] is not None else "")
                         + (f" at {size[goal]} x {size[goal]}" if mixed else "")
                         + labels.get(goal, "")
                         for goal, gap in g["gaps"])
        missing = [goal for goal in CLOTH_DIFFICULTY if goal not in size]
        if mixed:
            verdict = "whether it grows cannot be judged until all folds are run at one size"
        elif labels:
            verdict = (f"whether it grows cannot be judged until {_and(list(labels))} "
                       "are run from one start")
        elif missing:
            verdict = (f"whether it grows cannot be judged until {_and(missing)} "
                       f"{'is' if len(missing) == 1 else 'are'} run")
        else:
            verdict = {True: "it grows with difficulty",
                       False: "it does not grow with difficulty",
                       None: "whether it grows cannot be judged"}[g["grows"]]
            if g["separate"] == []:
                verdict += ("; no two folds' gap intervals are separate, so these seeds "
                            "cannot order the folds by their gap")
            elif g["separate"]:
                verdict += ("; gap intervals separate only for " + _and(
                    [f"{a} vs {b}" for a, b in g["separate"]]))
        lines.append(f"- {g['setup']}: the gap Original - Simple (mm) over the cloth folds in "
                     f"the paper's order of difficulty: {gaps}; {verdict} (the paper: it "
                     f"grows).")
        if not missing and g["trials_wall_s"] is not None:
            lines.append(f"- {g['setup']}: the four cloth folds' trials took "
                         f"{g['trials_wall_s'] / 3600:.1f} h of one core.")
    return lines + holm_lines(c["families"])


