"""Benches of the rollout service: batched rollouts and reduced FD derivatives."""

from __future__ import annotations

import numpy as np

from dopt.bench.timing import best_wall, mj_step_seconds
from dopt.rollout import FDConfig, RolloutConfig, RolloutService
from dopt.scene import Scene


def _scene_and_state(task: str, seed: int):
    from dopt.tasks import get_task
    tm = get_task(task)(np.random.default_rng(seed))
    return Scene(tm.model), tm, np.asarray(tm.initial_state, dtype=float)


def _controls(scene: Scene, rng: np.random.Generator, shape) -> np.ndarray:
    """Random controls within ctrlrange (a tenth of it), shape (..., nu)."""
    lo, hi = scene.model.actuator_ctrlrange.T
    return rng.uniform(0.1 * lo, 0.1 * hi, tuple(shape) + (scene.nu,))


def bench_rollout(task: str, P: int, T: int, threads: int, repeats: int, seed: int) -> dict:
    """P open-loop rollouts of T steps in one call, against P*T mj_step / threads."""
    scene, _, x0 = _scene_and_state(task, seed)
    rng = np.random.default_rng(seed)
    u = _controls(scene, rng, (P, T))
    svc = RolloutService(scene, RolloutConfig(threads=threads))
    wall = best_wall(lambda: svc.rollout(x0, u), repeats)
    step = mj_step_seconds(scene.model, x0, u[: min(P, 8)], repeats)
    limit = P * T * step / svc.threads
    return {"bench": "rollout", "task": task, "P": P, "T": T, "nv": scene.nv,
            "threads": svc.threads, "wall_s": wall, "mj_step_us": step * 1e6,
            "limit_s": limit, "limit_ratio": wall / limit}


def active_set(scene: Scene, tm, n_objects: int) -> np.ndarray:
    """The robot plus 6 * n_objects DoFs next to the goal: |C| = 7 + 6 * n_objects.

    Clutter: the goal cylinder and its nearest neighbours (all 6 DoFs each, as the paper's
    |C| = 19 example); soft tasks: the first 6 * n_objects DoFs of the soft body's vertices."""
    if tm.soft_body is None:
        groups = ["robot", f"object:{tm.goal_object}"]
        others = [f"object:{n}" for n in tm.distractors][: max(0, n_objects - 1)]
        return scene.dofs(*groups, *others)
    soft = scene.dofs(f"flex:{tm.soft_body}")[: 6 * n_objects]
    return np.union1d(scene.dofs("robot"), soft)


def bench_derivatives(task: str, n_objects: int, T: int, threads: int, repeats: int,
                      centered: bool, seed: int) -> dict:
    """Reduced-set FD over a horizon vs the physical limit, vs the full set and vs the Batch
    route (a full mj_step per perturbation), same run. The C loops skip the stages a control
    or velocity nudge leaves unchanged, so their limit_ratio can drop below 1."""
    scene, tm, x0 = _scene_and_state(task, seed)
    rng = np.random.default_rng(seed)
    u = _controls(scene, rng, (T,))
    svc = RolloutService(scene, RolloutConfig(threads=threads))
    states = svc.trajectory(x0, u).states[:-1]
    fd = FDConfig(eps=1e-6, centered=centered)
    C = active_set(scene, tm, n_objects)
    sides = 2 if centered else 1

    def steps(c):  # mj_step equivalents per horizon: nominal + ctrl + vel + pos perturbations
        return T * (1 + sides * (scene.nu + 2 * c))

    batch = RolloutService(scene, RolloutConfig(threads=threads, c_kernels=False))
    wall = best_wall(lambda: svc.derivatives(states, C, fd), repeats)
    full = best_wall(lambda: svc.derivatives(states, None, fd), repeats)
    batch_wall = best_wall(lambda: batch.derivatives(states, C, fd), repeats)
    step = mj_step_seconds(scene.model, x0, u, repeats)
    limit = steps(len(C)) * step / svc.threads
    full_limit = steps(scene.nv) * step / svc.threads
    return {"bench": "derivatives", "task": task, "T": T, "nv": scene.nv, "n_dofs": len(C),
            "centered": centered, "threads": svc.threads,
            "route": "c-kernels" if svc.uses_c_kernels else "batch", "wall_s": wall,
            "full_wall_s": full, "mj_step_us": step * 1e6, "mj_steps": steps(len(C)),
            "limit_s": limit, "limit_ratio": wall / limit,
            "full_limit_ratio": full / full_limit, "vs_full": wall / full,
            "batch_wall_s": batch_wall, "vs_batch": wall / batch_wall}
