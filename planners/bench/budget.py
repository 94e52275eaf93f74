"""Bench of the cloth rollouts' budget: the same CEM samples simulated with the fixed move and
with moves sized per sample (``PickerConfig.move``), paired (``python -m planners.bench
cloth-budget``).

Per fold (the paper protocol's diagonal and side folds, ``PickPlaceSettings.preset("cloth",
fold, protocol="paper")`` at ``n`` particles per side): a CEM(Simple) plan of ``iterations``
iterations runs on the fixed move, on one simulation thread (how a sweep's trial runs today),
and every population it samples is recorded with its costs and the CPU and wall time of its
``PickPlaceTask.evaluate``; then each recorded population is evaluated again with sized moves,
on ``threads`` threads (0: every core, how a single trial runs now). The samples are those of
a real plan (its first iterations: the widest distribution, so the longest moves), and the
costs are paired per sample:

- ``steps_ratio``: steps simulated, sized over fixed (``PickPlaceTask.n_steps``);
- ``cpu_ratio``: the process's CPU seconds over the evaluations (every thread), new over old;
- ``wall_ratio``: their wall seconds, new (sized, all cores) over old (fixed, one thread);
- ``cost_delta_median_mm``, ``cost_delta_p90_mm``: the median and 90th percentile of the
  per-sample cost difference, new minus old (mm; the samples both rules keep stable), and
  ``cost_abs_delta_p90_mm`` of its magnitude (a large negative difference is no equality);
- ``control``: the same differences for the fixed move one step longer (``one_step_longer``)
  against the old: the smallest change of the schedule, so the floor below which no change
  of the move's timing can bring a sample's cost (a sheet dragged over the floor amplifies a
  step's difference in where it lands);
- ``fig7_panel_h``: the projected wall hours of one Fig. 7 panel of this fold (``FIG7_METHODS``
  x ``PROTOCOL_SEEDS["paper"]`` trials; the scripted policy's few steps and the executed plans
  left out) on this machine's cores, old and new: the CEM trials' sampled sequences (methods x
  seeds x stages x the protocol's iterations x population) at the per-sample CPU seconds
  measured here, over the cores (a sweep keeps every core busy either way). CEM(Original)'s
  and CEM(Random)'s samples are taken to cost what CEM(Simple)'s do.

Timings on a loaded machine mean little; the steps and the costs do not depend on it. The
projection is at the benched ``n``. ``quick`` shrinks everything to a smoke run (``QUICK``).
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np
import torch

from dopt.rollout import RolloutConfig, RolloutService, available_cores
from dopt.tasks.pick.scene import PickPlaceTask
from planners.cem import CEM
from planners.pick_place import METHODS, PROTOCOL_SEEDS, make_problem
from planners.pick_place.settings import PickPlaceSettings

#: the folds benched by default (the single-layer Fig. 7 folds)
FOLDS = ("diagonal", "side")
#: the methods of one Fig. 7 panel, and those among them that sample with CEM
FIG7_METHODS = METHODS
CEM_METHODS = tuple(m for m in METHODS if m != "scripted")
#: the smoke run: an 8 x 8 cloth, one iteration of 4 samples per fold
QUICK = {"n": 8, "iterations": 1, "population": 4}


class _Recorder:
    """A ``PickPlaceTask`` for CEM that keeps every population it is asked to evaluate
    ((P, H) particles, (P, H, 3) displacements) with its costs (P,) and the CPU and wall
    seconds of each evaluation."""

    def __init__(self, task: PickPlaceTask):
        self.task = task
        self.bound, self.n_particles = task.bound, task.n_particles
        self.populations: list[tuple[np.ndarray, np.ndarray]] = []
        self.costs: list[np.ndarray] = []
        self.cpu_s = self.wall_s = 0.0

    def evaluate(self, particles: torch.Tensor, displacements: torch.Tensor) -> torch.Tensor:
        self.populations.append((particles.numpy().copy(), displacements.numpy().copy()))
        costs, cpu, wall = timed_costs(self.task, *self.populations[-1])
        self.costs.append(costs)
        self.cpu_s += cpu
        self.wall_s += wall
        return torch.from_numpy(costs)


def timed_costs(task: PickPlaceTask, particles: np.ndarray, displacements: np.ndarray
                ) -> tuple[np.ndarray, float, float]:
    """``task.evaluate`` of (P, H), (P, H, 3): the costs (P,) (+inf where unstable or
    infeasible), the process's CPU seconds (every thread) and the wall seconds it took."""
    cpu, wall = time.process_time(), time.perf_counter()
    costs = np.asarray(task.evaluate(particles, displacements), dtype=float)
    return costs, time.process_time() - cpu, time.perf_counter() - wall


def fold_settings(fold: str, n: int, iterations: int, population: int | None
                  ) -> PickPlaceSettings:
    """The paper protocol's settings of ``fold`` at ``n``, with ``iterations`` CEM iterations
    and ``population`` (None: the protocol's; the elites shrink with it)."""
    s = PickPlaceSettings.preset("cloth", fold, protocol="paper")
    P = s.cem.population if population is None else int(population)
    cem = replace(s.cem, iterations=int(iterations), population=P,
                  elites=max(1, min(s.cem.elites, P // 2)))
    return replace(s, n=int(n), cem=cem)


def _task(settings: PickPlaceSettings, seed: int, stack, **changes) -> tuple:
    """The first stage's task of ``settings`` with ``changes`` (its service on the settings'
    threads, closed by ``stack``), its key particles and the problem's number of stages."""
    s = replace(settings, **changes)
    problem = make_problem(s, seed)
    stage = problem.stages[0]
    svc = stack.enter_context(RolloutService(problem.scene.scene,
                                             RolloutConfig(threads=s.threads)))
    return (PickPlaceTask(problem.scene, stage.goal, problem.start_state, svc), stage.keys,
            len(problem.stages))


def one_step_longer(task: PickPlaceTask) -> float:
    """The picker speed (m/s) whose fixed move takes one step more than ``task``'s: the
    control pairing's, the smallest change of the schedule."""
    pk = task.picker
    return float(np.linalg.norm(pk.bound)) / ((pk.move_steps + 0.5) * pk.dt)


def _replayed(task: PickPlaceTask, populations: list) -> tuple[np.ndarray, float, float]:
    """``populations`` [((P, H), (P, H, 3))] evaluated on ``task``: the costs (S,), the CPU
    and the wall seconds in all."""
    out = [timed_costs(task, *pop) for pop in populations]
    return (np.concatenate([c for c, _, _ in out]), sum(c for _, c, _ in out),
            sum(w for _, _, w in out))


def bench_fold(fold: str, n: int, iterations: int, population: int | None, seed: int,
               threads: int) -> dict:
    """One fold's row (module docstring): the plan on the fixed move (one thread), its
    populations again with sized moves (``threads``) and with the fixed move one step longer
    (the control), the ratios, the paired cost differences and the samples' moves."""
    from contextlib import ExitStack

    settings = fold_settings(fold, n, iterations, population)
    with ExitStack() as stack:
        old, keys, stages = _task(settings, seed, stack, threads=1)
        new = _task(settings, seed, stack, picker_move="sized", threads=threads)[0]
        control = _task(settings, seed, stack, threads=1,
                        picker_speed=one_step_longer(old))[0]
        recorder = _Recorder(old)
        CEM(settings.cem).plan(recorder, keys, torch.Generator().manual_seed(seed))
        after, cpu, wall = _replayed(new, recorder.populations)
        near = _replayed(control, recorder.populations)[0]
    before = np.concatenate(recorder.costs)
    disp = np.concatenate([d for _, d in recorder.populations])             # (S, H, 3)
    moved = np.concatenate([p for p, _ in recorder.populations]) >= 0
    return {"fold": fold, "n": int(n), "samples": int(len(before)),
            "iterations": int(iterations), "population": settings.cem.population,
            "horizon": settings.cem.horizon, "threads_old": 1,
            "threads_new": new.service.threads,
            "steps_old": int(old.n_steps), "steps_new": int(new.n_steps),
            "cpu_old_s": recorder.cpu_s, "cpu_new_s": cpu,
            "wall_old_s": recorder.wall_s, "wall_new_s": wall,
            "steps_ratio": new.n_steps / old.n_steps, "cpu_ratio": cpu / recorder.cpu_s,
            "wall_ratio": wall / recorder.wall_s,
            "move_mean_m": float(np.linalg.norm(disp, axis=-1)[moved].mean())
            if moved.any() else 0.0,
            **cost_deltas(before, after),
            "control": cost_deltas(before, near),
            "fig7_panel_h": panel_hours(stages, recorder.cpu_s / len(before),
                                        cpu / len(before))}


def cost_deltas(before: np.ndarray, after: np.ndarray) -> dict:
    """The paired cost differences (S,) -> (S,) m, after minus before, in mm over the samples
    both keep finite: median, 90th percentile, 90th percentile of the magnitude, largest
    magnitude; and the samples each left non-finite (unstable or infeasible)."""
    both = np.isfinite(before) & np.isfinite(after)
    d = 1e3 * (after[both] - before[both])
    stat = (lambda f: float(f(d))) if len(d) else (lambda f: None)
    return {"cost_delta_median_mm": stat(np.median),
            "cost_delta_p90_mm": stat(lambda x: np.percentile(x, 90)),
            "cost_abs_delta_p90_mm": stat(lambda x: np.percentile(np.abs(x), 90)),
            "cost_abs_delta_max_mm": stat(lambda x: np.abs(x).max()),
            "paired": int(both.sum()), "nonfinite_old": int((~np.isfinite(before)).sum()),
            "nonfinite_new": int((~np.isfinite(after)).sum())}


def panel_hours(stages: int, old_s: float, new_s: float) -> dict:
    """One Fig. 7 panel of a fold of ``stages`` stages (module docstring) at ``old_s`` and
    ``new_s`` CPU seconds per sampled sequence: {"old", "new"} wall hours on this machine's
    cores, and the count of sequences and the cores they are over."""
    cem = PickPlaceSettings.preset("cloth", FOLDS[0], protocol="paper").cem
    sequences = (len(CEM_METHODS) * PROTOCOL_SEEDS["paper"] * stages * cem.iterations
                 * cem.population)
    cores = available_cores()
    return {"old": sequences * old_s / cores / 3600, "new": sequences * new_s / cores / 3600,
            "sequences": sequences, "cores": cores,
            "trials": len(FIG7_METHODS) * PROTOCOL_SEEDS["paper"]}


def bench_cloth_budget(n: int = 20, folds=FOLDS, iterations: int = 3,
                       population: int | None = None, seed: int = 0, threads: int = 0,
                       quick: bool = False, on_fold=None) -> dict:
    """Every fold's row (``bench_fold``) and the ratios over all of them (summed steps, CPU
    and wall); ``quick``: ``QUICK``'s sizes instead of n, iterations and population.
    ``on_fold(out)`` is called with the result so far after each fold."""
    if quick:
        n, iterations, population = QUICK["n"], QUICK["iterations"], QUICK["population"]
    rows = {}
    out = {"bench": "cloth-budget", "task": "cloth", "protocol": "paper", "n": int(n),
           "iterations": int(iterations), "seed": int(seed), "threads": int(threads),
           "quick": bool(quick), "cores": available_cores(), "folds": rows}
    for fold in folds:
        rows[fold] = bench_fold(fold, n, iterations, population, seed, threads)
        total = {k: sum(r[k] for r in rows.values())
                 for k in ("steps_old", "steps_new", "cpu_old_s", "cpu_new_s", "wall_old_s",
                           "wall_new_s")}
        out.update(steps_ratio=total["steps_new"] / total["steps_old"],
                   cpu_ratio=total["cpu_new_s"] / total["cpu_old_s"],
                   wall_ratio=total["wall_new_s"] / total["wall_old_s"])
        if on_fold is not None:
            on_fold(out)
    return out
