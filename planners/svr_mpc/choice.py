"""What each Table 1 row's active sets held, read from its finished trials (no simulation).

The paper's argument is about the choice of C: an SVR row should keep the DoFs that matter
(the pushed object's) and drop the rest. ``goal_held`` measures whether it does: per
optimisation after an episode's first (which every row runs over every DoF), whether C held
every planar DoF (world x and y, ``dopt.tasks.push.task_model.planar_dofs``) of the task's goal
objects. ``choice_fields`` sets that beside what else orders the rows: the lag, the steps the
authors' executor held the arm, and how far its nearest-state landing strays from the lag
(a C that holds moving objects can match a row far from where the arm is in time), each as
Kendall's tau against the rows' median cost ratio.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy import stats

from planners.svr_mpc.episode import dofs_of_mask
from planners.svr_mpc.settings import row_label, split_params


def goal_dofs(params: dict) -> np.ndarray:
    """(k,) int: the qvel indices of the goal objects' planar DoFs in the task instance of a
    trial's ``params`` (``trial_params``), built once per instance."""
    settings, seed, _ = split_params(params)
    return np.array(_goal_dofs(settings.task, settings.scene, int(seed)))


@lru_cache(maxsize=512)
def _goal_dofs(task: str, scene, seed: int) -> tuple[int, ...]:
    """The goal objects' planar DoFs of the task instance of ``seed`` on ``scene`` (a
    ``PushScene``: the same instance for every method)."""
    from dopt.tasks.push.task_model import planar_dofs
    from planners.svr_mpc.settings import SVRMPCSettings

    built = SVRMPCSettings(task=task, scene=scene).build_task(seed)
    return tuple(int(d) for d in planar_dofs(built.model, built.goal_bodies))


def goal_held(active_sets: list[str], goal: np.ndarray) -> list[bool]:
    """Per optimisation after the first, whether its C (a hex mask of ``dofs_mask``) holds
    every DoF of ``goal`` ((k,) int); [] for an episode of one optimisation."""
    return [bool(np.isin(goal, dofs_of_mask(m)).all()) for m in active_sets[1:]]


def choice_fields(records: list[dict], baseline: str = "baseline",
                  goal_of=goal_dofs) -> dict:
    """Per row (``row_label``; the ``unoptimised`` trials, whose C is empty, left out), over
    the trials that have active sets: "goal_held_share" (``goal_held`` pooled over every
    optimisation after the first), "held_steps_mean", "lag_steps_mean",
    "landing_offset_mean" (|landed row - lag| over the optimisations after the first, where
    the trials store landings; None elsewhere), and
    "cost_ratio_median" (the median over seeds of the row's MPC cost over ``baseline``'s on
    the same seed); then Kendall's tau (and p) of each of those three against
    "cost_ratio_median" over the rows other than ``baseline`` ("tau": {field: {"tau", "p"}};
    None with fewer than 3 rows). ``goal_of(params) -> (k,) int`` gives a trial's goal DoFs.

    Returns {"rows": {row: {...}}, "tau": {...}}; {} without a ``baseline`` row."""
    by: dict = {}
    for r in records:
        if r["params"].get("optimiser") == "unoptimised" or "active_sets" not in r["result"]:
            continue
        by.setdefault(row_label(r["params"]), []).append(r)
    if baseline not in by:
        return {}
    base = {r["params"]["seed"]: r["result"]["mpc_cost"] for r in by[baseline]}
    rows = {}
    for row, group in by.items():
        held = [h for r in group for h in goal_held(r["result"]["active_sets"],
                                                    goal_of(r["params"]))]
        ratios = [r["result"]["mpc_cost"] / base[r["params"]["seed"]] for r in group
                  if r["params"]["seed"] in base]
        rows[row] = {"goal_held_share": float(np.mean(held)) if held else None,
                     "held_steps_mean": float(np.mean([r["result"].get("held_steps", 0)
                                                       for r in group])),
                     "lag_steps_mean": float(np.mean([r["result"]["lag_steps_mean"]
                                                      for r in group])),
                     "landing_offset_mean": _landing_offset(group),
                     "cost_ratio_median": float(np.median(ratios)) if ratios else None,
                     "n_trials": len(group)}
    tau = {}
    others = [v for k, v in rows.items() if k != baseline and v["cost_ratio_median"] is not None]
    for field in ("goal_held_share", "held_steps_mean", "lag_steps_mean", "landing_offset_mean"):
        pts = [(v[field], v["cost_ratio_median"]) for v in others if v[field] is not None]
        if len(pts) < 3:
            tau[field] = None
            continue
        t, p = stats.kendalltau(*zip(*pts, strict=True))
        tau[field] = {"tau": float(t), "p": float(p), "rows": len(pts)}
    return {"rows": rows, "tau": tau}


def _landing_offset(group: list[dict]) -> float | None:
    """Mean |landed row - lag steps| over the optimisations after each trial's first, pooled
    over ``group``'s trials that store both (None: none does)."""
    offs = [abs(a - b) for r in group if "landed_at" in r["result"]
            for a, b in zip(r["result"]["landed_at"][1:], r["result"]["lag_steps"][1:],
                            strict=True)]
    return float(np.mean(offs)) if offs else None
