"""Why CEM(Random) lands where it does: the reach of each seed's random candidate set.

CEM(Random) plans over as many particles as there are key particles, drawn at random once
per stage (``CEMPlanner.candidate_particles``, seeded by the trial's seed). A fold moves part
of the cloth; a particle of the part that stays cannot fold it, however well CEM places it.
This module re-draws each recorded trial's candidate sets (the same numpy generator, the same
seed, the same order of stages: bit for bit what the trial planned over) and measures what
they can reach:

- ``need`` of a particle in a stage: how far the stage's goal moves it, |g_s - g_{s-1}| (m),
  with g_0 the flat start (the intended motion, independent of what the planner did);
- ``reach`` of a stage: the largest need among its candidates over the largest need of all
  particles (1: a candidate sits where the fold moves most; 0: no candidate moves at all);
- ``blind`` stages: no candidate needs more than ``moving`` metres;
- the chance of a blind stage under the draw, hypergeometric: C(N - M, K) / C(N, K) with M
  the particles that need more than ``moving`` and K the candidates.

``random_reach`` pairs each trial's final cost with its smallest stage reach, and
``reach_summary`` gives the Spearman rank correlation of the two (scipy), the blind trials
observed against expected (and the chance of at least as many), and the mean final cost of
blind and seeing trials.

Shapes: N particles, K candidates, S stages.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np

#: metres a particle must move in a stage to count as moved by it
MOVING = 0.01


@dataclass(frozen=True)
class StageReach:
    """One stage of one trial: its name, candidates (K,), the largest need among them and
    over all particles (m), their ratio ``reach``, and ``p_blind`` the chance that a random
    draw of K holds no particle that moves."""

    stage: str
    candidates: list[int]
    need: float
    max_need: float
    reach: float
    p_blind: float


@dataclass(frozen=True)
class TrialReach:
    """One CEM(Random) trial: seed, final cost (m), its stages, ``reach`` the smallest stage
    reach, ``blind`` whether some stage had no moving candidate."""

    seed: int
    final_cost: float
    stages: list[StageReach]
    reach: float
    blind: bool

    def to_dict(self) -> dict:
        return asdict(self)


def stage_needs(problem) -> list[np.ndarray]:
    """(S,) arrays (N,): how far each stage's goal moves each particle from the previous
    stage's goal (the first stage: from the start state), m."""
    prev = problem.scene.positions(problem.start_state)
    needs = []
    for stage in problem.stages:
        needs.append(np.linalg.norm(np.asarray(stage.goal) - prev, axis=1))
        prev = np.asarray(stage.goal)
    return needs


def p_blind(need: np.ndarray, k: int, moving: float = MOVING) -> float:
    """The chance that k particles drawn without replacement from len(need) all need at most
    ``moving`` metres (hypergeometric)."""
    n, m = len(need), int(np.sum(need > moving))
    if k > n:
        raise ValueError(f"cannot draw {k} candidates from {n} particles")
    return math.comb(n - m, k) / math.comb(n, k)


def trial_reach(settings, seed: int, final_cost: float, moving: float = MOVING) -> TrialReach:
    """Re-draw the candidates of a CEM(Random) trial of ``settings`` (``PickPlaceSettings``)
    and seed, and measure their reach (module docstring)."""
    from planners.pick_place import CEMPlanner, make_problem

    problem = make_problem(settings, seed)
    planner = CEMPlanner(settings.cem, "random", seed)
    stages = []
    for stage, need in zip(problem.stages, stage_needs(problem), strict=True):
        cand = planner.candidate_particles(stage.keys, len(need))
        top = float(need.max())
        stages.append(StageReach(stage.name, cand.tolist(), float(need[cand].max()), top,
                                 float(need[cand].max() / top) if top > 0 else 1.0,
                                 p_blind(need, len(cand), moving)))
    return TrialReach(int(seed), float(final_cost), stages,
                      min(s.reach for s in stages),
                      any(s.need <= moving for s in stages))


def random_reach(records: Sequence[dict], moving: float = MOVING) -> list[TrialReach]:
    """``trial_reach`` of every CEM(Random) trial record (``{"params": {"settings", "seed",
    "method"}, "result": {"final_cost"}}``, as a pick-and-place sweep stores them), by seed.

    Raises:
        ValueError: the CEM(Random) records ran more than one setting (a folder holding two
            protocols, such as a multi-layer fold's chained and prepared starts): a seed would
            stand for two trials; split them first (``settings_groups``)."""
    from planners.pick_place import PickPlaceSettings

    random = [rec for rec in records if rec["params"].get("method") == "random"]
    if len(settings_groups(random)) > 1:
        raise ValueError("the CEM(Random) records ran more than one setting; "
                         "split them with settings_groups first")
    out = []
    for rec in random:
        params, result = rec["params"], rec["result"]
        settings = PickPlaceSettings.from_dict(params["settings"])
        out.append(trial_reach(settings, params["seed"], result["final_cost"], moving))
    return sorted(out, key=lambda t: t.seed)


def settings_groups(records: Sequence[dict]) -> list[list[dict]]:
    """The trial records split by what they ran (``PickPlaceSettings.identity`` of their
    ``params.settings``; the method and seed aside), in order of first appearance."""
    import json

    from planners.pick_place import PickPlaceSettings

    groups: dict[str, list[dict]] = {}
    for rec in records:
        identity = PickPlaceSettings.from_dict(rec["params"]["settings"]).identity()
        groups.setdefault(json.dumps(identity, sort_keys=True), []).append(rec)
    return list(groups.values())


def at_least(chances: Sequence[float], k: int) -> float:
    """The chance that at least ``k`` of independent events with the given chances happen
    (the Poisson-binomial upper tail, by dynamic programming over the events)."""
    dist = np.zeros(len(chances) + 1)
    dist[0] = 1.0
    for c in chances:
        dist[1:] = dist[1:] * (1.0 - c) + dist[:-1] * c
        dist[0] *= 1.0 - c
    return float(min(1.0, dist[max(k, 0):].sum()))


def reach_summary(trials: Sequence[TrialReach]) -> dict:
    """The Spearman correlation of final cost and reach over the trials (rho, two-sided p;
    None under 3 trials or a constant column), blind trials observed and expected (the sum of
    each trial's chance of a blind stage), and the mean final cost of blind and seeing
    trials (m; None where there are none), and ``p_blind_at_least`` the chance of at least
    as many blind trials as observed (``at_least``)."""
    from scipy.stats import spearmanr

    costs = np.array([t.final_cost for t in trials])
    reach = np.array([t.reach for t in trials])
    rho = p = None
    if len(trials) >= 3 and np.ptp(costs) > 0 and np.ptp(reach) > 0:
        r = spearmanr(costs, reach)
        rho, p = float(r.statistic), float(r.pvalue)
    blind = np.array([t.blind for t in trials], dtype=bool)
    chances = [1.0 - math.prod(1.0 - s.p_blind for s in t.stages) for t in trials]
    return {"trials": len(trials), "spearman_rho": rho, "spearman_p": p,
            "blind": int(blind.sum()), "blind_expected": float(sum(chances)),
            "p_blind_at_least": at_least(chances, int(blind.sum())),
            "cost_blind": float(costs[blind].mean()) if blind.any() else None,
            "cost_seeing": float(costs[~blind].mean()) if (~blind).any() else None}
