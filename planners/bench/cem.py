"""Bench of CEM iterations on the pick-and-place tasks against their physical limit.

An iteration samples P action sequences, encodes them into control rows, runs them as one
batched rollout of H*K steps each, computes Eq. 2 and refits. Its physical limit is the pure
``mj_step`` cost of those P*H*K steps over the cores the rollout runs on; ``step_seconds``
measures one ``mj_step`` of the same scene in the same run, on one core (a plain loop on one
``MjData`` from a mid-action state, each step's CPU time taken, the median kept: a loaded
machine preempts a step of milliseconds, which its wall time would count).

``time_iterations`` runs a plan of a few iterations through the real path (``CEM.plan``,
``PickPlaceTask.evaluate``, the ``RolloutService``) under ``cProfile`` and splits each
iteration's time into ``PIECES``: the batched simulation itself, the service's array building,
the control rows' encoding, the stability verdict, the cost, CEM's sampling and refit (torch)
and the rest (Python glue). The profiler adds about a microsecond per Python call, a few
thousand calls an iteration, against iterations of seconds; the library holds no timing code.
The records the stability verdict reads are copied inside the batched call, so they count as
simulation.

- ``bench_cem`` (``python -m planners.bench cem``): a toy budget on the cloth or rope;
- ``bench_cem_limit`` (``python -m planners.bench cem-limit``): the paper protocol's cloth
  diagonal fold per cloth size, each size's iteration against its limit and where the rest
  goes.
"""

from __future__ import annotations

import cProfile
import pstats
import time
from dataclasses import replace

import mujoco
import mujoco.batch
import numpy as np
import torch

from dopt.rollout import RolloutConfig, RolloutService, available_cores
from dopt.rollout_batch import BatchRoute, why_unstable
from dopt.stability import Monitor, Scan
from dopt.state import faulty_rows
from dopt.tasks.pick.constraints import ActionConstraint
from dopt.tasks.pick.picker import CONTROL_SPEC, NONE, Picker, PickerConfig
from dopt.tasks.pick.scene import PickPlaceTask
from planners.cem import CEM, CEMConfig
from planners.pick_place import GOALS, PRESETS, pick_task

#: where an iteration's time goes: piece -> the functions whose time (cProfile's cumulative
#: time, a call from one of them to another counted once) it is. "service" and "python" are
#: what is left: the service's own time (checking the inputs, building the state and record
#: arrays, chunking) is ``RolloutService.rollout`` less "simulate" and "stability"; "python"
#: is the iteration (``CEM._iterate``) less every other piece.
PIECES = {
    "simulate": (mujoco.batch.Batch.rollout,),
    "stability": (Monitor.start, Scan.update, Scan.flag, Scan.result, faulty_rows,
                  why_unstable, BatchRoute._replay),
    "encode": (Picker.encode,),
    "cost": (PickPlaceTask.cost, ActionConstraint.stretched),
    "cem": (CEM.sample, CEM.refit),
}
#: the pieces of the breakdown, in the order the table prints them
SHARES = ("simulate", "service", "stability", "encode", "cost", "cem", "python")
#: mj_step calls ``step_seconds`` times by default
STEP_SAMPLES = 2000


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


# ------------------------------------------------------------------------ the measurements
def step_seconds(task: PickPlaceTask, controls: np.ndarray, start: int,
                 samples: int = STEP_SAMPLES) -> dict:
    """One ``mj_step`` of the task's scene on one core: a plain loop on one ``MjData``.

    Steps ``controls`` (T, ncontrol) of ``CONTROL_SPEC`` from the task's start state up to
    step ``start`` (untimed), then, from the state there, the rest of them, again and again
    from that state until ``samples`` steps were timed, each step on its own: the thread's
    CPU time (what the step costs a core, also on a loaded machine, where a step of
    milliseconds is often preempted) and the wall time.

    Returns {"median_s", "mean_s", "wall_median_s", "samples"}: seconds of one step (CPU
    time, but the wall median).
    """
    m = task.scene.model
    spec = task.scene.scene.layout.spec
    data = mujoco.MjData(m)
    mujoco.mj_setState(m, data, task.start_state, spec)
    for row in controls[:start]:
        mujoco.mj_setState(m, data, row, CONTROL_SPEC)
        mujoco.mj_step(m, data)
    mid = np.empty(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(m, data, mid, spec)
    rest = controls[start:]
    if not len(rest):
        raise ValueError(f"no steps after step {start} of {len(controls)} controls to time")
    cpu, wall = [], []
    cpu_clock, wall_clock = time.thread_time, time.perf_counter
    while len(cpu) < samples:
        mujoco.mj_setState(m, data, mid, spec)
        for row in rest[:samples - len(cpu)]:
            mujoco.mj_setState(m, data, row, CONTROL_SPEC)
            w0, c0 = wall_clock(), cpu_clock()
            mujoco.mj_step(m, data)
            c1, w1 = cpu_clock(), wall_clock()
            cpu.append(c1 - c0)
            wall.append(w1 - w0)
    return {"median_s": float(np.median(cpu)), "mean_s": float(np.mean(cpu)),
            "wall_median_s": float(np.median(wall)), "samples": len(cpu)}


def _label(fn) -> tuple:
    """cProfile's key of a Python function."""
    code = fn.__code__
    return code.co_filename, code.co_firstlineno, code.co_name


def _seconds(stats: dict, functions) -> float:
    """Seconds spent inside ``functions`` (a call from one of them to another counted once)."""
    keys = {_label(f) for f in functions}
    total = 0.0
    for key in keys & stats.keys():
        _, _, _, cumulative, callers = stats[key]
        outside = [v[3] for caller, v in callers.items() if caller not in keys]
        total += sum(outside) if callers else cumulative
    return total


def breakdown(stats: dict) -> dict:
    """Seconds of each of ``SHARES`` and of the whole (``CEM._iterate``), summed over the
    iterations of one profile's ``pstats.Stats.stats``."""
    total = _seconds(stats, [CEM._iterate])
    out = {name: _seconds(stats, fns) for name, fns in PIECES.items()}
    out["service"] = (_seconds(stats, [RolloutService.rollout]) - out["simulate"]
                      - out["stability"])
    out["python"] = total - sum(out.values())
    return {"iteration": total, **{name: out[name] for name in SHARES}}


def _cores(threads: int, population: int) -> int:
    """The cores a batched rollout of ``population`` on ``threads`` threads runs on: no more
    than the threads, the rollouts or the cores this process may use."""
    return max(1, min(threads, population, available_cores()))


def time_iterations(task: PickPlaceTask, candidates, config: CEMConfig, seed: int,
                    step_samples: int = STEP_SAMPLES) -> dict:
    """``config.iterations`` CEM iterations of ``task`` over ``candidates`` (a plan from the
    seed), each against the physical limit, and where their time goes.

    Before the plan the rollout service is warmed (its batch of P simulations allocated, one
    step each); after it, ``step_seconds`` times one ``mj_step`` from the middle of the first
    sampled sequence that moves something (step snap + hold + move / 2 of its first action),
    on the scene the population is simulated on (the task's planning scene, when it has one).

    Returns a row: the budget (P, H, K and its phases, the steps an iteration simulates, the
    threads and the cores they run on), ``mj_step_ms`` (the median CPU time of one step;
    ``mj_step_mean_ms`` the mean, ``mj_step_wall_ms`` the median wall time, beside),
    ``limit_s`` = steps x step / cores, ``iteration_s`` (mean over the iterations;
    ``iterations_s`` each), ``ratio`` = iteration / limit, ``simulate_ratio`` = the batched
    simulation alone against the limit, ``cpu_s`` the process's CPU time per iteration (every
    thread) and ``cpu_ratio`` = it / (steps x step), the work an iteration does against the
    steps' own (what a loaded machine's wall ratio hides), ``seconds`` per iteration and
    ``shares`` of the iteration for each of ``SHARES`` (they sum to one), the unstable
    samples and the calls the profiler saw per iteration.
    """
    sim = task.planning or task
    cem = CEM(config)
    P, H, K = config.population, config.horizon, sim.picker.steps_per_action
    gen = torch.Generator().manual_seed(seed)
    bound = torch.as_tensor(task.bound, dtype=torch.float64)
    cand = torch.from_numpy(np.array(candidates, dtype=np.int64))
    first = cem.sample(cem.initial(len(cand), bound), cand, bound, gen)
    U = sim.picker.encode(first.particles.numpy(), first.displacements.numpy())
    sim.service.rollout(sim.start_state, U[:, :1], control_spec=CONTROL_SPEC)    # warm-up

    profile = cProfile.Profile()
    cpu = time.process_time()
    profile.enable()
    try:
        result = cem.plan(task, candidates, torch.Generator().manual_seed(seed))
    finally:
        profile.disable()
    cpu = time.process_time() - cpu
    stats = pstats.Stats(profile).stats
    parts = breakdown(stats)

    moves = np.flatnonzero(first.particles[:, 0].numpy() != NONE)
    p = int(moves[0]) if len(moves) else 0
    pk = sim.picker
    step = step_seconds(sim, U[p], pk.snap_steps + pk.hold_steps + pk.move_steps // 2,
                        step_samples)

    n_iter = config.iterations
    steps = P * H * K
    threads = sim.service.threads
    cores = _cores(threads, P)
    limit = steps * step["median_s"] / cores
    iteration = float(np.mean(result.seconds_per_iteration))
    total = parts.pop("iteration")
    return {"P": P, "H": H, "K": K,
            "phases": {"snap": pk.snap_steps, "hold": pk.hold_steps, "move": pk.move_steps,
                       "settle": pk.settle_steps},
            "candidates": len(cand), "nv": sim.scene.scene.nv, "steps": steps,
            "threads": threads, "cores": cores,
            "mj_step_ms": 1e3 * step["median_s"], "mj_step_mean_ms": 1e3 * step["mean_s"],
            "mj_step_wall_ms": 1e3 * step["wall_median_s"],
            "step_samples": step["samples"], "limit_s": limit,
            "iterations": n_iter, "iteration_s": iteration,
            "iterations_s": [float(s) for s in result.seconds_per_iteration],
            "ratio": iteration / limit, "simulate_ratio": parts["simulate"] / n_iter / limit,
            "cpu_s": cpu / n_iter, "cpu_ratio": cpu / n_iter / (limit * cores),
            "seconds": {k: v / n_iter for k, v in parts.items()},
            "shares": {k: v / total for k, v in parts.items()},
            "unstable": int(result.n_nonfinite),
            "profiled_calls": sum(s[1] for s in stats.values()) / n_iter}


# ---------------------------------------------------------------------------- the benches
def bench_cem(task: str, n: int | None, P: int, H: int, bound: float | None, threads: int,
              repeats: int, seed: int) -> dict:
    """Seconds per CEM iteration (the best of ``repeats`` iterations of one plan) against
    P*H*K mj_step / cores, same run; n and bound default to the preset of the task's first
    goal (cloth 12 and 0.3 m, rope 40 and 0.1 m)."""
    if task not in BENCH_GOALS:
        raise ValueError(f"unknown task {task!r}; the cem bench knows "
                         f"{' and '.join(BENCH_GOALS)}")
    pick_spec, preset = pick_task(task), PRESETS[task, GOALS[task][0]]
    n, bound = n or preset.n, bound or preset.bound
    scene = pick_spec.build(pick_spec.config(n=n), PickerConfig(bound=(bound,) * 3))
    goal, cand = BENCH_GOALS[task](n, scene.radius)
    with RolloutService(scene.scene, RolloutConfig(threads=threads)) as svc:
        row = time_iterations(PickPlaceTask(scene, goal, rollout=svc), cand,
                              CEMConfig(population=P, elites=max(1, P // 5),
                                        iterations=repeats, horizon=H, init_std=1.0), seed)
    wall = min(row["iterations_s"])
    return {"bench": "cem", "task": task, "n": n, "P": P, "H": H, "K": row["K"],
            "steps": row["steps"], "nv": row["nv"], "threads": row["threads"],
            "cores": row["cores"], "s_per_iteration": wall,
            "mj_step_us": 1e3 * row["mj_step_ms"], "limit_s": row["limit_s"],
            "limit_ratio": wall / row["limit_s"], "shares": row["shares"]}


def bench_cem_limit(sizes: list[int], threads: int = 0, iterations: int = 2, seed: int = 0,
                    candidates: str = "keys", step_samples: int = STEP_SAMPLES,
                    on_row=None) -> dict:
    """Per cloth size n (particles per side): the paper protocol's CEM preset of the diagonal
    fold (``PickPlaceSettings.preset("cloth", "diagonal", protocol="paper")``) at that n,
    ``iterations`` iterations of its first stage's plan over the key particles
    (``candidates="keys"``, CEM(Simple)) or every particle ("all", CEM(Original)), built by
    ``make_problem`` as a trial builds it; each a row of ``time_iterations`` with ``n``, the
    particles and the physics preset. ``on_row(out)`` is called with the result so far after
    each size."""
    from planners.pick_place.problem import make_problem
    from planners.pick_place.settings import PickPlaceSettings

    if candidates not in ("keys", "all"):
        raise ValueError(f"candidates must be 'keys' or 'all', got {candidates!r}")
    base = PickPlaceSettings.preset("cloth", "diagonal", protocol="paper")
    rows = []
    out = {"bench": "cem-limit", "task": "cloth", "goal": "diagonal", "protocol": "paper",
           "candidates": candidates, "iterations": iterations, "threads": threads,
           "seed": seed, "rows": rows}
    for n in sizes:
        settings = replace(base, n=int(n), threads=threads)
        problem = make_problem(settings, seed)
        stage = problem.stages[0]
        cand = (stage.keys if candidates == "keys"
                else np.arange(problem.scene.n_particles))
        config = replace(settings.cem, iterations=iterations)
        with RolloutService(problem.scene.scene, RolloutConfig(threads=threads)) as svc:
            plan_svc = (None if problem.planning_scene is None
                        else RolloutService(problem.planning_scene.scene,
                                            RolloutConfig(threads=threads)))
            try:
                task = PickPlaceTask(problem.scene, stage.goal, problem.start_state, svc,
                                     problem.planning_scene, plan_svc)
                row = time_iterations(task, cand, config, seed, step_samples)
            finally:
                if plan_svc is not None:
                    plan_svc.close()
        rows.append({"n": int(n), "particles": problem.scene.n_particles,
                     "physics": settings.planning_physics or settings.physics,
                     "stage": stage.name, **row})
        if on_row is not None:
            on_row(out)
    return out


def limit_table(rows: list[dict], header: bool = True) -> str:
    """The rows of ``bench_cem_limit`` as a text table, one line per size, in fixed-width
    columns (so that rows printed one at a time line up under the header)."""
    head = ["n", "steps/it", "ms/step", "cores", "limit_s", "iter_s", "ratio", "sim/limit",
            "cpu/steps", *SHARES]
    lines = [[str(r["n"]), str(r["steps"]), f"{r['mj_step_ms']:.3f}", str(r["cores"]),
              f"{r['limit_s']:.2f}", f"{r['iteration_s']:.2f}", f"{r['ratio']:.2f}",
              f"{r['simulate_ratio']:.2f}", f"{r['cpu_ratio']:.2f}",
              *(f"{100 * r['shares'][k]:.1f}%" for k in SHARES)] for r in rows]
    widths = [max(len(h), 9) for h in head]
    return "\n".join("  ".join(c.rjust(w) for c, w in zip(line, widths, strict=True))
                     for line in ([head] if header else []) + lines)
