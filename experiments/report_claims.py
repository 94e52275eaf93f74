"""The papers' claims, each judged on the recorded result files (the per-paper pages).

A ``Claim`` names what a paper says (in words, where it says it) and how our result files
judge it: ``judge(results)`` gives a ``Finding`` (the verdict, one sentence of what we measured
with every number read from the files, and the files it read), or None where no file bears on
it yet. Verdicts (``VERDICTS``): "holds", "partly holds" (some of its cases hold), "does not
hold", "not shown" (the test finds no effect either way) and "not judged" (a demonstration or a
case no file can decide). ``CLAIMS`` lists both papers' claims in the order their pages give
them; ``claim_of(title)`` finds one by its title, which is also its heading on the page (the
README map links there). Standard library only (report.py's rule).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from report_base import KP, SVR, Result, _and, _finite, as_flag, mm, num
from report_fig7 import _departs, fig7_claims
from report_stats import scaling_families
from report_svr import (
    MIN_KEPT_BASELINE,
    equal_lag_table1,
    kept_baseline,
    paper_preset_table1,
    verdict_counts,
)

#: each paper's page, beside the index docs/RESULTS.md (``report_pages``)
PAGE_FILES = {KP: "KEY-PARTICLES.md", SVR: "STATE-VECTOR-REDUCTION.md"}
VERDICTS = ("holds", "partly holds", "does not hold", "not shown", "not judged")
#: the Table 1 tasks of the state-vector-reduction paper, in its order
TASKS = ("clutter", "soft", "soft_rigid")


@dataclass(frozen=True)
class Finding:
    """A claim judged: ``verdict`` (one of ``VERDICTS``), ``measured`` (a sentence, every
    number from ``files``) and the result files it read."""

    verdict: str
    measured: str
    files: tuple[Result, ...]

    def __post_init__(self):
        if self.verdict not in VERDICTS:
            raise ValueError(f"verdict must be one of {VERDICTS}, got {self.verdict!r}")


@dataclass(frozen=True)
class Claim:
    """What ``paper`` says at ``where`` (``says``, in words), how ``judge`` reads it from the
    result files, and the RESULTS.md section (``details``) that holds the tables behind it."""

    paper: str
    title: str
    where: str
    says: str
    details: str
    judge: Callable[[list[Result]], Finding | None]


def share(k: int, n: int) -> str:
    """The verdict of a claim that holds in ``k`` of its ``n`` cases."""
    if n == 0:
        return "not judged"
    return "holds" if k == n else "does not hold" if k == 0 else "partly holds"


def _newest(files: list[Result]) -> Result | None:
    return max(files, key=lambda r: str(r.origin.get("date", ""))) if files else None


# ------------------------------------------------------------------------ key particles
def _key_counts(results: list[Result]) -> Finding | None:
    r = _newest([r for r in results if r.kind == "key_particles" and not r.quick])
    if r is None:
        return None
    tasks, paper = r.data.get("tasks") or {}, r.data.get("paper") or {}
    cases = []
    for goal, p in paper.items():
        ours = tasks.get(goal) or {}
        field, key = ("n_elements", "triangles") if "triangles" in p else ("n_keys", "keys")
        if key in p and field in ours:
            cases.append((goal.replace("_", " "), ours[field], p[key], key))
    held = [c for c in cases if c[1] == c[2]]
    off = [f"{g} {o} {k} (paper {p})" for g, o, p, k in cases if o != p]
    return Finding(share(len(held), len(cases)),
                   f"{len(held)} of {len(cases)} goals reduce to the paper's count"
                   + (f"; not {_and(off)}" if off else ""), (r,))


def _authors_goals(results: list[Result]) -> Finding | None:
    r = _newest([r for r in results if r.kind == "kp_authors"])
    if r is None:
        return None
    s = r.data["summary"]
    return Finding(share(min(s["paper_elements_held"], s["keys_held"]), s["goals"]),
                   f"the paper's triangles on {s['paper_elements_held']} of {s['goals']} of "
                   f"the authors' goals, its keys on {s['keys_held']}, the same key particles "
                   f"as the authors' code on {s['keys_agree']}", (r,))


def _paper_panels(results: list[Result], task: str) -> tuple[dict, list[Result]]:
    """Fig. 7's panels of ``task`` under the paper's protocol without departures, judged
    (``fig7_claims``), and their files."""
    files = [r for r in results if r.kind == "fig7" and r.data.get("task") == task
             and r.data.get("protocol") == "paper" and not r.quick and not _departs(r)]
    panels = {p["goal"]: p for p in fig7_claims(files)["panels"].values()}
    return panels, files


def _rope(results: list[Result]) -> Finding | None:
    panels, files = _paper_panels(results, "rope")
    if not panels:
        return None
    cases, parts = 0, []
    for goal, p in panels.items():
        ms = p["file"].data["methods"]
        means = {m: ms[m]["final_cost_mean"] for m in ("simple", "original", "random")
                 if _finite((ms.get(m) or {}).get("final_cost_mean"))}
        below = "simple" in means and "original" in means and means["simple"] < means["original"]
        worst = len(means) == 3 and max(means, key=means.get) == "random"
        cases += below + worst
        held = (p["holm"].get("original") or (None, None, False))[2]
        parts.append(f"{goal}: Simple {mm(means.get('simple'))} mm, Original "
                     f"{mm(means.get('original'))}, Random {mm(means.get('random'))}"
                     f" (Simple < Original {'apart' if held else 'not apart'} under Holm)")
    return Finding(share(cases, 2 * len(panels)), "; ".join(parts), tuple(files))


def _cloth_beats_original(results: list[Result]) -> Finding | None:
    panels, files = _paper_panels(results, "cloth")
    judged = {g: p for g, p in panels.items() if p["holm"].get("original")}
    if not judged:
        return None
    apart = [g for g, p in judged.items() if p["holm"]["original"][2]
             and p["gap"] is not None and p["gap"] > 0]
    return Finding(share(len(apart), len(judged)),
                   f"CEM(Simple) ends closer than CEM(Original) with the difference apart from "
                   f"zero under Holm on {len(apart)} of {len(judged)} folds ("
                   + "; ".join(f"{g}: {p['simple_vs_original']}" for g, p in judged.items())
                   + ")", tuple(files))


def _cloth_gap_grows(results: list[Result]) -> Finding | None:
    _, files = _paper_panels(results, "cloth")
    g = next((g for g in fig7_claims(files)["cloth"] if g["setup"] == "preset paper"), None)
    if g is None or all(gap is None for _, gap in g["gaps"]):
        return None
    verdict = {True: "holds", False: "does not hold", None: "not judged"}[g["grows"]]
    apart = ("no two folds' gaps apart" if g["separate"] == [] else
             f"gaps apart only for {_and([f'{a} vs {b}' for a, b in g['separate']])}"
             if g["separate"] else "")
    return Finding(verdict, "the gap Original - Simple, diagonal to underneath: "
                   + ", ".join(f"{goal} {mm(gap)} mm" for goal, gap in g["gaps"])
                   + (f" ({apart})" if apart else ""), tuple(files))


def _random_over_original(results: list[Result]) -> Finding | None:
    panels, files = _paper_panels(results, "cloth")
    pairs = {}
    for goal, p in panels.items():
        ms = p["file"].data["methods"]
        o, r = ((ms.get(m) or {}).get("final_cost_mean") for m in ("original", "random"))
        if _finite(o) and _finite(r):
            pairs[goal] = (r, o)
    if not pairs:
        return None
    below = [g for g, (r, o) in pairs.items() if r < o]
    return Finding(share(len(below), len(pairs)),
                   f"CEM(Random) below CEM(Original) on {len(below)} of {len(pairs)} folds ("
                   + ", ".join(f"{g} {mm(r)} vs {mm(o)} mm" for g, (r, o) in pairs.items())
                   + ")", tuple(files))


def _scaling(results: list[Result]) -> Finding | None:
    files, family = scaling_families(results)
    files = {k: r for k, r in files.items() if not r.quick}
    if not files:
        return None
    words = {}
    for goal, r in sorted(files.items()):
        t = {**r.data["trend"]["original_minus_simple"],
             **family.get((goal, "original_minus_simple"), {})}
        words[goal] = t["verdict"] if t["verdict"] in ("grows", "shrinks") else "no trend"
        if t.get("slope") is not None:
            words[goal] += f" ({mm(t['slope'])} ± {mm(t.get('slope_ci95'))} mm per log N)"
    grows = sum(w.startswith("grows") for w in words.values())
    shrinks = sum(w.startswith("shrinks") for w in words.values())
    verdict = ("not shown" if grows == shrinks == 0
               else "does not hold" if grows == 0 else share(grows, len(words)))
    sizes = sorted({n for r in files.values() for n in r.data["n_particles"]})
    return Finding(verdict, f"the gap Original - Simple against log N (N {sizes[0]}-"
                   f"{sizes[-1]}): " + ", ".join(f"{g} {w}" for g, w in words.items()),
                   tuple(files.values()))


def _panda(results: list[Result]) -> Finding | None:
    r = _newest([r for r in results if r.kind == "panda_execute" and not r.quick])
    if r is None:
        return None
    goals = r.data["goals"]
    return Finding("not judged", "in simulation, a Panda executing the picker's plans ends "
                   + "; ".join(f"{mm(e['panda_final_cost_mean'])} mm from the {g} goal (the "
                               f"picker {mm(e['picker_final_cost_mean'])}, {e['n']} seeds)"
                               for g, e in goals.items()), (r,))


# ------------------------------------------------------------------ state-vector reduction
def _authors_table1(results: list[Result]) -> dict[str, Result]:
    """{task: its Table 1 file on the authors' problems} (``paper_preset_table1``)."""
    return {t: r for t in TASKS if (r := paper_preset_table1(results, t, ("authors",)))}


def _few_baseline(r: Result) -> str | None:
    """Why a Table 1 file's rows cannot be judged against its baseline: its baseline is kept
    (neither outlier nor unstable) in fewer than ``MIN_KEPT_BASELINE`` of its episodes; None
    when it can."""
    kept = kept_baseline(r.data)
    if kept and kept[0] < MIN_KEPT_BASELINE * kept[1]:
        return f"not judged (baseline kept in {kept[0]} of {kept[1]})"
    return None


def _versus(reference: str) -> Callable[[list[Result]], Finding | None]:
    """The judge of "SVR costs less than ``reference``" on the authors' problems: a task holds
    where Holm finds some SVR row cheaper than it and none dearer (the paper: its methods are
    capable of a lower cost); a task whose baseline is mostly left out (``_few_baseline``) is
    not judged against the baseline."""
    def judge(results: list[Result]) -> Finding | None:
        held, judged, parts, files = 0, 0, [], []
        for task, r in _authors_table1(results).items():
            few = _few_baseline(r) if reference == "baseline" else None
            c = verdict_counts(r.data.get("versus")).get(reference)
            if few is None and c is None:
                continue
            files.append(r)
            if few is not None:
                parts.append(f"{task} {few}")
                continue
            judged += 1
            held += c["cheaper"] > 0 and c["dearer"] == 0
            parts.append(f"{task} {c['cheaper']} of {c['n']} SVR rows cheaper, "
                         f"{c['dearer']} dearer" + _at_equal_time(results, r, reference))
        if not parts:
            return None
        return Finding(share(held, judged), "under Holm's correction: " + "; ".join(parts),
                       tuple(files))
    return judge


def _at_equal_time(results: list[Result], free: Result, reference: str) -> str:
    """" (at equal time, every optimisation X ms: a of n cheaper, b dearer)" where the task
    of ``free`` has an equal-lag run by the same executor (``equal_lag_table1``), else ""."""
    equal = equal_lag_table1(results, free.data.get("task"), like=free)
    c = equal and verdict_counts(equal.data.get("versus")).get(reference)
    if not c:
        return ""
    return (f" (at equal time, every optimisation {as_flag(equal.data['clock_ms'])} ms: "
            f"{c['cheaper']} of {c['n']} cheaper, {c['dearer']} dearer)")


def _faster(results: list[Result]) -> Finding | None:
    files = _authors_table1(results)
    held, parts = 0, []
    for task, r in files.items():
        ms = r.data["methods"]
        base = (ms.get("baseline") or {}).get("opt_ms_mean")
        ratios = [m["opt_ms_mean"] / base for k, m in ms.items()
                  if k.startswith(("sum-", "svd-")) and _finite(m.get("opt_ms_mean"))] \
            if _finite(base) and base > 0 else []
        if ratios:
            held += max(ratios) < 1
            parts.append(f"{task} {num(min(ratios))}-{num(max(ratios))} of the baseline's")
    if not parts:
        return None
    return Finding(share(held, len(parts)), "SVR rows' optimisation time: " + "; ".join(parts),
                   tuple(files.values()))


def _lag(results: list[Result]) -> Finding | None:
    """The paper's mechanism: the gain is the time saved, so it is gone when every row's
    optimisation takes the same time (a fixed model clock, ``equal_lag_table1``, run by the
    same executor). A task holds where Holm finds some SVR row cheaper than baseline on the
    clock and none at equal time."""
    held, judged, parts, files = 0, 0, [], []
    for task, free in _authors_table1(results).items():
        equal = equal_lag_table1(results, task, like=free)
        if equal is None:
            continue
        files += [free, equal]
        few = _few_baseline(free) or _few_baseline(equal)
        c_free = verdict_counts(free.data.get("versus")).get("baseline")
        c_eq = verdict_counts(equal.data.get("versus")).get("baseline")
        if few or not c_free or not c_eq:
            parts.append(f"{task} {few or 'not judged (no test against baseline)'}")
            continue
        judged += 1
        held += c_free["cheaper"] > 0 and c_eq["cheaper"] == 0
        parts.append(f"{task}: {c_free['cheaper']} of {c_free['n']} SVR rows cheaper than "
                     f"baseline on the clock, {c_eq['cheaper']} of {c_eq['n']} with every "
                     f"optimisation {as_flag(equal.data['clock_ms'])} ms")
    if not parts:
        return None
    return Finding(share(held, judged), "; ".join(parts), tuple(files))


def fig4_files(results: list[Result], problem: str) -> list[Result]:
    """The Fig. 4 files (not quick) of ``problem`` ("authors" or "ours"), fewest trials first:
    a reader takes the last, the sweep with the most scenes per point."""
    files = [r for r in results if r.kind == "fig4" and not r.quick
             and r.data.get("problem", "ours") == problem]
    return sorted(files, key=lambda r: (sum(p.get("n_trials") or 0
                                            for p in r.data.get("points") or []), r.name))


def _curves(results: list[Result], field: str) -> tuple[Result | None, dict]:
    """The authors' Fig. 4 file and {theta: [(rho, field value)] by rho}, finite values only,
    rho above zero (rho 0 is the baseline)."""
    files = fig4_files(results, "authors")
    if not files:
        return None, {}
    curves: dict = {}
    for p in files[-1].data.get("points") or []:
        if _finite(p.get(field)) and _finite(p.get("rho")) and p["rho"] > 0:
            curves.setdefault(p.get("theta"), []).append((p["rho"], p[field]))
    return files[-1], {t: sorted(c) for t, c in sorted(curves.items()) if len(c) > 1}


def _dofs_fall(results: list[Result]) -> Finding | None:
    r, curves = _curves(results, "n_dofs_mean")
    if not curves:
        return None
    falls = [t for t, c in curves.items()
             if all(b[1] <= a[1] for a, b in zip(c, c[1:], strict=False))]
    return Finding(share(len(falls), len(curves)),
                   f"mean |C| never rises with rho for {len(falls)} of {len(curves)} thetas ("
                   + "; ".join(f"theta {t}: {num(c[0][1], 1)} to {num(c[-1][1], 1)}"
                               for t, c in curves.items()) + ")", (r,))


def _theta_zero(results: list[Result]) -> Finding | None:
    r, curves = _curves(results, "mpc_cost_normalised_mean")
    if 0 not in curves or len(curves) < 2:
        return None
    others = {t: dict(c) for t, c in curves.items() if t != 0}
    common = [(rho, v) for rho, v in curves[0] if all(rho in o for o in others.values())]
    worse = [rho for rho, v in common if all(v > o[rho] for o in others.values())]
    return Finding(share(len(worse), len(common)),
                   f"theta 0 the dearest at {len(worse)} of {len(common)} rho values "
                   f"(theta {', '.join(map(str, others))} beside it)", (r,))


def _moderate_rho(results: list[Result]) -> Finding | None:
    r, curves = _curves(results, "mpc_cost_normalised_mean")
    if not curves:
        return None
    inner = {t: min(c, key=lambda x: x[1])[0] for t, c in curves.items()}
    moderate = [t for t, rho in inner.items() if curves[t][0][0] < rho < curves[t][-1][0]]
    return Finding(share(len(moderate), len(inner)),
                   "the cheapest rho lies inside the grid for "
                   f"{len(moderate)} of {len(inner)} thetas ("
                   + "; ".join(f"theta {t}: rho {as_flag(rho)}" for t, rho in inner.items()) + ")",
                   (r,))


# ----------------------------------------------------------------------------- the list
_T1 = "State-vector reduction, Table 1 beside the paper"
_F4 = "State-vector reduction, Fig. 4: importance threshold rho and random DoFs theta"
_F7 = "Key particles, Fig. 7: final cost of pick-and-place"
CLAIMS = (
    Claim(KP, "Few key particles per goal", "Sec. IV-C.1, Fig. 4",
          "Simplifying each goal shape keeps a handful of key particles: two and four on the "
          "rope, a few triangles on the cloth.",
          "Key particles, Fig. 4 and Sec. IV-C.1: key particles of each goal", _key_counts),
    Claim(KP, "The same keys on the authors' goals", "Sec. IV-C.1",
          "The authors' own cloth goals reduce to the counts the paper prints.",
          "Key particles on the authors' own goals", _authors_goals),
    Claim(KP, "Rope: Simple beats Original, Random is worst", "Sec. IV-C.2, Fig. 7 (a, b)",
          "On the rope CEM(Simple) ends closer than CEM(Original), with a modest gain, and "
          "CEM(Random) finds the worst plan on both panels.", _F7, _rope),
    Claim(KP, "Cloth: Simple beats Original on every fold", "Sec. IV-C.2, Fig. 7 (c-f)",
          "CEM(Simple) achieves a better solution than CEM(Original) consistently in all four "
          "cloth folds.", _F7, _cloth_beats_original),
    Claim(KP, "Cloth: the gap grows with difficulty", "Sec. IV-C.2, Fig. 7 (d-f)",
          "From the side to the reflective to the underneath fold the gap between CEM(Simple) "
          "and CEM(Original) increases.", _F7, _cloth_gap_grows),
    Claim(KP, "Cloth: Random beats Original", "Sec. IV-C.2, Fig. 7 (c-f)",
          "In all cloth folds CEM(Random) achieves slightly better results than CEM(Original).",
          _F7, _random_over_original),
    Claim(KP, "The gain grows with the particle count", "Sec. IV-C.2, Sec. V",
          "The gain of the reduced action space over the original grows with the number of "
          "particles: modest on the rope, large on the cloth.",
          "Key particles: the gain against the particle count", _scaling),
    Claim(KP, "A robot arm executes the plans", "Sec. IV-D, Fig. 6",
          "A real robot executes the plans for the cloth folds (a demonstration).",
          "Key particles, Sec. IV-D: a Panda executes the plans", _panda),
    Claim(SVR, "SVR costs less than the baseline", "Sec. VI, Table 1",
          "On all three tasks the reduced methods reach a lower MPC cost than iLQR-Baseline.",
          _T1, _versus("baseline")),
    Claim(SVR, "SVR costs less than a random choice", "Sec. VI, Table 1",
          "Choosing the DoFs by importance beats keeping as few chosen at random (iLQR-Rand).",
          _T1, _versus("rand-t5")),
    Claim(SVR, "SVR optimises faster", "Sec. I, Table 1",
          "A reduced state vector makes each optimisation significantly faster.", _T1,
          _faster),
    Claim(SVR, "The gain is the lag saved", "Abstract, Sec. VI",
          "The lower MPC cost comes from the shorter optimisations: less policy lag.",
          "State-vector reduction, Table 1: iLQR-SVR in asynchronous MPC", _lag),
    Claim(SVR, "A larger rho keeps fewer DoFs", "Sec. VI, Fig. 4",
          "As rho increases the methods get pickier and the mean size of C decreases.", _F4,
          _dofs_fall),
    Claim(SVR, "Never re-adding DoFs does worse", "Sec. VI, Fig. 4",
          "With theta zero (no DoF is ever re-introduced) SVR does noticeably worse than with "
          "the other two thetas.", _F4, _theta_zero),
    Claim(SVR, "The best rho is moderate", "Sec. VI, Fig. 4",
          "The best rho is a moderate value: near zero SVR tends to the baseline, large it "
          "tends to iLQR-Rand.", _F4, _moderate_rho),
)


def claim_of(title: str) -> Claim:
    """The claim of ``title`` (ValueError naming it if there is none)."""
    for c in CLAIMS:
        if c.title == title:
            return c
    raise ValueError(f"no claim titled {title!r}; claims: {[c.title for c in CLAIMS]}")
