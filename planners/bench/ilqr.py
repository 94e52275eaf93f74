"""Bench of one iLQR(-SVR) iteration per DoF-selection method on a pushing task."""

from __future__ import annotations

import time

import numpy as np
import torch

from dopt.tasks import get_task
from planners.svr import SelectionConfig, paper_theta
from planners.svr_mpc import build_controller


def bench_ilqr(task: str, methods: list[str], rho: float, theta: int | None, iterations: int,
               warmup: int, threads: int, seed: int) -> list[dict]:
    """Mean wall time of an iteration per method, from the same state and warm controls.

    Each method first runs ``warmup`` iterations (SVR settles its DoF set there), then
    ``iterations`` timed ones; ``vs_baseline`` is its time over baseline's, same run.
    theta None: the paper's Table 1 value per method (planners.svr.paper_theta).
    """
    torch.set_num_threads(1)
    tm = get_task(task)(np.random.default_rng(seed))
    x0 = tm.initial_state
    U0 = np.zeros((tm.horizon, tm.model.nu))
    out = []
    for method in methods:
        th = paper_theta(method) if theta is None else theta
        ctl = build_controller(tm, SelectionConfig(method, rho=rho, theta=th),
                               np.random.default_rng(seed), threads)
        svc, ilqr, sel = ctl.service, ctl.ilqr, ctl.selector
        U, walls, splits, sizes = U0, [], [], []
        for i in range(warmup + iterations):
            C = sel.before()
            t0 = time.perf_counter()
            step = ilqr.iterate(x0, U, C)
            wall = time.perf_counter() - t0
            sel.after(step.K, step.dofs)
            U = step.controls
            if i >= warmup:
                walls.append(wall)
                splits.append(step.seconds)
                sizes.append(len(C))
        split = {k: 1e3 * float(np.mean([s[k] for s in splits])) for k in splits[0]}
        ms = 1e3 * float(np.mean(walls))
        split["other"] = ms - sum(split.values())
        out.append({"bench": "ilqr", "task": task, "method": method, "ms_per_iteration": ms,
                    "n_dofs": float(np.mean(sizes)), "split_ms": split, "threads": svc.threads,
                    "route": "c-kernels" if svc.uses_c_kernels else "batch",
                    "rho": rho, "theta": th, "final_cost": step.cost_after})
        svc.close()
    base = next((r["ms_per_iteration"] for r in out if r["method"] == "baseline"), None)
    for r in out:
        r["vs_baseline"] = None if base is None else r["ms_per_iteration"] / base
    return out
