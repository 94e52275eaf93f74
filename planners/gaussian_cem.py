"""Torch-batched cross-entropy method over a box with one diagonal Gaussian: the plain CEM of
the key-particle authors' code (``cem/cem.py``, ``CEMOptimizer.obtain_solution``).

Each iteration draws P vectors x ~ N(mean, diag(std^2)) clipped to the box [low, high], adds
the best vector found so far as one more sample (evaluated once: its cost is carried), asks
for the costs and refits mean and std to the E lowest-cost samples (no smoothing, no floor:
the authors' refit). A NaN or inf cost scores +inf; an iteration without one finite cost is
an error. The answer is the best sample seen, not the final mean.

Everything random comes through the caller's ``torch.Generator``. Shapes: P population,
E elites, D dimensions.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import torch

from dopt.validation import check_config, float_array


@dataclass(frozen=True)
class GaussianCEMConfig:
    """population: P samples per iteration (the carried best comes on top); elites: E;
    iterations: refits; init_std: the first std as a fraction of the box's width (the
    authors' variance (high - low) / 4 on their box [-1, 1] is a std of sqrt(1/2), 0.354 of
    its width 2); the first mean is the box's centre."""

    population: int = 32
    elites: int = 3
    iterations: int = 30
    init_std: float = 0.5 ** 0.5 / 2

    def __post_init__(self):
        check_config(self, positive=("init_std",), minimum={"population": 1, "elites": 1,
                                                            "iterations": 1})
        if self.elites > self.population:
            raise ValueError(f"need elites <= population, got {self.elites} > "
                             f"{self.population}")


@dataclass(frozen=True)
class GaussianCEMResult:
    """best (D,), its cost, the best cost after each iteration (iterations,), the mean elite
    cost of each, the seconds of each, the samples evaluated, those with a non-finite cost."""

    best: np.ndarray
    cost: float
    cost_history: np.ndarray
    elite_history: np.ndarray
    seconds_per_iteration: np.ndarray
    n_evaluated: int
    n_nonfinite: int


class GaussianCEM:
    """CEM with one diagonal Gaussian over a box (module docstring)."""

    def __init__(self, config: GaussianCEMConfig = GaussianCEMConfig()):
        if not isinstance(config, GaussianCEMConfig):
            raise TypeError(f"config must be a GaussianCEMConfig, got "
                            f"{type(config).__name__}")
        self.config = config

    def plan(self, cost: Callable[[torch.Tensor], torch.Tensor], low, high,
             generator: torch.Generator,
             on_iteration: Callable[[int, float], None] | None = None) -> GaussianCEMResult:
        """Minimise ``cost`` ((P, D) float64 samples -> (P,) costs) over the box
        [low, high] (D,) each.

        Raises:
            TypeError: a generator that is not a ``torch.Generator``.
            ValueError: a box with low > high or of another shape than high, costs of another
                shape than (P,).
            RuntimeError: every sample of an iteration had a non-finite cost.
        """
        cfg = self.config
        lo = torch.from_numpy(float_array(low, "low").reshape(-1).copy())
        hi = torch.from_numpy(float_array(high, "high").reshape(-1).copy())
        if lo.shape != hi.shape or not (lo <= hi).all():
            raise ValueError(f"low and high must be (D,) with low <= high, got {tuple(lo.shape)}"
                             f" and {tuple(hi.shape)}")
        if not isinstance(generator, torch.Generator):
            raise TypeError(f"generator must be a torch.Generator, got "
                            f"{type(generator).__name__}")
        mean, std = (lo + hi) / 2, cfg.init_std * (hi - lo)
        best, best_cost = None, float("inf")
        history, elites_mean, seconds, n_bad, n_eval = [], [], [], 0, 0
        for it in range(cfg.iterations):
            t0 = time.perf_counter()
            noise = torch.randn((cfg.population, len(lo)), generator=generator,
                                dtype=torch.float64)
            x = torch.maximum(torch.minimum(mean + std * noise, hi), lo)
            c = torch.as_tensor(cost(x), dtype=torch.float64).reshape(-1)
            if c.shape != (cfg.population,):
                raise ValueError(f"cost returned {tuple(c.shape)} costs for "
                                 f"{cfg.population} samples")
            n_eval += cfg.population
            finite = torch.isfinite(c)
            n_bad += int((~finite).sum())
            if not finite.any():
                raise RuntimeError(f"every sample of CEM iteration {it} had a non-finite cost")
            c = torch.where(finite, c, torch.inf)
            if best is not None:                  # the carried best competes as a sample
                x, c = torch.cat([x, best[None]]), torch.cat([c, torch.tensor([best_cost])])
            order = torch.argsort(c, stable=True)[:cfg.elites]
            order = order[torch.isfinite(c[order])]
            elite = x[order]
            mean, std = elite.mean(0), elite.std(0, unbiased=False)
            if float(c[order[0]]) < best_cost:
                best, best_cost = x[order[0]].clone(), float(c[order[0]])
            history.append(best_cost)
            elites_mean.append(float(c[order].mean()))
            seconds.append(time.perf_counter() - t0)
            if on_iteration is not None:
                on_iteration(it, best_cost)
        return GaussianCEMResult(best.numpy().copy(), best_cost, np.array(history),
                                 np.array(elites_mean), np.array(seconds), n_eval, n_bad)
