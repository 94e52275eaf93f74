"""The key-particle paper's claims, each judged on the recorded result files (its page,
docs/KEY-PARTICLES.md; ``dopt.lab.report.claims``)."""

from __future__ import annotations

from dopt.lab.report.base import Result, _and, _finite, mm
from dopt.lab.report.claims import Claim, Finding, newest, share
from planners.pick_place.experiments.report_encoding import TITLE as ENCODING_TITLE
from planners.pick_place.experiments.report_fig7 import _departs, fig7_claims, start_labels
from planners.pick_place.experiments.report_idle import idle_counts, idle_share, trial_records
from planners.pick_place.experiments.report_paper import (
    KP,
    encoding_families,
    n_range,
    scaling_families,
)


# ------------------------------------------------------------------------ key particles
def _key_counts(results: list[Result]) -> Finding | None:
    r = newest([r for r in results if r.kind == "key_particles" and not r.quick])
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
    r = newest([r for r in results if r.kind == "kp_authors"])
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


def _idle_from_prepared(panels: dict) -> str:
    """Per fold of ``panels`` ({goal: panel}) that starts from the prepared previous fold,
    how many of each method's plans pick nothing (``report_idle.idle_share``); "" if none."""
    parts = []
    for goal, p in panels.items():
        info = p["file"].notes.get("trials")
        if (p["file"].data.get("settings") or {}).get("fold_start") != "prepared" or not info:
            continue
        counts = idle_counts(trial_records(info.files))
        if any(i for i, _ in counts.values()):
            parts.append(f"{goal} {idle_share(counts)}")
    return ("; plans that pick nothing, leaving the prepared start to settle: "
            + "; ".join(parts)) if parts else ""


def _cloth_gap_grows(results: list[Result]) -> Finding | None:
    panels, files = _paper_panels(results, "cloth")
    g = next((g for g in fig7_claims(files)["cloth"] if g["setup"] == "preset paper"), None)
    if g is None or all(gap is None for _, gap in g["gaps"]):
        return None
    verdict = {True: "holds", False: "does not hold", None: "not judged"}[g["grows"]]
    apart = ("no two folds' gaps apart" if g["separate"] == [] else
             f"gaps apart only for {_and([f'{a} vs {b}' for a, b in g['separate']])}"
             if g["separate"] else "")
    labels = start_labels(g)
    return Finding(verdict, "the gap Original - Simple, diagonal to underneath: "
                   + ", ".join(f"{goal} {mm(gap)} mm" + labels.get(goal, "")
                               for goal, gap in g["gaps"])
                   + (f" ({apart})" if apart else "")
                   + ("; the multi-layer folds start differently, so their gaps belong to two "
                      "experiments" if labels else "")
                   + _idle_from_prepared(panels), tuple(files))


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
    return trend_finding({k: r for k, r in files.items() if not r.quick}, family, "n_particles")


def _encoding(results: list[Result]) -> Finding | None:
    return trend_finding(*encoding_families(results), "n_points",
                         " candidate points under the drag encoding, one physics mesh")


def trend_finding(files: dict, family: dict, counts: str, what: str = "") -> Finding | None:
    """Sec. V's claim judged on the trend tests of ``files`` ({key: a scaling summary}, N
    its ``counts`` field, ``what`` said after them; ``family``: their Holm family,
    ``trend_families``): per file the
    verdict on Original - Simple against log N; "holds" where it grows on every file (some:
    "partly holds"), "does not hold" where it grows on none and shrinks on some, "not shown"
    where no file finds a trend, "not judged" where no file has enough sizes and seeds to fit
    one. None without files."""
    if not files:
        return None
    words, fitted = {}, 0
    for goal, r in sorted(files.items()):
        t = {**r.data["trend"]["original_minus_simple"],
             **family.get((goal, "original_minus_simple"), {})}
        words[goal] = t["verdict"] if t["verdict"] in ("grows", "shrinks") else "no trend"
        if t.get("slope") is not None:
            fitted += 1
            words[goal] += f" ({mm(t['slope'])} ± {mm(t.get('slope_ci95'))} mm per log N)"
        else:
            words[goal] += " (too few sizes or seeds to fit one)"
    grows = sum(w.startswith("grows") for w in words.values())
    shrinks = sum(w.startswith("shrinks") for w in words.values())
    verdict = ("not judged" if not fitted else "not shown" if grows == shrinks == 0
               else "does not hold" if grows == 0 else share(grows, len(words)))
    ranges = {g: n_range(r, counts) for g, r in files.items()}
    if len(set(ranges.values())) == 1:            # one range: said once
        head = f"{next(iter(ranges.values()))}{what}"
    else:                                          # each file its own
        head, words = what.lstrip(), {g: f"({ranges[g]}) {w}" for g, w in words.items()}
    return Finding(verdict, "the gap Original - Simple against log N"
                   + (f" ({head})" if head else "") + ": "
                   + ", ".join(f"{g} {w}" for g, w in words.items()), tuple(files.values()))


def _panda(results: list[Result]) -> Finding | None:
    r = newest([r for r in results if r.kind == "panda_execute" and not r.quick])
    if r is None:
        return None
    goals = r.data["goals"]
    return Finding("not judged", "in simulation, a Panda executing the picker's plans ends "
                   + "; ".join(f"{mm(e['panda_final_cost_mean'])} mm from the {g} goal (the "
                               f"picker {mm(e['picker_final_cost_mean'])}, {e['n']} seeds)"
                               for g, e in goals.items()), (r,))


# ----------------------------------------------------------------------------- the list
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
    Claim(KP, "The gain grows with the candidate count under the authors' encoding", "Sec. V",
          "The improvement of the reduced action space over the original grows with the number "
          "of particles.",
          ENCODING_TITLE,
          _encoding, hidden_until_recorded=True),
    Claim(KP, "A robot arm executes the plans", "Sec. IV-D, Fig. 6",
          "A real robot executes the plans for the cloth folds (a demonstration).",
          "Key particles, Sec. IV-D: a Panda executes the plans", _panda),
)
