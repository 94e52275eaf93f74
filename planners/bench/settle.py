"""Bench of settling until at rest (``python -m planners.bench settle``): what a rest test
would cut from CEM's sampled rollouts, and what it changes in their costs.

Per cloth size n (particles per side), the paper protocol's diagonal-fold preset at that n,
its first stage built as a trial builds it (``make_problem``), and ``samples`` random action
sequences of the preset's horizon (particles uniform over the pickable ones, displacements
uniform in the bound box, from ``seed``): one plain rollout (every sample every step), then one
``rollout_until_rest`` per rest speed. A row per speed: the share of an action's steps that
are its settle (all a rest test can cut), the steps the rest test saved, its wall time against
the plain rollout's (same run), the cost change |cost(rest) - cost(plain)| (mm; median, 90th
percentile, max over the samples stable in both), whether the CEM elites (the preset's count of
lowest costs) are the same set, and the particles' root-mean-square speed when the plain
settle ends (percentiles: how far from rest the fixed settle leaves the cloth).
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from dopt.rollout import RolloutConfig, RolloutService
from dopt.tasks.pick.scene import PickPlaceTask
from dopt.tasks.pick.settle import RestTest, rollout_until_rest

#: rest speeds (m/s) the bench tries by default
SPEEDS = (0.002, 0.005, 0.01, 0.02)


def bench_settle(sizes: list[int], speeds=SPEEDS, samples: int = 32, threads: int = 0,
                 seed: int = 0, on_row=None) -> dict:
    """The rows of the module docstring, per size and speed; ``on_row(out)`` after each size."""
    from planners.pick_place.problem import make_problem
    from planners.pick_place.settings import PickPlaceSettings

    if not speeds or any(not s > 0 for s in speeds):
        raise ValueError(f"speeds must be rest speeds > 0 (m/s), got {list(speeds)}")
    base = PickPlaceSettings.preset("cloth", "diagonal", protocol="paper")
    rows = []
    out = {"bench": "settle", "task": "cloth", "goal": "diagonal", "protocol": "paper",
           "samples": samples, "threads": threads, "seed": seed, "rows": rows}
    for n in sizes:
        settings = replace(base, n=int(n), threads=threads)
        problem = make_problem(settings, seed)
        scene, stage = problem.scene, problem.stages[0]
        pk = scene.picker
        g = np.random.default_rng(seed)
        H = settings.cem.horizon
        idx = g.choice(pk.pickable, (samples, H))
        disp = g.uniform(-settings.bound, settings.bound, (samples, H, 3))
        with RolloutService(scene.scene, RolloutConfig(threads=threads)) as svc:
            task = PickPlaceTask(scene, stage.goal, problem.start_state, svc)
            t0 = time.perf_counter()
            plain = task.rollout(idx, disp)
            plain_s = time.perf_counter() - t0
            plain_cost = np.where(plain.stability.unstable, np.nan,
                                  task.cost(plain.final_states))
            v = plain.final_states[:, scene.scene.layout["qvel"]][:, scene.velocity_dofs]
            rms_end = np.sqrt((v ** 2).sum(-1).mean(-1))
            for speed in speeds:
                t0 = time.perf_counter()
                rested = rollout_until_rest(svc, pk, scene.velocity_dofs, problem.start_state,
                                            idx, disp, RestTest(speed=float(speed)))
                rest_s = time.perf_counter() - t0
                cost = np.where(rested.result.stability.unstable, np.nan,
                                task.cost(rested.result.final_states))
                rows.append({"n": int(n), "particles": scene.n_particles,
                             "physics": settings.physics, "H": H,
                             "K": pk.steps_per_action, "settle_steps": pk.settle_steps,
                             "dt": pk.dt,
                             "speed": float(speed), "samples": samples,
                             **_compare(plain_cost, cost, settings.cem.elites),
                             "settle_share": pk.settle_steps / pk.steps_per_action,
                             "steps_saved": 1 - rested.steps.sum() / (rested.full_steps
                                                                      * samples),
                             "wall_ratio": rest_s / plain_s, "plain_s": plain_s,
                             "rms_speed_at_settle_end": _percentiles(rms_end,
                                                                     ("p10", "p50", "p90"))})
        if on_row is not None:
            on_row(out)
    return out


def _compare(plain: np.ndarray, rest: np.ndarray, elites: int) -> dict:
    """Cost change (mm) over the samples stable in both, and whether the ``elites`` lowest
    costs are the same samples (unstable ones last)."""
    both = np.isfinite(plain) & np.isfinite(rest)
    change = 1e3 * np.abs(rest[both] - plain[both])
    order = (np.argsort(np.where(np.isfinite(c), c, np.inf), kind="stable")[:elites]
             for c in (plain, rest))
    same = set(next(order).tolist()) == set(next(order).tolist())
    return {"stable": int(both.sum()),
            "cost_change_mm": _percentiles(change, ("p50", "p90", "max")),
            "same_elites": bool(same)}


def _percentiles(x: np.ndarray, names: tuple) -> dict:
    """{"p50": ..., "max": ...} of ``x`` (None each when empty)."""
    q = [100.0 if name == "max" else float(name[1:]) for name in names]
    values = np.percentile(x, q).tolist() if len(x) else [None] * len(q)
    return dict(zip(names, values, strict=True))
