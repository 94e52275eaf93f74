"""The key-particle authors' action encoding as a planner option: CEM(Original), CEM(Simple)
and CEM(Random) over T short drags (``DRAG_METHODS``; ``make_planner`` builds them from
``PickPlaceSettings.drag``, a ``DragSettings``).

The encoding (``softgym/action_space/action_space.py`` ``reset_action_space``,
``Picker.step``; ``cem/cem.py``): a plan is T decisions of four numbers u in [-1, 1] (the
softagent environment's normalised action box): three moves, u * ``step`` per substep, and a
pick scalar a = (u + 1) / 2 in [0, 1] mapped onto the C candidates by ``pick_index`` (the
authors' ``interp1d`` over C + 2 nodes: C + 1 bins of width 1 / (C + 1), the last None). The
pick is re-drawn at every decision, so to carry one point across decisions CEM must keep its
Gaussian inside one bin: the handicap of a large candidate set that grows with C.

Candidates are virtual points on the physics mesh (``dopt.tasks.pick.drag``): CEM(Original)
the N points of a sqrt(N) x sqrt(N) grid over the sheet (``grid_points``; N is
``DragSettings.n_points``, independent of the mesh), CEM(Simple) the stage's key particles,
CEM(Random) as many grid points as keys, drawn by the seed. CEM is the authors' plain one
(``planners.gaussian_cem``): one diagonal Gaussian over the T x 4 numbers, 10 % elites.

A drag trial's recorded actions are (T,) candidate indices (-1: None) and (T, 3) moves per
substep (m), not the macro encoding's particles and displacements.

Shapes: P population, T decisions, C candidates, N grid points, V mesh vertices.
"""

from __future__ import annotations

import logging

import numpy as np
import torch

from dopt.tasks import PickPlaceTask
from dopt.tasks.pick.drag import DragConfig, DragResult, DragSimulator, VirtualPoints
from dopt.tasks.pick.picker import NONE
from dopt.tasks.pick.scene import mean_distance
from planners.gaussian_cem import GaussianCEM, GaussianCEMConfig
from planners.pick_place.drag_settings import DragSettings
from planners.pick_place.planners import StagePlan, register_planner

log = logging.getLogger(__name__)

#: the drag encoding's methods and their candidate sets
DRAG_METHODS = {"simple-drag": "keys", "original-drag": "all", "random-drag": "random"}


def pick_index(a, n_candidates: int) -> np.ndarray:
    """The candidate a pick scalar selects, as the authors' ``Picker.step``: (...) in [0, 1]
    -> (...) int64 in 0 .. C-1, or ``NONE`` (-1).

    ``interp1d(linspace(0, 1, C + 2), linspace(0, C + 1, C + 2))(a)``, floored; an index of C
    or more is None. The interpolation is scipy's own arithmetic (the bracketing nodes by
    ``searchsorted`` on the left, then slope times offset plus the lower node's value), so a
    scalar on a bin's edge falls where theirs does.

    Raises:
        ValueError: a scalar outside [0, 1] or NaN (interp1d's bounds error), C < 1.
    """
    if not isinstance(n_candidates, (int, np.integer)) or n_candidates < 1:
        raise ValueError(f"n_candidates must be an int >= 1, got {n_candidates!r}")
    a = np.asarray(a, dtype=float)
    if not np.all((a >= 0) & (a <= 1)):
        raise ValueError("pick scalars must lie in [0, 1] (the authors' interp1d range)")
    c = int(n_candidates)
    x = np.linspace(0.0, 1.0, c + 2)
    y = np.linspace(0.0, c + 1.0, c + 2)
    hi = np.clip(np.searchsorted(x, a), 1, c + 1)
    lo = hi - 1
    slope = (y[hi] - y[lo]) / (x[hi] - x[lo])
    idx = np.floor(slope * (a - x[lo]) + y[lo]).astype(np.int64)
    return np.where(idx >= c, NONE, idx)


def decode(samples, n_candidates: int, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Samples (P, T * 4) in [-1, 1] -> candidate picks (P, T) (``pick_index``, NONE = -1) and
    moves per substep (P, T, 3) m, denormalised as softagent's ``NormalizedEnv``
    (low + (u + 1) / 2 * (high - low), clipped to the box)."""
    u = np.asarray(samples, dtype=float)
    u = u.reshape(u.shape[0], -1, 4)
    moves = np.clip(-step + (u[..., :3] + 1.0) * 0.5 * (2 * step), -step, step)
    a = np.clip((u[..., 3] + 1.0) * 0.5, 0.0, 1.0)
    return pick_index(a, n_candidates), moves


def grid_points(rest: np.ndarray, m: int) -> np.ndarray:
    """(m * m, 3) the points of an m x m grid over the bounding box of the flat sheet ``rest``
    (V, 3) at its height, point ix * m + iy at (x_ix, y_iy) (the cloth's numbering); its
    corners are the sheet's."""
    rest = np.asarray(rest, dtype=float)
    lo, hi = rest[:, :2].min(0), rest[:, :2].max(0)
    xs, ys = np.linspace(lo[0], hi[0], m), np.linspace(lo[1], hi[1], m)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    return np.stack([gx.ravel(), gy.ravel(), np.full(m * m, rest[:, 2].mean())], axis=1)


class DragTask:
    """Costs of drag plans on a stage: a ``PickPlaceTask``'s scene, start and goal, the
    candidate points (C,) and the drag settings. ``evaluate`` (P, T * 4) -> (P,) torch costs:
    Eq. 2 after the plan and the settle, or its lowest value over the decisions
    (``DragSettings.best_over_trajectory``); an unstable rollout costs +inf."""

    def __init__(self, task: PickPlaceTask, points: VirtualPoints, drag: DragSettings):
        self.task, self.points, self.drag = task, points, drag
        self.sim = DragSimulator(task.scene, DragConfig(step=drag.step, repeat=drag.repeat,
                                                        substeps=drag.substeps,
                                                        settle=task.picker.config.settle))
        self.n_evaluated = self.n_unstable = self.n_steps = 0

    def rollout(self, samples) -> tuple[DragResult, np.ndarray, np.ndarray]:
        """The drag rollouts of samples (P, T * 4): result, Eq. 2 at each decision's end
        (P, T), Eq. 2 after the settle (P,)."""
        picks, moves = decode(samples, len(self.points), self.drag.step)
        res = self.sim.run(self.task.start_state, self.points, picks, moves)
        scene, goal = self.task.scene, self.task.goal
        per_decision = mean_distance(scene.positions(res.decision_states), goal)
        final = mean_distance(scene.positions(res.final_states), goal)
        self.n_steps += picks.shape[0] * (picks.shape[1] * self.sim.decision_steps
                                          + self.sim.settle_steps)
        return res, per_decision, final

    def evaluate(self, samples: torch.Tensor) -> torch.Tensor:
        res, per_decision, final = self.rollout(samples.numpy())
        cost = per_decision.min(axis=1) if self.drag.best_over_trajectory else final
        unstable = res.stability.unstable
        self.n_evaluated += len(cost)
        self.n_unstable += int(unstable.sum())
        return torch.from_numpy(np.where(unstable, np.inf, cost))

    def execute(self, best: np.ndarray) -> tuple[DragResult, np.ndarray, int]:
        """The best sample (T * 4,) executed: with best_over_trajectory only up to its best
        decision (the authors stop there), then released and settled. Returns the result of
        one rollout, its decoded picks and moves as (T', 4) rows, and T'."""
        res, per_decision, _ = self.rollout(best[None])
        rows = np.asarray(best, dtype=float).reshape(-1, 4)
        if self.drag.best_over_trajectory:
            rows = rows[:int(np.argmin(per_decision[0])) + 1]
            res, _, _ = self.rollout(rows.reshape(1, -1))
        return res, rows, len(rows)


class DragPlanner:
    """CEM over drag plans (module docstring) for one candidate set: "keys", "all" or
    "random"; ``seed`` seeds the torch generator of CEM and the numpy one of random
    candidates."""

    def __init__(self, drag: DragSettings, candidates: str, seed: int):
        if not isinstance(drag, DragSettings):
            raise TypeError(f"drag must be DragSettings, got {type(drag).__name__}")
        if candidates not in DRAG_METHODS.values():
            raise ValueError(f"candidates must be one of {sorted(set(DRAG_METHODS.values()))},"
                             f" got {candidates!r}")
        self.drag, self.candidates = drag, candidates
        self.cem = GaussianCEM(GaussianCEMConfig(population=drag.population,
                                                 elites=drag.elites,
                                                 iterations=drag.iterations))
        self.generator = torch.Generator().manual_seed(int(seed))
        self.rng = np.random.default_rng(int(seed))

    def candidate_points(self, task: PickPlaceTask, keys) -> VirtualPoints:
        """The C candidate points of a stage with key particles ``keys`` (K,), on the flat
        sheet of ``task``'s scene (its initial state)."""
        scene = task.scene
        rest = scene.positions(scene.initial_state)
        keys = np.asarray(keys, dtype=int).reshape(-1)
        if self.candidates == "keys":
            pts = rest[keys]
        else:
            grid = grid_points(rest, round(self.drag.n_points ** 0.5))
            pts = grid if self.candidates == "all" else grid[np.sort(
                self.rng.choice(len(grid), size=len(keys), replace=False))]
        return VirtualPoints(rest, scene.elements, pts)

    def plan(self, task: PickPlaceTask, keys, on_iteration=None) -> StagePlan:
        """CEM over drag plans, then the best executed on the task's scene."""
        points = self.candidate_points(task, keys)
        dtask = DragTask(task, points, self.drag)
        D = 4 * self.drag.horizon
        res = self.cem.plan(dtask.evaluate, -np.ones(D), np.ones(D), self.generator,
                            on_iteration)
        done, rows, _ = dtask.execute(res.best)
        picks, moves = decode(rows.reshape(1, -1), len(points), self.drag.step)
        state = done.final_states[0]
        st = done.stability
        log.info("drag plan over %d candidates: planned %.1f mm, executed %.1f mm",
                 len(points), res.cost * 1e3, float(task.cost(state)) * 1e3)
        return StagePlan(picks[0], moves[0], state, float(task.cost(state)),
                         res.cost_history.tolist(), len(points),
                         res.seconds_per_iteration.tolist(), res.n_evaluated + 1,
                         res.n_nonfinite + int(st.unstable[0]), bool(st.unstable[0]),
                         st.reason[0], n_steps=dtask.n_steps, n_full_steps=dtask.n_steps)


def speed_check(task: PickPlaceTask, drag: DragSettings, substeps, samples: int,
                generator: torch.Generator) -> dict:
    """Whether the sheet tolerates the drag speed: ``samples`` plans from the authors' first
    CEM distribution (``GaussianCEMConfig.init_std`` about the box's centre, clipped) over
    CEM(Original)'s grid, simulated from ``task``'s start at each substep count in
    ``substeps``. Returns {str(k): {"speed_m_per_s" (the fastest substep's per axis),
    "n_unstable", "reasons", "max_strain" (p50, p90, max), "max_speed" (p50, max)}}."""
    planner = DragPlanner(drag, "all", 0)
    points = planner.candidate_points(task, [])
    D = 4 * drag.horizon
    x = torch.randn((samples, D), generator=generator, dtype=torch.float64)
    x = (x * GaussianCEMConfig().init_std * 2).clamp(-1.0, 1.0).numpy()
    out = {}
    for k in substeps:
        dtask = DragTask(task, points, DragSettings(**{**drag.to_dict(), "substeps": int(k)}))
        st = dtask.rollout(x)[0].stability
        out[str(int(k))] = {
            "speed_m_per_s": drag.step / (int(k) * float(task.scene.model.opt.timestep)),
            "n_unstable": st.n_unstable, "reasons": sorted(set(r for r in st.reason if r)),
            "max_strain": [float(np.percentile(st.max_strain, q)) for q in (50, 90, 100)],
            "max_speed": [float(np.percentile(st.max_speed, q)) for q in (50, 100)]}
    return out


def _drag_planner(candidates: str):
    def build(settings, seed: int) -> DragPlanner:
        if settings.drag is None:
            raise ValueError(f"the {candidates!r} drag planner plans in the drag encoding: "
                             f"settings.drag must be DragSettings, not None")
        return DragPlanner(settings.drag, candidates, seed)
    return build


for _name, _label in (("simple-drag", "CEM(Simple), drags"),
                      ("original-drag", "CEM(Original), drags"),
                      ("random-drag", "CEM(Random), drags")):
    register_planner(_name, _drag_planner(DRAG_METHODS[_name]), _label)
