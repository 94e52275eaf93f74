"""Torch-batched cross-entropy method (CEM) over sequences of pick-and-place actions.

An action is ``(i, dx, dy, dz)``: pick particle i, move it by a displacement bounded per axis,
release; or None (particle index ``NONE = -1``). A plan is a sequence of H actions. CEM keeps,
for every action slot h,

- a categorical distribution over the C candidate particles plus None, and
- a Gaussian over the displacement for each candidate (mean and std per axis, clipped to the
  bound when sampled),

samples a population of P sequences, asks the task for their costs, and refits both to the
E elite sequences, blending with the previous distribution by ``smoothing``. A sample whose
cost is NaN or inf (a simulation gone unstable) scores +inf: it is never an elite nor the
best, and a population without one finite cost is an error, not a plan. A candidate's
Gaussian moves towards its elites' mean and std by the share of elites that chose it (all E:
a plain smoothed refit; one: a small step, since one sample tells nothing of a spread).

The planner knows nothing of ropes or cloth: it talks to a ``PickTask`` (anything with
``bound`` and ``evaluate``; ``dopt.tasks.pick.scene.PickPlaceTask`` is one), and every
random draw goes through the caller's ``torch.Generator``.

Shapes: P population, E elites, H horizon (actions per sequence), C candidates (+1: None).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Protocol

import numpy as np
import torch

from dopt.validation import check_config
from planners._checks import particle_indices, picker_bound

log = logging.getLogger(__name__)

#: particle index of the None action
NONE = -1


class PickTask(Protocol):
    """What CEM needs from a task."""

    bound: np.ndarray
    """(3,) largest |displacement| per axis (m)."""

    def evaluate(self, particles: torch.Tensor, displacements: torch.Tensor) -> torch.Tensor:
        """Costs of P action sequences: (P, H) int64 particles (NONE = -1), (P, H, 3) float64
        displacements -> (P,) float64 costs (lower is better)."""


@dataclass(frozen=True)
class CEMConfig:
    """CEM settings. The defaults are what the experiments run; the paper gives its iteration
    count (30, ``planners.pick_place.presets.PAPER_CHANGES``) and no population, elites or
    distribution parameters.

    Attributes:
        population: P, CEM's sequences sampled per iteration.
        elites: E, the sequences the distribution is refitted to.
        iterations: CEM iterations (refits of the distribution); a pick-and-place goal's per
            stage.
        horizon: H, actions per sequence (a plan).
        smoothing: weight of the previous distribution in each refit (0: plain refit).
        init_std: initial displacement std, as a fraction of the bound (1: the whole bound,
            so the first population spans the workspace).
        min_std: floor of the displacement std, as a fraction of the bound.
        prob_floor: floor of every categorical probability after a refit, as a fraction of the
            uniform probability 1 / (C + 1), so that it means the same for 4 candidates and for
            144 (keeps exploring; 0: none). 0.25 is a safeguard against the categorical
            collapsing on a wrong key early (docs/DESIGN-NOTES.md).
        keep_best: put the best sequence found so far back into every population.
    """

    population: int = field(default=32, metadata={"at_least": 1})
    elites: int = field(default=6, metadata={"at_least": 1})
    iterations: int = field(default=15, metadata={"at_least": 1})
    horizon: int = field(default=3, metadata={"at_least": 1})
    smoothing: float = 0.3
    init_std: float = 1.0
    min_std: float = 0.05
    prob_floor: float = 0.25
    keep_best: bool = True

    def __post_init__(self):
        # types: ints (not bools), finite numbers, keep_best a bool; the fields' bounds
        # (their metadata) (TypeError / ValueError)
        check_config(self)
        if not self.elites <= self.population:
            raise ValueError(f"need 1 <= elites <= population, got elites={self.elites}, "
                             f"population={self.population}")
        if not 0.0 <= self.smoothing < 1.0:
            raise ValueError(f"smoothing must be in [0, 1), got {self.smoothing}")
        if not (self.init_std > 0 and 0 <= self.min_std <= self.init_std):
            raise ValueError(f"need init_std > 0 and 0 <= min_std <= init_std, got "
                             f"{self.init_std}, {self.min_std}")
        if not 0.0 <= self.prob_floor < 1.0:
            raise ValueError(f"prob_floor must be in [0, 1), got {self.prob_floor}")


@dataclass
class Distribution:
    """The sampling distribution over action sequences.

    Attributes:
        probs: (H, C+1) categorical over the candidates, the last column None.
        mean, std: (H, C+1, 3) displacement Gaussian per slot and candidate (m).
    """

    probs: torch.Tensor
    mean: torch.Tensor
    std: torch.Tensor


@dataclass(frozen=True)
class Samples:
    """A population: choice (P, H) index into the candidates (C = None), particles (P, H)
    particle indices (NONE = -1), displacements (P, H, 3) in metres."""

    choice: torch.Tensor
    particles: torch.Tensor
    displacements: torch.Tensor


@dataclass(frozen=True)
class CEMResult:
    """Outcome of ``CEM.plan``.

    Attributes:
        particles: (H,) the best sequence's particles (NONE = -1 for None).
        displacements: (H, 3) its displacements (m).
        cost: its cost.
        cost_history: (iterations,) best cost found up to each iteration.
        elite_history: (iterations,) mean elite cost of each iteration.
        seconds_per_iteration: (iterations,) wall time of each iteration.
        candidates: (C,) the candidate particles planned over.
        n_evaluated: samples evaluated (iterations x population).
        n_nonfinite: samples whose cost was NaN or inf and scored +inf (a ``PickPlaceTask``
            gives +inf to every rollout its stability verdict flags).
    """

    particles: np.ndarray
    displacements: np.ndarray
    cost: float
    cost_history: np.ndarray
    elite_history: np.ndarray
    seconds_per_iteration: np.ndarray
    candidates: np.ndarray
    n_evaluated: int = 0
    n_nonfinite: int = 0


@dataclass
class CEMProgress:
    """Where ``CEM.plan`` stands after ``iteration`` iterations: all it needs to go on exactly
    as if it had not stopped (``CEM.plan(..., resume=progress)``).

    Attributes:
        iteration: iterations done.
        dist: the sampling distribution after them.
        best: (choice (H,), particles (H,), displacements (H, 3)) of the best sample so far.
        best_cost: its cost.
        cost_history, elite_history, seconds: one entry per iteration done (``CEMResult``).
        n_nonfinite: samples so far whose cost was not finite.
        generator_state: the torch generator's state after the last iteration done (uint8).
    """

    iteration: int
    dist: Distribution
    best: tuple
    best_cost: float
    cost_history: list
    elite_history: list
    seconds: list
    n_nonfinite: int
    generator_state: torch.Tensor

    def to_dict(self) -> dict:
        """JSON-able form: tensors as nested lists (float64 lists round-trip exactly)."""
        return {"iteration": self.iteration,
                "dist": {k: getattr(self.dist, k).tolist() for k in ("probs", "mean", "std")},
                "best": [t.tolist() for t in self.best], "best_cost": self.best_cost,
                "cost_history": list(self.cost_history),
                "elite_history": list(self.elite_history), "seconds": list(self.seconds),
                "n_nonfinite": self.n_nonfinite,
                "generator_state": self.generator_state.tolist()}

    @classmethod
    def from_dict(cls, d: dict) -> CEMProgress:
        """Inverse of ``to_dict``, checked (a checkpoint file may hold anything): shapes that
        fit one another, probabilities that are finite, >= 0 and sum to 1 per action, finite
        means, finite stds >= 0, finite costs and histories as long as the iteration count,
        and a generator state of a torch CPU generator's exact size in bytes.

        Raises:
            ValueError: a dict that is not a ``to_dict`` form (a key missing, a bad value);
                the message says what is wrong.
        """
        try:
            gen = d["generator_state"]
            if not isinstance(gen, list) or not all(
                    isinstance(b, int) and not isinstance(b, bool) and 0 <= b <= 255
                    for b in gen):
                raise ValueError("its generator state is not a list of bytes (ints 0..255)")
            dist = Distribution(*(torch.tensor(d["dist"][k], dtype=torch.float64)
                                  for k in ("probs", "mean", "std")))
            choice, particles, disp = d["best"]
            best = (torch.tensor(choice, dtype=torch.int64),
                    torch.tensor(particles, dtype=torch.int64),
                    torch.tensor(disp, dtype=torch.float64))
            counts = {k: d[k] for k in ("iteration", "n_nonfinite")}
            if not all(isinstance(v, int) and not isinstance(v, bool) for v in counts.values()):
                raise ValueError(f"its counts {counts} are not integers")
            out = cls(d["iteration"], dist, best, float(d["best_cost"]),
                      [float(c) for c in d["cost_history"]],
                      [float(c) for c in d["elite_history"]],
                      [float(c) for c in d["seconds"]], d["n_nonfinite"],
                      torch.tensor(gen, dtype=torch.uint8))
        except (KeyError, TypeError, ValueError, RuntimeError) as e:
            raise ValueError(f"not a CEM progress record ({type(e).__name__}: {e})") from e
        problem = _progress_problem(out)
        if problem is not None:
            raise ValueError(f"not a CEM progress record: {problem}")
        return out


#: bytes of a torch CPU generator's state (what ``torch.Generator.set_state`` takes)
GENERATOR_STATE_BYTES = torch.Generator().get_state().numel()


def _progress_problem(p: CEMProgress) -> str | None:
    """What makes a ``CEMProgress`` read from a file unusable, or None (``from_dict``)."""
    probs, mean, std = p.dist.probs, p.dist.mean, p.dist.std
    if probs.ndim != 2 or probs.shape[1] < 2:
        return f"its probabilities have shape {tuple(probs.shape)}, not (H, C + 1), C >= 1"
    H, C1 = probs.shape
    for name, t in (("means", mean), ("stds", std)):
        if tuple(t.shape) != (H, C1, 3):
            return f"its {name} have shape {tuple(t.shape)}, not {(H, C1, 3)}"
    if not (torch.isfinite(probs).all() and (probs >= 0).all()):
        return "its probabilities are not all finite and >= 0 (NaN or negative)"
    if not torch.allclose(probs.sum(-1), torch.ones(H, dtype=torch.float64), atol=1e-6):
        return f"its probabilities do not sum to 1 per action (sums {probs.sum(-1).tolist()})"
    if not (torch.isfinite(mean).all() and torch.isfinite(std).all() and (std >= 0).all()):
        return "its means or stds are not finite, or a std is negative"
    choice, particles, disp = p.best
    if tuple(choice.shape) != (H,) or tuple(particles.shape) != (H,) or \
            tuple(disp.shape) != (H, 3):
        return f"its best sample does not have the shapes ({H},), ({H},), ({H}, 3)"
    if not (((choice >= 0) & (choice < C1)).all() and (particles >= NONE).all()
            and torch.isfinite(disp).all()):
        return "its best sample has choices outside 0..C, particles below -1 or a NaN/inf move"
    if p.iteration < 1 or p.n_nonfinite < 0:
        return f"its iteration {p.iteration} (>= 1) or non-finite count {p.n_nonfinite} (>= 0)"
    histories = (p.cost_history, p.elite_history, p.seconds)
    if any(len(h) != p.iteration for h in histories):
        return f"its histories are not {p.iteration} long (one entry per iteration)"
    if not all(np.isfinite(v) for h in ([p.best_cost], *histories) for v in h) or \
            any(v < 0 for v in p.seconds):
        return "its best cost or histories hold NaN/inf (or a negative time)"
    if p.generator_state.numel() != GENERATOR_STATE_BYTES:
        return (f"its generator state has {p.generator_state.numel()} bytes, a torch CPU "
                f"generator's has {GENERATOR_STATE_BYTES}")
    return None


class CEM:
    """Cross-entropy method over pick-and-place sequences (see the module docstring)."""

    def __init__(self, config: CEMConfig = CEMConfig()):
        if not isinstance(config, CEMConfig):
            raise TypeError(f"config must be a CEMConfig, got {type(config).__name__}")
        self.config = config

    # ----------------------------------------------------------------- pieces
    def initial(self, n_candidates: int, bound: torch.Tensor) -> Distribution:
        """Uniform over the C candidates and None; zero-mean displacements with
        std = init_std * bound."""
        H, C = self.config.horizon, n_candidates
        probs = torch.full((H, C + 1), 1.0 / (C + 1), dtype=torch.float64)
        mean = torch.zeros((H, C + 1, 3), dtype=torch.float64)
        std = (self.config.init_std * bound).expand(H, C + 1, 3).clone()
        return Distribution(probs, mean, std)

    def sample(self, dist: Distribution, candidates: torch.Tensor, bound: torch.Tensor,
               generator: torch.Generator) -> Samples:
        """Draw P sequences; displacements are clipped to the bound and zero for None."""
        P = self.config.population
        H, C1 = dist.probs.shape
        choice = torch.multinomial(dist.probs, P, replacement=True, generator=generator).T
        slot = torch.arange(H).expand(P, H)
        noise = torch.randn((P, H, 3), generator=generator, dtype=torch.float64)
        disp = dist.mean[slot, choice] + dist.std[slot, choice] * noise
        disp = torch.maximum(torch.minimum(disp, bound), -bound)
        is_none = choice == C1 - 1
        disp[is_none] = 0.0
        with_none = torch.cat([candidates, torch.tensor([NONE])])
        return Samples(choice, with_none[choice], disp)

    def refit(self, dist: Distribution, samples: Samples, costs: torch.Tensor,
              bound: torch.Tensor) -> tuple[Distribution, torch.Tensor]:
        """Refit to the E lowest-cost samples; returns the new distribution and the elite
        indices (E,). Candidates no elite chose keep their Gaussian.

        A sample with a non-finite cost is never an elite: with fewer than E finite costs the
        refit uses the finite ones (E' < E of them, and the returned indices are E').

        Raises:
            ValueError: no sample has a finite cost.
        """
        cfg = self.config
        H, C1 = dist.probs.shape
        elite = torch.argsort(costs, stable=True)[:cfg.elites]
        elite = elite[torch.isfinite(costs[elite])]
        n_elites = len(elite)
        if n_elites == 0:
            raise ValueError(f"no sample has a finite cost (all {len(costs)} are NaN or inf); "
                             f"nothing to refit to")
        onehot = torch.nn.functional.one_hot(samples.choice[elite], C1).to(torch.float64)
        counts = onehot.sum(0)                                                   # (H, C+1)
        probs = counts / n_elites
        a = cfg.smoothing
        probs = a * dist.probs + (1 - a) * probs
        if cfg.prob_floor:
            probs = torch.clamp(probs, min=cfg.prob_floor / C1)
            probs = probs / probs.sum(-1, keepdim=True)
        d = samples.displacements[elite]                                          # (E, H, 3)
        n = counts.clamp(min=1)[..., None]
        mu = torch.einsum("ehc,ehd->hcd", onehot, d) / n
        var = torch.einsum("ehc,ehd->hcd", onehot, d ** 2) / n - mu ** 2
        sd = var.clamp(min=0).sqrt()
        # each candidate's Gaussian moves by the share of elites that chose it: all elites
        # agreeing is a plain smoothed refit, a single elite barely moves it (one sample says
        # nothing about a spread), and an unchosen candidate keeps its Gaussian
        step = ((1 - a) * counts / n_elites)[..., None]
        mean = dist.mean + step * (mu - dist.mean)
        std = dist.std + step * (sd - dist.std)
        std = torch.maximum(std, cfg.min_std * bound)
        return Distribution(probs, mean, std), elite

    # ------------------------------------------------------------------- plan
    def plan(self, task: PickTask, candidates, generator: torch.Generator,
             on_iteration: Callable[[int, float], None] | None = None, *,
             resume: CEMProgress | None = None,
             on_progress: Callable[[CEMProgress], None] | None = None) -> CEMResult:
        """Optimise H-action sequences over the candidate particles.

        Samples whose cost is NaN or inf score +inf: they are never elites nor the best. An
        iteration in which every sample does is an error, not a result.

        Args:
            task: evaluates a population (see ``PickTask``); its ``bound`` must be (3,) (or a
                scalar) of finite non-negative metres; with an ``n_particles`` attribute the
                candidates are checked against it.
            candidates: (C,) distinct integer particle indices the picker may grasp (None is
                always allowed).
            generator: a ``torch.Generator``, the only source of randomness; the same seed gives
                the same result.
            on_iteration: called as ``on_iteration(i, best_cost)`` after every iteration
                (progress bars live in the caller).
            resume: a ``CEMProgress`` of this plan (same task, candidates and config) to go on
                from: the generator is set to its state, and the result is the one the
                uninterrupted plan gives.
            on_progress: called with a ``CEMProgress`` after every iteration (a long plan
                saves it, so that a rerun can resume).

        Raises:
            TypeError: candidates that are not integers (floats, bools), a generator that is not
                a ``torch.Generator``, an ``on_iteration`` that is not callable, or costs from
                ``task.evaluate`` that are not numbers.
            ValueError: empty, repeated, negative or out-of-range candidates, a bad bound,
                ``task.evaluate`` returning costs of another shape than (P,), or a ``resume``
                that does not fit this plan (its shapes or iteration count).
            RuntimeError: every sample of an iteration had a non-finite cost.
            whatever ``task.evaluate`` raises (bad actions, an unstable simulation).
        """
        cfg = self.config
        cand = torch.from_numpy(particle_indices(candidates, "candidates",
                                                 getattr(task, "n_particles", None),
                                                 distinct=True))
        bound = torch.from_numpy(picker_bound(getattr(task, "bound", None)))
        if not isinstance(generator, torch.Generator):
            raise TypeError(f"generator must be a torch.Generator (the only source of "
                            f"randomness), got {type(generator).__name__}")
        for name, f in (("on_iteration", on_iteration), ("on_progress", on_progress)):
            if f is not None and not callable(f):
                raise TypeError(f"{name} must be callable or None, got {f!r}")
        run = self._start(cand, bound, resume, generator)
        for it in range(run.iteration, cfg.iterations):
            run = self._iterate(task, run, cand, bound, generator)
            if on_iteration is not None:
                on_iteration(it, run.best_cost)
            if on_progress is not None:
                on_progress(replace(run, cost_history=list(run.cost_history),
                                    elite_history=list(run.elite_history),
                                    seconds=list(run.seconds),
                                    generator_state=generator.get_state()))
        best = run.best
        return CEMResult(best[1].numpy().copy(), best[2].numpy().copy(), run.best_cost,
                         np.array(run.cost_history), np.array(run.elite_history),
                         np.array(run.seconds), cand.numpy().copy(),
                         cfg.iterations * cfg.population, run.n_nonfinite)

    def _start(self, cand: torch.Tensor, bound: torch.Tensor, resume: CEMProgress | None,
               generator: torch.Generator) -> CEMProgress:
        """Where a plan over ``cand`` (C,) starts: the initial distribution, or ``resume``
        checked and the generator set to its state (``generator_state`` of the returned
        progress is filled in only when it is handed out)."""
        dist = self.initial(cand.numel(), bound)
        if resume is None:
            return CEMProgress(0, dist, None, float("inf"), [], [], [], 0, None)
        self._check_resume(resume, dist)
        generator.set_state(resume.generator_state)
        log.info("CEM resumes after iteration %d of %d (best %.4g)", resume.iteration,
                 self.config.iterations, resume.best_cost)
        return replace(resume, cost_history=list(resume.cost_history),
                       elite_history=list(resume.elite_history), seconds=list(resume.seconds))

    def _iterate(self, task, run: CEMProgress, cand: torch.Tensor, bound: torch.Tensor,
                 generator: torch.Generator) -> CEMProgress:
        """One CEM iteration from ``run``: sample (the best so far in slot 0 with
        ``keep_best``), evaluate (non-finite costs score +inf), refit, keep the best."""
        cfg, it, t0 = self.config, run.iteration, time.perf_counter()
        s = self.sample(run.dist, cand, bound, generator)
        if cfg.keep_best and run.best is not None:
            s.choice[0], s.particles[0], s.displacements[0] = run.best
        costs = _check_costs(task, task.evaluate(s.particles, s.displacements), cfg.population)
        finite = torch.isfinite(costs)
        if not finite.any():
            raise RuntimeError(
                f"every sample of CEM iteration {it} had a non-finite cost (all "
                f"{cfg.population} NaN or inf from {_evaluate_name(task)}); no plan to return")
        if not finite.all():
            log.debug("CEM iteration %d: %d of %d costs non-finite, scored +inf", it,
                      int((~finite).sum()), cfg.population)
        costs = torch.where(finite, costs, torch.inf)
        dist, elite = self.refit(run.dist, s, costs, bound)
        i = int(elite[0])
        best, best_cost = run.best, run.best_cost
        if float(costs[i]) < best_cost:
            best_cost = float(costs[i])
            best = (s.choice[i].clone(), s.particles[i].clone(), s.displacements[i].clone())
        run.cost_history.append(best_cost)
        run.elite_history.append(float(costs[elite].mean()))
        run.seconds.append(time.perf_counter() - t0)
        log.debug("CEM iteration %d: best %.4g, elite mean %.4g, %.2f s", it, best_cost,
                  run.elite_history[-1], run.seconds[-1])
        return replace(run, iteration=it + 1, dist=dist, best=best, best_cost=best_cost,
                       n_nonfinite=run.n_nonfinite + int((~finite).sum()))


    def _check_resume(self, resume, initial: Distribution) -> None:
        """ValueError unless ``resume`` is a CEMProgress of a plan shaped like this one."""
        if not isinstance(resume, CEMProgress):
            raise TypeError(f"resume must be a CEMProgress or None, got "
                            f"{type(resume).__name__}")
        n = resume.iteration
        problems = [f"{name} {tuple(getattr(resume.dist, name).shape)} against "
                    f"{tuple(getattr(initial, name).shape)}"
                    for name in ("probs", "mean", "std")
                    if getattr(resume.dist, name).shape != getattr(initial, name).shape]
        if not 1 <= n <= self.config.iterations:
            problems.append(f"iteration {n} outside 1..{self.config.iterations}")
        if any(len(h) != n for h in (resume.cost_history, resume.elite_history,
                                     resume.seconds)):
            problems.append(f"histories of another length than its {n} iterations")
        if resume.best is None or resume.best[2].shape != (self.config.horizon, 3):
            problems.append("no best sample of this horizon")
        if problems:
            raise ValueError("resume does not fit this plan: " + "; ".join(problems))


def _evaluate_name(task) -> str:
    return f"{type(task).__name__}.evaluate"


def _check_costs(task, raw, population: int) -> torch.Tensor:
    """The costs ``task.evaluate`` returned as a (P,) float64 tensor (NaN/inf kept)."""
    if raw is None:
        raise TypeError(f"{_evaluate_name(task)} returned None; it must return "
                        f"({population},) float costs")
    kind = (("c" if raw.is_complex() else "b" if raw.dtype == torch.bool else "f")
            if torch.is_tensor(raw) else np.asarray(raw).dtype.kind)
    if kind in "cbUS":
        what = {"c": "complex", "b": "bool", "U": "str", "S": "bytes"}[kind]
        raise TypeError(f"{_evaluate_name(task)} returned {what} costs; it must return "
                        f"({population},) real float costs")
    try:
        costs = torch.as_tensor(raw.detach().cpu() if torch.is_tensor(raw)
                                else np.asarray(raw, dtype=float), dtype=torch.float64)
    except (TypeError, ValueError) as e:
        raise TypeError(f"{_evaluate_name(task)} must return ({population},) float costs, got "
                        f"{type(raw).__name__}: {e}") from None
    if costs.shape != (population,):
        raise ValueError(f"{_evaluate_name(task)} returned costs of shape "
                         f"{tuple(costs.shape)} for {population} samples; it must return "
                         f"one cost per sample, shape ({population},)")
    return costs
