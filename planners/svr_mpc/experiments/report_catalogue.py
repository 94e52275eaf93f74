"""What the state-vector-reduction paper's experiments reproduce (their catalogue entries, the
headline rows of RESULTS.md) and how their summaries are rebuilt from their committed trials
(``experiments/resummarize.py``, ``dopt.lab.report.resummarize``), and which trials a clock
check holds."""

from __future__ import annotations

import re
from pathlib import Path

from dopt.lab.report.base import Result
from dopt.lab.report.engine import Entry
from dopt.lab.report.resummarize import commits_of
from dopt.lab.report.trials import TrialInfo
from dopt.lab.trialpack import StoredTrial, stored_trials
from planners.svr_mpc.experiments.report_svr import SVR

SEED = re.compile(r"-seed(?P<seed>\d+)(-|$)")


def has_variant(tag: str):
    """A ``where`` test of a Table 1 file's "derivatives_effect": a row with ``tag``
    (``+skip``, ``+boxqp``, ``+central``)."""
    return lambda effect: any(tag in row for row in effect or {})


#: the paper's Table 1 trials per task
TABLE1_TRIALS = {"clutter": 100, "soft": 20, "soft_rigid": 20}
#: trials per task of the Table 1 runs with the end-effector cost term
TABLE1_EE_TRIALS = {"clutter": 20, "soft": 10, "soft_rigid": 10}

CATALOGUE = (
    [Entry(SVR, f"Table 1: {task}", f"python experiments/mpc.py --task {task} --preset paper "
             f"--trials {n} --workers 2 --no-render --out docs/results/runs/table1-{task} "
             f"--record docs/results/table1-{task}.json", "table1",
             {"task": task, "derivatives_effect": None, "cost": lambda c: c != "ee"})
       for task, n in TABLE1_TRIALS.items()]
    + [Entry(SVR, f"Table 1 with the end-effector term (ours), {task}",
             f"python experiments/mpc.py --task {task} --preset paper --cost ee --trials {n} "
             f"--workers 2 --no-render --out docs/results/runs/table1-{task}-ee "
             f"--record docs/results/table1-{task}-ee.json", "table1",
             {"task": task, "derivatives_effect": None, "cost": "ee"})
       for task, n in TABLE1_EE_TRIALS.items()]
    + [Entry(SVR, f"Beyond the paper: FD at every K-th timestep on sum-t10-r1, {task}",
             f"python experiments/mpc.py --task {task} --preset paper --rows "
             f"baseline,sum-t10-r1,sum-t10-r1+skip5,sum-t10-r1+skip10 --trials {n} --workers 2 "
             f"--no-render --out docs/results/runs/keypoints-{task} "
             f"--record docs/results/keypoints-{task}.json", "table1",
             {"task": task, "derivatives_effect": has_variant("+skip")})
       for task, n in TABLE1_TRIALS.items()]
    + [Entry(SVR, f"Beyond the paper: control limits in iLQR's backward pass (box QP), {task}",
             f"python experiments/mpc.py --task {task} --preset paper --rows "
             f"baseline,sum-t10-r1,sum-t10-r1+boxqp --trials 10 --workers 2 --no-render "
             f"--out docs/results/runs/boxqp-{task} --record docs/results/boxqp-{task}.json",
             "table1", {"task": task, "derivatives_effect": has_variant("+boxqp")})
       for task in TABLE1_TRIALS]
    + [Entry(SVR, "Finite differences: the authors' central (eps 1e-6) against our forward "
                  "(eps 1e-3), clutter",
             "python experiments/mpc.py --task clutter --preset paper --rows "
             "baseline,sum-t10-r1,sum-t10-r1+central --trials 20 --workers 2 --no-render "
             "--out docs/results/runs/fd-central-clutter "
             "--record docs/results/fd-central-clutter.json", "table1",
             {"task": "clutter", "derivatives_effect": has_variant("+central")})]
    + [Entry(SVR, "Table 1's virtual clock against the real clock",
             "python experiments/clock_check.py --task clutter --preset paper --rows "
             "baseline,rand-t5,sum-t10-r1 --trials 10 --out docs/results/runs/clock-check-clutter "
             "--record docs/results/clock-check-clutter.json", "clock_check",
             {"nominal_threads": 2.0})]
    + [Entry(SVR, "The virtual clock at 1.3 nominal threads (the first check's speed-up), "
                  "on a second machine",
             "python experiments/clock_check.py --task clutter --preset paper --rows "
             "baseline,rand-t5,sum-t10-r1 --seed 10 --trials 10 --nominal-threads 1.3 "
             "--out docs/results/runs/clock-check-clutter "
             "--record docs/results/clock-check-clutter-1.3.json", "clock_check",
             {"nominal_threads": 1.3})]
    + [Entry(SVR, "Fig. 4: rho, theta sweep",
             "python experiments/rho_sweep.py --task clutter --preset paper --rhos "
             "0,0.1,0.5,1,5,10,20,50,100,500,1e6 --thetas 0,5,10 --trials 20 --workers 2 "
             "--paper-reference docs/results/paper-svr.json --out docs/results/runs/fig4-clutter "
             "--record docs/results/fig4-clutter.json", "fig4")])


def clock_check_trials(folder: Path, r: Result) -> list[StoredTrial]:
    """The trials of a clock check: its seeds' under ``real/`` and ``virtual/``."""
    seeds = set(r.data.get("seeds") or ())
    files = [p for sub in ("real", "virtual") for p in stored_trials(folder / sub / "trials")]
    return [p for p in files if (m := SEED.search(p.stem)) and int(m["seed"]) in seeds]


def _baseline(records: list[dict]) -> str:
    """The row every other is normalised by (experiments/mpc.py's ``baseline_label``): the
    row of the baseline trials run without feedback (by the paper's optimiser)."""
    from planners.svr_mpc import DEFAULT_OPTIMISER, row_label

    base = [r for r in records if r["params"]["method"] == "baseline"
            and r["params"].get("optimiser", DEFAULT_OPTIMISER) == DEFAULT_OPTIMISER]
    plain = [r for r in base if not r["params"].get("feedback")] or base
    return row_label(plain[0]["params"]) if plain else "baseline"


def table1_rebuild(d: dict, records: list[dict], info: TrialInfo) -> dict:
    from planners.svr_mpc import row_label, table1_fields

    if rows := d.get("methods"):        # its own rows: another run may share the folder
        records = [r for r in records if row_label(r["params"]) in rows]
    return {"row_settings": {row_label(r["params"]): {k: r["params"][k]
                                                      for k in ("method", "theta", "rho")}
                             for r in records},
            **table1_fields(records, baseline=_baseline(records)),
            "trial_commits": commits_of(records)}


def fig4_rebuild(d: dict, records: list[dict], info: TrialInfo) -> dict:
    from planners.svr_mpc import fig4_fields

    return {**fig4_fields(records, d.get("method"), baseline=_baseline(records)),
            "trial_commits": commits_of(records)}


def clock_check_rebuild(d: dict, records: list[dict], info: TrialInfo) -> dict:
    from planners.svr_mpc.experiments import clock_check

    by: dict = {}
    for path, r in zip(sorted(info.files, key=lambda p: p.name), records, strict=True):
        by.setdefault(path.parent.parent.name, []).append(r)
    nominal = next(r["params"]["nominal_threads"] for r in by.get("virtual", records))
    return {"rows": clock_check.compare({c: by[c] for c in ("real", "virtual") if c in by},
                                        nominal),
            "trial_commits": {c: commits_of(rs) for c, rs in by.items()}}


def svr_explain_rebuild(d: dict, records: list[dict], info: TrialInfo) -> dict:
    from planners.svr_mpc.experiments import explain as svr_explain

    m = re.search(r"--bins[ =](\d+)", str((d.get("resummarized_from") or d.get("provenance")
                                          or {}).get("command") or ""))
    bins = int(m.group(1)) if m else svr_explain.parser().get_default("bins")
    return {"rows": svr_explain.summarize_rows(records, bins),
            "trial_commits": commits_of(records)}
