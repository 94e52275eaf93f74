"""Bench of the model clock: the CPU time of one MPC optimisation against its DoF count |C|,
per pushing task, and the least-squares fit ms = a + b |C| that ``planners.svr_mpc``'s
``CLOCK_MODEL_MS`` holds.

Each point is one optimisation of ``planners.svr.SVROptimiser`` with ``rand`` at theta
random DoFs besides the robot (so |C| = 7 + theta exactly) under the paper's protocol (Eq. 2
cost, from the authors' set-up state and push plan), on one simulation thread; its duration is
the process CPU time over the nominal thread count (the virtual clock's definition).
"""

from __future__ import annotations

import time

import numpy as np
import torch

from dopt.lab.provenance import provenance
from dopt.mpc import Plan
from dopt.tasks import get_task
from dopt.tasks.push import warm_start
from dopt.tasks.push.costs import COST_PRESETS
from planners.svr import SelectionConfig
from planners.svr_mpc import build_controller


def bench_clock(tasks: list[str], sizes: int, iterations: int, warmup: int,
                nominal_threads: float, seed: int) -> dict:
    """``sizes`` DoF counts from the robot's 7 to nv per task; per count the mean CPU time of
    ``iterations`` optimisations after ``warmup``; the fit per task."""
    torch.set_num_threads(1)
    rows, fits = [], {}
    for name in tasks:
        tm = get_task(name)(np.random.default_rng(seed))
        start = warm_start.setup(tm).final_state
        plan = Plan(warm_start.push(tm, start, tm.horizon).controls)
        nv = tm.model.nv
        thetas = np.unique(np.linspace(0, nv - 7, sizes).round().astype(int))
        points = []
        for theta in thetas:
            ctl = build_controller(tm, SelectionConfig("rand", theta=int(theta)),
                                   np.random.default_rng(seed), threads=1,
                                   weights=COST_PRESETS["paper"])
            p, cpu = plan, []
            for i in range(warmup + iterations):
                c0 = time.process_time()
                p = ctl.optimiser.optimise(start, p)
                if i >= warmup:
                    cpu.append(time.process_time() - c0)
            ctl.service.close()
            ms = 1e3 * float(np.mean(cpu)) / nominal_threads
            points.append((7 + int(theta), ms))
            rows.append({"task": name, "n_dofs": 7 + int(theta), "ms": ms,
                         "cpu_ms": [1e3 * c for c in cpu]})
        c, ms = np.array(points, dtype=float).T
        b, a = np.polyfit(c, ms, 1)
        resid = ms - (a + b * c)
        fits[name] = {"a_ms": float(a), "b_ms": float(b),
                      "r2": float(1 - resid @ resid / ((ms - ms.mean()) @ (ms - ms.mean())))}
    return {"experiment": "clock_model", "nominal_threads": nominal_threads,
            "iterations": iterations, "rows": rows, "fits": fits, "provenance": provenance()}
