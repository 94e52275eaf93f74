"""The pick-and-place planners, one interface (``PickPlanner``), built by name with
``make_planner`` (the paper's Sec. IV-C.2 methods, ``METHODS``):

    simple    CEM over the key particles of each stage's goal (CEM(Simple))
    original  CEM over all particles (CEM(Original))
    random    CEM over a random subset as large as the key set (CEM(Random))
    scripted  pick each key particle, move it above its goal, release

A planner plans one stage from the current state and returns a ``StagePlan``.

Shapes: N particles, K key particles, C candidates, H actions per plan, ns state row.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Protocol

import numpy as np
import torch

from dopt.tasks import PickPlaceTask
from planners.cem import CEM, CEMConfig, CEMProgress
from planners.pick_place.settings import PickPlaceSettings, check_seed, check_settings
from planners.scripted import ScriptedConfig, scripted

#: planner names (the paper's methods), in the order of its figures
METHODS = ("simple", "original", "random", "scripted")
LABELS = {"simple": "CEM(Simple)", "original": "CEM(Original)", "random": "CEM(Random)",
          "scripted": "Scripted"}
#: the CEM methods' candidate sets (``CEMPlanner.CANDIDATES``)
CEM_CANDIDATES = {"simple": "keys", "original": "all", "random": "random"}


@dataclass(frozen=True)
class StagePlan:
    """A planner's answer for one stage: the actions particles (H,) / displacements (H, 3),
    the state (ns,) after executing them, its cost (m), the best cost after each iteration
    (one entry for the scripted policy), the candidates planned over, the seconds of
    each CEM iteration (empty for the scripted policy), the rollouts simulated while planning,
    how many of them the stability verdict flagged and how many broke the stretch limit of
    C(a_t), whether the executed plan was unstable (with the reason), the blow-up
    captures of it (``run_problem``'s ``blowup_out``; folders relative to it), and the steps
    the sampled rollouts simulated against those of a full settle each
    (``PickPlaceSettings.rest_speed``; equal without it)."""

    particles: np.ndarray
    displacements: np.ndarray
    final_state: np.ndarray
    cost: float
    cost_history: list
    n_candidates: int
    seconds_per_iteration: list = field(default_factory=list)
    n_rollouts: int = 0
    n_unstable_rollouts: int = 0
    unstable: bool = False
    unstable_reason: str = ""
    n_infeasible_rollouts: int = 0
    blowups: list = field(default_factory=list)
    n_steps: int = 0
    n_full_steps: int = 0

    def to_dict(self) -> dict:
        """JSON-able form (arrays as lists; float64 round-trips exactly)."""
        d = asdict(self)
        for name in ("particles", "displacements", "final_state"):
            d[name] = np.asarray(d[name]).tolist()
        return d

    @classmethod
    def from_dict(cls, d: dict) -> StagePlan:
        d = dict(d)
        d["particles"] = np.asarray(d["particles"], dtype=int)
        for name in ("displacements", "final_state"):
            d[name] = np.asarray(d[name], dtype=float)
        return cls(**d)


class PickPlanner(Protocol):
    """Plans one stage: ``plan(task, keys, on_iteration)``, where ``task`` holds the start
    state and the stage's goal and ``keys`` (K,) are its key particles.

    A planner that can be stopped and resumed (``run_problem``'s ``checkpoint``) also has
    ``rng_state()`` / ``set_rng_state(state)`` (its random generators' state, JSON-able)
    and takes ``resume`` (a progress dict it gave ``on_progress``) and ``on_progress``
    (called with a JSON-able dict after each step of its planning) in ``plan``."""

    def plan(self, task: PickPlaceTask, keys: np.ndarray,
             on_iteration: Callable[[int, float], None] | None = None) -> StagePlan: ...


class CEMPlanner:
    """CEM over a candidate set: the keys ("keys", CEM(Simple)), every particle ("all",
    CEM(Original)) or as many random particles as keys ("random", CEM(Random), sorted).

    Args:
        config: the CEM settings.
        candidates: "keys", "all" or "random".
        seed: seeds the torch generator of CEM and the numpy generator of random candidates.
    """

    CANDIDATES = ("keys", "all", "random")

    def __init__(self, config: CEMConfig, candidates: str, seed: int):
        if candidates not in self.CANDIDATES:
            raise ValueError(f"candidates must be one of {self.CANDIDATES}, got {candidates!r}")
        check_seed(seed)
        self.cem, self.candidates = CEM(config), candidates
        self.generator = torch.Generator().manual_seed(int(seed))
        self.rng = np.random.default_rng(int(seed))

    def candidate_particles(self, keys: np.ndarray, n_particles: int) -> np.ndarray:
        """(C,) particle indices CEM may pick for a stage with key particles ``keys`` (K,)."""
        keys = np.asarray(keys, dtype=int)
        if self.candidates == "keys":
            return keys
        if self.candidates == "all":
            return np.arange(n_particles)
        return np.sort(self.rng.choice(n_particles, size=len(keys), replace=False))

    def rng_state(self) -> dict:
        """The torch and numpy generators' state (JSON-able)."""
        return {"torch": self.generator.get_state().tolist(),
                "numpy": self.rng.bit_generator.state}

    def set_rng_state(self, state: dict) -> None:
        """Inverse of ``rng_state``."""
        self.generator.set_state(torch.tensor(state["torch"], dtype=torch.uint8))
        self.rng.bit_generator.state = state["numpy"]

    def plan(self, task, keys, on_iteration=None, *, resume: dict | None = None,
             on_progress: Callable[[dict], None] | None = None) -> StagePlan:
        """CEM over the candidates, then the best plan executed on the task's scene.
        ``resume``: a dict ``on_progress`` gave while planning this stage from the same rng
        state (candidates, CEM progress, the task's rollout counters), to go on from."""
        cand = self.candidate_particles(keys, task.n_particles)
        counters = ("n_evaluated", "n_unstable", "n_infeasible")
        steps = ("n_steps", "n_full_steps")        # absent from progress saved before them
        cem_resume = None
        if resume is not None:
            if np.asarray(resume["candidates"]).tolist() != cand.tolist():
                raise ValueError("the saved progress planned over other candidates than this "
                                 "planner draws: not a progress of this stage and seed")
            cem_resume = CEMProgress.from_dict(resume["cem"])
            for name in counters:
                setattr(task, name, int(resume["task"][name]))
            for name in steps:
                setattr(task, name, int(resume["task"].get(name, 0)))

        def progress(p: CEMProgress) -> None:
            on_progress({"candidates": cand.tolist(), "cem": p.to_dict(),
                         "task": {name: getattr(task, name) for name in counters + steps}})

        res = self.cem.plan(task, cand, self.generator, on_iteration, resume=cem_resume,
                            on_progress=progress if on_progress is not None else None)
        done = task.execute(res.particles, res.displacements)
        # the executed plan's cost, on the task's own scene (CEM may have planned on a cheaper
        # model; without one the two are the same rollout)
        return StagePlan(res.particles, res.displacements, done.state,
                         float(task.cost(done.state)),
                         res.cost_history.tolist(), len(cand),
                         res.seconds_per_iteration.tolist(), res.n_evaluated + 1,
                         res.n_nonfinite - task.n_infeasible + int(done.unstable),
                         done.unstable, done.reason, task.n_infeasible,
                         n_steps=task.n_steps, n_full_steps=task.n_full_steps)


class ScriptedPlanner:
    """The paper's scripted policy over the key particles (deterministic: no seed)."""

    def __init__(self, config: ScriptedConfig = ScriptedConfig()):
        if not isinstance(config, ScriptedConfig):
            raise TypeError(f"config must be a ScriptedConfig, got {type(config).__name__}")
        self.config = config

    def plan(self, task, keys, on_iteration=None) -> StagePlan:
        res = scripted(task, keys, self.config)
        return StagePlan(res.particles, res.displacements, res.final_state, float(res.cost),
                         [float(res.cost)], len(np.asarray(keys).reshape(-1)),
                         n_rollouts=len(res.particles), n_unstable_rollouts=int(res.unstable),
                         unstable=res.unstable, unstable_reason=res.reason)


#: planners beyond ``METHODS``, by name: ``(settings, seed) -> PickPlanner``
#: (``register_planner``; the drag encoding's, ``planners.pick_place.drag``, register there)
REGISTERED: dict[str, Callable[[PickPlaceSettings, int], PickPlanner]] = {}


def register_planner(name: str, factory: Callable[[PickPlaceSettings, int], PickPlanner],
                     label: str) -> None:
    """Make ``make_planner(name, ...)`` build ``factory(settings, seed)``; ``label`` names it
    in figures and tables (``LABELS``). ValueError for a name already taken."""
    if not isinstance(name, str) or not name or name in METHODS or name in REGISTERED:
        raise ValueError(f"planner name {name!r} is empty or already taken")
    REGISTERED[name] = factory
    LABELS[name] = label


def make_planner(method: str, settings: PickPlaceSettings, seed: int = 0) -> PickPlanner:
    """The planner of a method name (``METHODS``, or one of ``REGISTERED``, such as the drag
    encoding's, which need ``settings.drag``) with the settings' configs; ``seed`` an int
    >= 0."""
    if not isinstance(method, str) or method not in METHODS + tuple(REGISTERED):
        raise ValueError(f"unknown method {method!r}; choose from "
                         f"{', '.join(METHODS + tuple(REGISTERED))}")
    check_settings(settings)
    check_seed(seed)
    if method in REGISTERED:
        return REGISTERED[method](settings, seed)
    if method == "scripted":
        return ScriptedPlanner(settings.scripted)
    return CEMPlanner(settings.cem, CEM_CANDIDATES[method], seed)
