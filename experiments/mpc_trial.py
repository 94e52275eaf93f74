"""One asynchronous-MPC trial of the state-vector-reduction paper, and the aggregation of many.

``run_trial(params)`` is a pure function of (task, method, parameters, seed): it builds its own
task instance, cost, rollout service, iLQR and DoF selector, runs one MPC episode in real time
(times ``slowdown``), and returns a JSON-able dict. The same seed gives every method the same
task layout, so costs are compared pairwise against baseline.
"""

from __future__ import annotations

import numpy as np

from stats import mean_ci

TRIAL_DEFAULTS = dict(rho=1.0, theta=10, slowdown=None, timeout=None, threads=0,
                      feedback=False, control_noise=0.0, synchronous=False)


def trial_key(p: dict) -> str:
    """File-name key of a trial: everything that changes its outcome."""
    parts = [p["task"], p["method"], f"rho{p['rho']:g}", f"theta{p['theta']}",
             f"slow{p['slowdown']:g}", f"Y{p['timeout']}", f"seed{p['seed']}"]
    if p.get("feedback"):
        parts.append("fb")
    if p.get("control_noise"):
        parts.append(f"noise{p['control_noise']:g}")
    return "-".join(parts)


def run_trial(params: dict) -> dict:
    """Run one MPC episode; see TRIAL_DEFAULTS for the optional parameters."""
    import torch

    from dopt import RolloutConfig, RolloutService, Scene
    from dopt.mpc import MPC, MPCConfig, Plan, mpc_cost
    from dopt.tasks import get_task
    from dopt.tasks.push_costs import PushWeights, goal_distance, push_cost
    from planners.ilqr import ILQR
    from planners.svr import DofSelector, SelectionConfig, SVROptimiser

    p = {**TRIAL_DEFAULTS, **params}
    torch.set_num_threads(1)
    seed = int(p["seed"])
    tm = get_task(p["task"])(np.random.default_rng(seed))
    scene = Scene(tm.model)
    cost = push_cost(tm, scene)
    svc = RolloutService(scene, RolloutConfig(threads=int(p["threads"])))
    selector = DofSelector(scene.nv, tm.robot_dofs, cost.costed_dofs,
                           SelectionConfig(p["method"], rho=float(p["rho"]),
                                           theta=int(p["theta"])),
                           np.random.default_rng([seed, 1]))
    optimiser = SVROptimiser(ILQR(svc, cost), selector)
    distance = goal_distance(tm, scene)
    radius = PushWeights().success_radius
    config = MPCConfig(timeout=int(p["timeout"] or tm.timeout),
                       slowdown=float(p["slowdown"] or tm.slowdown),
                       synchronous=bool(p["synchronous"]), feedback=bool(p["feedback"]),
                       control_noise=float(p["control_noise"]))
    mpc = MPC(scene, optimiser, config, np.random.default_rng([seed, 2]),
              success=lambda x: distance(x) < radius)
    res = mpc.run(tm.initial_state, Plan(np.zeros((tm.horizon, scene.nu))))
    return {
        "mpc_cost": mpc_cost(cost, res),
        "success": bool(res.success),
        "steps": int(len(res.controls)),
        "goal_distance_start": distance(tm.initial_state),
        "goal_distance_end": distance(res.states[-1]),
        "opt_ms_mean": 1e3 * float(np.mean(res.opt_seconds)),
        "dofs_mean": float(np.mean(res.n_dofs)),
        "n_optimisations": len(res.opt_seconds),
        "lag_steps_mean": float(np.mean(res.lag_steps)),
        "late_steps": int(res.late_steps),
        "opt_ms": [1e3 * s for s in res.opt_seconds],
        "n_dofs": res.n_dofs,
        "opt_step": res.opt_step,
        "active_dofs": res.dofs,
        "slowdown": config.slowdown,
        "timeout": config.timeout,
    }


#: a goal object that ends farther than this from the goal (m) was knocked over and rolled away;
#: the paper removes such outliers from its clutter means, and so do we (they are counted)
OUTLIER_DISTANCE = 0.5


def row_label(p: dict) -> str:
    """Table row of a trial: its method, ' +fb' when it executed the K feedback term."""
    return p["method"] + (" +fb" if p.get("feedback") else "")


def aggregate(records: list[dict], baseline: str = "baseline", level: float = 0.90) -> dict:
    """Per row (``row_label``): MPC cost normalised by the ``baseline`` row's on the same task
    instance (seed), mean and CI half-width at ``level`` over the trials that are not outliers,
    and the median over all; optimisation time, DoFs, success rate, trial and outlier counts.

    records: {"params", "result"} of finished trials of one task.
    """
    by = {}
    for r in records:
        by.setdefault(row_label(r["params"]), {})[
            (r["params"]["seed"], r["params"]["rho"], r["params"]["theta"])] = r["result"]

    def outlier(v):
        return v["goal_distance_end"] > OUTLIER_DISTANCE

    base = {k[0]: v["mpc_cost"] for k, v in by.get(baseline, {}).items() if not outlier(v)}
    out = {}
    for method, trials in by.items():
        res = list(trials.values())
        paired = {k: v for k, v in trials.items() if k[0] in base}
        norm_all = [v["mpc_cost"] / base[k[0]] for k, v in paired.items()]
        norm = [v["mpc_cost"] / base[k[0]] for k, v in paired.items() if not outlier(v)]
        mean, ci = mean_ci(norm, level) if norm else (float("nan"), float("nan"))
        out[method] = {
            "mpc_cost_normalised_mean": mean,
            "mpc_cost_normalised_ci90": ci,
            "mpc_cost_normalised_median": float(np.median(norm_all)) if norm_all else None,
            "opt_ms_mean": float(np.mean([v["opt_ms_mean"] for v in res])),
            "dofs_mean": float(np.mean([v["dofs_mean"] for v in res])),
            "success_rate": float(np.mean([v["success"] for v in res])),
            "goal_distance_end_median": float(np.median([v["goal_distance_end"] for v in res])),
            "lag_steps_mean": float(np.mean([v["lag_steps_mean"] for v in res])),
            "outliers": int(sum(outlier(v) for v in res)),
            "trials": len(res),
        }
    return out


def feedback_effect(records: list[dict], level: float = 0.90) -> dict:
    """Per method with both variants: MPC cost with feedback over open loop on the same seed.

    Returns {method: {"ratio_geomean", "ratio_ci90": [lo, hi], "better", "pairs",
    "success_open_loop", "success_feedback"}}: the geometric mean of the paired ratios with a
    t-interval on their logs (cost ratios are skewed), and how many pairs feedback won.
    """
    by = {}
    for r in records:
        p = r["params"]
        by.setdefault(p["method"], {}).setdefault(p["seed"], {})[bool(p.get("feedback"))] = \
            r["result"]
    out = {}
    for method, seeds in by.items():
        pairs = [v for v in seeds.values() if len(v) == 2]
        if not pairs:
            continue
        logs = [np.log(v[True]["mpc_cost"] / v[False]["mpc_cost"]) for v in pairs]
        mean, ci = mean_ci(logs, level)
        out[method] = {
            "ratio_geomean": float(np.exp(mean)),
            "ratio_ci90": [float(np.exp(mean - ci)), float(np.exp(mean + ci))],
            "better": int(sum(x < 0 for x in logs)), "pairs": len(pairs),
            "success_open_loop": int(sum(v[False]["success"] for v in pairs)),
            "success_feedback": int(sum(v[True]["success"] for v in pairs)),
        }
    return out
