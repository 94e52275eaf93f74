"""The state-vector-reduction paper's claims, each judged on the recorded result files (its
page, docs/STATE-VECTOR-REDUCTION.md; ``dopt.lab.report.claims``)."""

from __future__ import annotations

from collections.abc import Callable

from dopt.lab.report.base import Result, _finite, as_flag, num
from dopt.lab.report.claims import Claim, Finding, share
from planners.svr_mpc.experiments.report_svr import (
    MIN_KEPT_BASELINE,
    SVR,
    TASKS,
    equal_lag_table1,
    kept_baseline,
    paper_preset_table1,
    verdict_counts,
)


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
    """The Fig. 4 files (not quick) of ``problem`` ("authors" or "ours"), a reader takes the
    last: those on the authors' executor (their regime: ``dopt.mpc``'s ``authors``) after
    those on the paper's Alg. 1, and within each the most trials last."""
    files = [r for r in results if r.kind == "fig4" and not r.quick
             and r.data.get("problem", "ours") == problem]
    return sorted(files, key=lambda r: (r.data.get("executor", "alg1") == "authors",
                                        sum(p.get("n_trials") or 0
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
CLAIMS = (
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
