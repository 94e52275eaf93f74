"""Bench of one CEM iteration on the cloth or rope pick-and-place task.

An iteration samples P action sequences, encodes them into control rows, runs them as one
batched rollout of H*K steps each, computes Eq. 2 and refits. Its physical limit is the pure
``mj_step`` cost of those P*H*K steps divided by the threads, measured in the same run by
stepping the same sampled sequences in a plain single-threaded Python loop.
"""

from __future__ import annotations

import time

import mujoco
import numpy as np
import torch

from dopt.bench.timing import best_wall
from dopt.rollout import RolloutConfig, RolloutService
from dopt.tasks.pick.picker import CONTROL_SPEC, PickerConfig
from dopt.tasks.pick.scene import PickPlaceTask
from planners.cem import CEM, CEMConfig
from planners.pick_place import GOALS, PRESETS, pick_task


def _cloth_goal(n: int, radius: float):
    """The diagonal fold and the sheet's four corners."""
    from deformables.goals import cloth_diagonal

    goal = cloth_diagonal(n=n).positions + np.array([0.0, 0.0, radius])
    N = n * n
    return goal, [0, n - 1, N - n, N - 1]


def _rope_goal(n: int, radius: float):
    """The crossed triangle and four particles a third of the rope apart."""
    from deformables.goals import rope_crossed_triangle

    return rope_crossed_triangle(n).positions, [0, n // 3, 2 * n // 3, n - 1]


#: task -> (n, scene radius) -> the goal (N, 3) one iteration is timed on and its candidates
BENCH_GOALS = {"cloth": _cloth_goal, "rope": _rope_goal}


def bench_cem(task: str, n: int | None, P: int, H: int, bound: float | None, threads: int,
              repeats: int, seed: int) -> dict:
    """Seconds per CEM iteration against P*H*K mj_step / threads, same run; n and bound
    default to the preset of the task's first goal (cloth 12 and 0.3 m, rope 40 and 0.1 m)."""
    if task not in BENCH_GOALS:
        raise ValueError(f"unknown task {task!r}; the cem bench knows "
                         f"{' and '.join(BENCH_GOALS)}")
    pick_spec, preset = pick_task(task), PRESETS[task, GOALS[task][0]]
    n, bound = n or preset.n, bound or preset.bound
    scene = pick_spec.build(pick_spec.config(n=n), PickerConfig(bound=(bound,) * 3))
    goal, cand = BENCH_GOALS[task](n, scene.radius)
    svc = RolloutService(scene.scene, RolloutConfig(threads=threads))
    pick = PickPlaceTask(scene, goal, rollout=svc)
    cem = CEM(CEMConfig(population=P, elites=max(1, P // 5), iterations=1, horizon=H,
                        init_std=1.0))
    wall = best_wall(lambda: cem.plan(pick, cand, torch.Generator().manual_seed(seed)),
                     repeats)

    # the same population, stepped one sequence after another on one thread
    bound_t = torch.as_tensor(pick.bound, dtype=torch.float64)
    samples = cem.sample(cem.initial(len(cand), bound_t), torch.tensor(cand), bound_t,
                         torch.Generator().manual_seed(seed))
    U = scene.picker.encode(samples.particles.numpy(), samples.displacements.numpy())
    m, data = scene.model, mujoco.MjData(scene.model)
    spec = scene.scene.layout.spec

    def loop():
        for rows in U:
            mujoco.mj_setState(m, data, scene.initial_state, spec)
            for row in rows:
                mujoco.mj_setState(m, data, row, CONTROL_SPEC)
                mujoco.mj_step(m, data)

    t0 = time.perf_counter()
    loop()
    step = (time.perf_counter() - t0) / U.shape[0] / U.shape[1]
    steps = U.shape[0] * U.shape[1]
    limit = steps * step / svc.threads
    return {"bench": "cem", "task": task, "n": n, "P": P, "H": H,
            "K": scene.picker.steps_per_action, "steps": steps, "nv": scene.scene.nv,
            "threads": svc.threads, "s_per_iteration": wall, "mj_step_us": step * 1e6,
            "limit_s": limit, "limit_ratio": wall / limit}
