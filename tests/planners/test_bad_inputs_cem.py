"""Every bad input of the planners' sampling side gets a clear error naming the argument, and no
failure passes as a result: CEM's cost handling (non-finite populations, costs of the wrong
shape), candidates, bounds and configs; the scripted policy (the pick-and-place settings':
tests/planners/pick_place/test_bad_inputs.py)."""
from types import SimpleNamespace

import numpy as np
import pytest
import torch

from planners.cem import CEM, NONE, CEMConfig, Samples
from planners.scripted import ScriptedConfig, scripted


# ------------------------------------------------------------------------------ tasks
class Points:
    """A PickTask and ScriptedTask without physics: picking particle i moves it by d; the cost
    is the mean particle distance to the goal (particle 3 moved by (0.05, 0, 0))."""

    def __init__(self, n=6):
        self.n_particles = n
        self.start = np.c_[np.arange(n) * 0.05, np.zeros((n, 2))]
        self.goal = self.start.copy()
        self.goal[3, 0] += 0.05
        self.bound = np.full(3, 0.1)
        self.start_state = self.start.ravel().copy()

    def final(self, particles, displacements):
        pos = np.repeat(self.start[None], len(particles), axis=0)
        for h in range(particles.shape[1]):
            rows = np.flatnonzero(particles[:, h] != NONE)
            pos[rows, particles[rows, h]] += displacements[rows, h]
        return pos

    def evaluate(self, particles, displacements):
        pos = self.final(particles.numpy(), displacements.numpy())
        return torch.from_numpy(np.linalg.norm(pos - self.goal, axis=-1).mean(-1))

    # ScriptedTask
    def positions(self, state):
        return np.asarray(state).reshape(-1, 3)

    def step(self, state, particle, displacement):
        p = self.positions(state).copy()
        p[particle] += displacement
        return SimpleNamespace(state=p.ravel(), unstable=False, reason="")

    def cost(self, state):
        return float(np.linalg.norm(self.positions(state) - self.goal, axis=1).mean())


class Returns(Points):
    """evaluate returns ``make(P)`` instead of the costs."""

    def __init__(self, make):
        super().__init__()
        self.make = make

    def evaluate(self, particles, displacements):
        return self.make(len(particles))


class Unstable(Points):
    """Samples whose first action picks ``bad`` go unstable (NaN cost); the lowest cost would
    otherwise be theirs."""

    def __init__(self, bad=5):
        super().__init__()
        self.bad = bad

    def evaluate(self, particles, displacements):
        p = particles.numpy()
        costs = 1.0 - 0.1 * p[:, 0].astype(float)
        return torch.from_numpy(np.where(p[:, 0] == self.bad, np.nan, costs))


class GoesUnstable(Points):
    """Finite costs in the first iteration, every cost NaN afterwards."""

    calls = 0

    def evaluate(self, particles, displacements):
        self.calls += 1
        costs = super().evaluate(particles, displacements)
        return costs if self.calls == 1 else torch.full_like(costs, np.nan)


def plan(task, candidates=(1, 2, 3), config=CEMConfig(population=8, elites=2, iterations=2,
                                                       horizon=1), generator=None, **kwargs):
    generator = torch.Generator().manual_seed(0) if generator is None else generator
    return CEM(config).plan(task, candidates, generator, **kwargs)


# ----------------------------------------------------------------------- CEM costs
@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
def test_a_population_without_a_finite_cost_is_an_error(value):
    """All costs NaN used to end in "TypeError: 'NoneType' object is not subscriptable"."""
    task = Returns(lambda P: torch.full((P,), value, dtype=torch.float64))
    with pytest.raises(RuntimeError, match="every sample of CEM iteration 0 had a non-finite "
                                           "cost .*Returns.evaluate"):
        plan(task)


def test_a_population_going_unstable_later_names_its_iteration():
    with pytest.raises(RuntimeError, match="every sample of CEM iteration 1"):
        plan(GoesUnstable())


def test_non_finite_costs_among_finite_ones_are_never_elite_nor_best():
    task = Unstable(bad=5)
    res = plan(task, candidates=[1, 2, 5], config=CEMConfig(population=16, elites=4,
                                                            iterations=4, horizon=1))
    assert np.isfinite(res.cost) and res.particles[0] != 5
    assert np.all(np.isfinite(res.cost_history)) and np.all(np.isfinite(res.elite_history))


def test_refit_uses_only_the_finite_elites():
    cem = CEM(CEMConfig(population=6, elites=4, horizon=1, smoothing=0.0, prob_floor=0.0))
    bound = torch.full((3,), 0.1, dtype=torch.float64)
    dist = cem.initial(2, bound)
    choice = torch.tensor([[0], [1], [0], [1], [2], [2]])
    s = Samples(choice, choice, torch.zeros((6, 1, 3), dtype=torch.float64))
    costs = torch.tensor([np.nan, 1.0, np.inf, 2.0, np.nan, np.inf], dtype=torch.float64)
    new, elite = cem.refit(dist, s, costs, bound)
    assert sorted(elite.tolist()) == [1, 3]                 # 2 finite of the 4 elites
    torch.testing.assert_close(new.probs[0], torch.tensor([0.0, 1.0, 0.0],
                                                          dtype=torch.float64))
    with pytest.raises(ValueError, match="no sample has a finite cost"):
        cem.refit(dist, s, torch.full((6,), np.nan, dtype=torch.float64), bound)


@pytest.mark.parametrize("make, error, match", [
    (lambda P: torch.zeros(3, dtype=torch.float64), ValueError,
     r"Returns.evaluate returned costs of shape \(3,\) for 8 samples"),
    (lambda P: torch.zeros((P, 1), dtype=torch.float64), ValueError,
     r"Returns.evaluate returned costs of shape \(8, 1\)"),
    (lambda P: 0.0, ValueError, r"Returns.evaluate returned costs of shape \(\)"),
    (lambda P: np.zeros(P + 1), ValueError, r"shape \(9,\) for 8 samples"),
    (lambda P: None, TypeError, "Returns.evaluate returned None"),
    (lambda P: ["cheap"] * P, TypeError, r"Returns.evaluate returned str costs"),
    (lambda P: np.ones(P) + 1j, TypeError, r"Returns.evaluate returned complex costs"),
    (lambda P: torch.ones(P, dtype=torch.complex128), TypeError, "returned complex costs"),
    (lambda P: np.ones(P, dtype=bool), TypeError, r"Returns.evaluate returned bool costs"),
    (lambda P: torch.ones(P, dtype=torch.bool), TypeError, "returned bool costs"),
])
def test_costs_of_the_wrong_shape_or_type(make, error, match):
    """3 zeros for 8 samples used to come back as a plan of cost 0.0."""
    with pytest.raises(error, match=match):
        plan(Returns(make))


def test_numpy_costs_of_the_right_shape_are_accepted():
    res = plan(Returns(lambda P: np.linspace(1.0, 2.0, P)))
    assert res.cost == 1.0


# ------------------------------------------------------------------ CEM arguments
@pytest.mark.parametrize("candidates, error, match", [
    ([0.5, 1.7], TypeError, "candidates must be integer particle indices, got dtype float64"),
    ([1.0, 2.0], TypeError, "candidates must be integer particle indices"),
    ([np.nan, 1], TypeError, "candidates must be integer particle indices"),
    ([True, False], TypeError, "candidates must be integer particle indices, got dtype bool"),
    (["a"], TypeError, "candidates must be integer particle indices"),
    ([-2, 3], ValueError, "candidates must be particle indices >= 0"),
    ([3, 6], ValueError, r"candidates must be particle indices < 6 .*\[6\]"),
    ([[1, 2], [3, 4]], ValueError, r"candidates must be 1-D particle indices, got shape \(2, 2"),
    (3, ValueError, "candidates must be 1-D"),
    ([], ValueError, "candidates is empty"),
    ([1, 1], ValueError, "candidates has repeated particles"),
])
def test_candidates(candidates, error, match):
    with pytest.raises(error, match=match):
        plan(Points(), candidates)


def test_candidates_may_be_a_tensor_or_numpy_ints():
    assert plan(Points(), torch.tensor([1, 3])).candidates.tolist() == [1, 3]
    assert plan(Points(), np.array([1, 3], np.int32)).candidates.tolist() == [1, 3]


@pytest.mark.parametrize("bound, error, match", [
    (np.nan, ValueError, "task.bound must be finite and >= 0"),
    (np.inf, ValueError, "task.bound must be finite and >= 0"),
    ([0.1, -0.1, 0.1], ValueError, "task.bound must be finite and >= 0"),
    ([0.1, 0.1], ValueError, r"task.bound must be \(3,\) metres .*shape \(2,\)"),
    (None, TypeError, r"task.bound must be \(3,\) metres, got None"),
    ("0.1", TypeError, r"task.bound must be \(3,\) metres"),
])
def test_task_bound(bound, error, match):
    task = Points()
    task.bound = bound
    with pytest.raises(error, match=match):
        plan(task)


@pytest.mark.parametrize("kwargs, error, match", [
    (dict(generator=0), TypeError, "generator must be a torch.Generator"),
    (dict(generator=np.random.default_rng(0)), TypeError, "generator must be a torch.Gen"),
    (dict(on_iteration=1), TypeError, "on_iteration must be callable"),
])
def test_generator_and_callback(kwargs, error, match):
    with pytest.raises(error, match=match):
        plan(Points(), **kwargs)


def test_cem_needs_a_config():
    with pytest.raises(TypeError, match="config must be a CEMConfig"):
        CEM({"population": 8})


@pytest.mark.parametrize("kwargs, error, match", [
    (dict(population=8.5), TypeError, "CEMConfig.population.*int"),
    (dict(horizon=True), TypeError, "CEMConfig.horizon.*int"),
    (dict(elites="2"), TypeError, "CEMConfig.elites.*int"),
    (dict(smoothing=np.nan), ValueError, "CEMConfig.smoothing.*finite"),
    (dict(smoothing="0.3"), TypeError, "CEMConfig.smoothing.*number"),
    (dict(smoothing=True), TypeError, "CEMConfig.smoothing.*number"),
    (dict(init_std=np.inf), ValueError, "CEMConfig.init_std.*finite"),
    (dict(init_std=-1.0), ValueError, "init_std > 0"),
    (dict(min_std=np.nan), ValueError, "CEMConfig.min_std.*finite"),
    (dict(prob_floor=np.nan), ValueError, "CEMConfig.prob_floor.*finite"),
    (dict(prob_floor=None), TypeError, "CEMConfig.prob_floor.*number"),
    (dict(keep_best=1), TypeError, "CEMConfig.keep_best.*bool"),
    (dict(keep_best="yes"), TypeError, "CEMConfig.keep_best.*bool"),
])
def test_cem_config_fields(kwargs, error, match):
    with pytest.raises(error, match=match):
        CEMConfig(**kwargs)


# ------------------------------------------------------------------------- scripted
def test_scripted_runs_on_the_toy_task():
    res = scripted(Points(), [3])
    assert res.particles.tolist() == [3] and res.cost < Points().cost(Points().start_state)


@pytest.mark.parametrize("keys, error, match", [
    ([1.5], TypeError, "keys must be integer particle indices"),
    ([True], TypeError, "keys must be integer particle indices, got dtype bool"),
    ([-1], ValueError, "keys must be particle indices >= 0"),
    ([7], ValueError, "keys must be particle indices < 6"),
    ([[1, 2]], ValueError, "keys must be 1-D"),
    ([], ValueError, "keys is empty"),
])
def test_scripted_keys(keys, error, match):
    """Negative keys used to pick particles from the end (-1: the last), floats were
    truncated, bools picked particles 0 and 1."""
    with pytest.raises(error, match=match):
        scripted(Points(), keys)


@pytest.mark.parametrize("attribute, value, error, match", [
    ("bound", np.nan, ValueError, "task.bound.*finite"),
    ("bound", -1.0, ValueError, "task.bound must be finite and >= 0"),
    ("goal", np.full((6, 3), np.nan), ValueError, r"task.goal.*NaN/inf"),
    ("goal", np.zeros((6, 2)), ValueError, r"task.goal.*shape"),
    ("start_state", np.full(18, np.nan), ValueError, r"task.start_state.*NaN/inf"),
    ("start_state", np.zeros((6, 3)), ValueError, r"task.start_state.*dim"),
])
def test_scripted_task(attribute, value, error, match):
    """NaN bounds, goals or starts used to come back as a NaN cost."""
    task = Points()
    setattr(task, attribute, value)
    with pytest.raises(error, match=match):
        scripted(task, [3])


def test_scripted_non_finite_final_cost_is_an_error():
    task = Points()
    task.cost = lambda state: float("nan")
    with pytest.raises(RuntimeError, match="non-finite cost"):
        scripted(task, [3])


@pytest.mark.parametrize("kwargs, error, match", [
    (dict(lift=np.nan), ValueError, "ScriptedConfig.lift.*finite"),
    (dict(lift=-0.01), ValueError, "ScriptedConfig.lift.*>= 0"),
    (dict(tolerance=0.0), ValueError, "ScriptedConfig.tolerance.*> 0"),
    (dict(tolerance=np.inf), ValueError, "ScriptedConfig.tolerance.*finite"),
    (dict(tolerance="a"), TypeError, "ScriptedConfig.tolerance.*number"),
    (dict(per_particle=1.5), TypeError, "ScriptedConfig.per_particle.*int"),
    (dict(per_particle=0), ValueError, "ScriptedConfig.per_particle.*>= 1"),
    (dict(max_actions=True), TypeError, "ScriptedConfig.max_actions.*int"),
])
def test_scripted_config_fields(kwargs, error, match):
    with pytest.raises(error, match=match):
        ScriptedConfig(**kwargs)


def test_scripted_needs_a_config():
    with pytest.raises(TypeError, match="config must be a ScriptedConfig"):
        scripted(Points(), [3], {"lift": 0.0})
