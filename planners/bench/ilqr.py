"""Bench of one iLQR(-SVR) iteration per DoF-selection method and derivative variant (finite
differences at every timestep, every K-th, or adaptive key points) on a pushing task."""

from __future__ import annotations

import time

import numpy as np
import torch

from dopt.tasks import get_task
from planners.ilqr import Derivatives, ILQRConfig
from planners.keypoints import KeypointConfig, interpolate, key_steps
from planners.svr import SelectionConfig, paper_theta
from planners.svr_mpc import build_controller


def bench_ilqr(task: str, methods: list[str], rho: float, theta: int | None, iterations: int,
               warmup: int, threads: int, seed: int, variants: tuple[str, ...] = ("every",),
               box_qp: bool = False) -> list[dict]:
    """Mean wall time of an iteration per method and derivative variant, from the same state
    and warm controls.

    Each (method, variant) first runs ``warmup`` iterations (SVR settles its DoF set there),
    then ``iterations`` timed ones; ``vs_baseline`` is its time over baseline's (every
    timestep), ``vs_every`` over the same method's with every timestep, same run. For key-point
    variants, ``fd_steps`` is the mean number of timesteps differenced and ``interp_error`` the
    relative Frobenius error of the interpolated [A B] against finite differences at every
    timestep on the last nominal, mean over t (``interp_error_median``: its median over t; the
    two differ where a few timesteps in contact, whose A and B change from one step to the
    next, carry the whole error). theta None: the paper's Table 1 value per
    method (planners.svr.paper_theta).
    """
    torch.set_num_threads(1)
    tm = get_task(task)(np.random.default_rng(seed))
    x0 = tm.initial_state
    U0 = np.zeros((tm.horizon, tm.model.nu))
    out = []
    for method in methods:
        for variant in variants:
            kp = KeypointConfig.parse(variant)
            how = Derivatives(keypoints=kp.method, fd_skip=kp.skip, box_qp=box_qp)
            out.append(_one(tm, x0, U0, method, rho, theta, how, iterations, warmup, threads,
                            seed))
    base = next((r["ms_per_iteration"] for r in out
                 if r["method"] == "baseline" and r["keypoints"] == "every"), None)
    every = {r["method"]: r["ms_per_iteration"] for r in out if r["keypoints"] == "every"}
    for r in out:
        r["vs_baseline"] = None if base is None else r["ms_per_iteration"] / base
        r["vs_every"] = (r["ms_per_iteration"] / every[r["method"]] if r["method"] in every
                         else None)
    return out


def _one(tm, x0, U0, method, rho, theta, how, iterations, warmup, threads, seed) -> dict:
    th = paper_theta(method) if theta is None else theta
    ctl = build_controller(tm, SelectionConfig(method, rho=rho, theta=th),
                           np.random.default_rng(seed), threads,
                           ILQRConfig(derivatives=how))
    keypoints = how.keypoint_config
    svc, ilqr, sel = ctl.service, ctl.ilqr, ctl.selector
    U, walls, splits, sizes, fd_steps = U0, [], [], [], []
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
            fd_steps.append(step.fd_steps)
    split = {k: 1e3 * float(np.mean([s[k] for s in splits])) for k in splits[0]}
    ms = 1e3 * float(np.mean(walls))
    split["other"] = ms - sum(split.values())
    error = error_median = None
    if keypoints.method != "every":
        X, C = step.states, step.dofs
        full = torch.from_numpy(svc.derivatives(X[:-1], C).F)
        keys = key_steps(keypoints, ilqr.service.scene, X, C)
        approx = interpolate(torch.from_numpy(svc.derivatives(X[keys], C).F), keys, len(full))
        norms = torch.linalg.matrix_norm(full).clamp_min(1e-300)
        per_step = torch.linalg.matrix_norm(approx - full) / norms
        error, error_median = float(per_step.mean()), float(per_step.median())
    row = {"bench": "ilqr", "task": tm.name, "method": method, "keypoints": keypoints.name,
           "box_qp": how.box_qp, "ms_per_iteration": ms, "n_dofs": float(np.mean(sizes)),
           "split_ms": split, "derivative_share": split["derivatives"] / ms,
           "fd_steps": float(np.mean(fd_steps)), "horizon": tm.horizon,
           "interp_error": error, "interp_error_median": error_median, "threads": svc.threads,
           "route": "c-kernels" if svc.uses_c_kernels else "batch", "rho": rho, "theta": th,
           "final_cost": step.cost_after}
    svc.close()
    return row
