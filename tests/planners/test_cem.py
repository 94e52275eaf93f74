"""CEM over pick actions: reproducibility, bounds, refit, convergence on a toy task with a known
optimum, and a reproducible iteration on a small cloth."""

import json

import numpy as np
import pytest
import torch

from planners.cem import CEM, NONE, CEMConfig, CEMProgress, Distribution, Samples


class PointsTask:
    """Toy PickTask without physics: picking particle i moves it rigidly by d. The cost is the
    mean particle distance to the goal; the optimum moves particle ``target`` by ``offset``."""

    def __init__(self, n=10, target=3, offset=(0.08, -0.05, 0.02), bound=0.1):
        self.start = np.zeros((n, 3))
        self.start[:, 0] = np.arange(n) * 0.05
        self.goal = self.start.copy()
        self.goal[target] += offset
        self.bound = np.full(3, bound)
        self.calls = 0

    def evaluate(self, particles, displacements):
        self.calls += 1
        p = particles.numpy()
        d = displacements.numpy()
        assert np.all(np.abs(d) <= self.bound + 1e-12)
        pos = np.repeat(self.start[None], len(p), axis=0)
        for h in range(p.shape[1]):
            rows = np.flatnonzero(p[:, h] != NONE)
            pos[rows, p[rows, h]] += d[rows, h]
        return torch.from_numpy(np.linalg.norm(pos - self.goal, axis=-1).mean(-1))


def _plan(seed, config, task=None, candidates=range(10)):
    task = task or PointsTask()
    return CEM(config).plan(task, list(candidates), torch.Generator().manual_seed(seed))


@pytest.mark.parametrize("population", [1, 16])
def test_same_seed_same_result(population):
    cfg = CEMConfig(population=population, elites=1, iterations=3, horizon=2)
    a, b = _plan(5, cfg), _plan(5, cfg)
    assert np.array_equal(a.particles, b.particles)
    assert np.array_equal(a.displacements, b.displacements)
    assert np.array_equal(a.cost_history, b.cost_history)
    c = _plan(6, cfg)
    assert not np.array_equal(a.displacements, c.displacements)


def test_converges_to_known_optimum():
    task = PointsTask()
    res = _plan(0, CEMConfig(population=64, elites=8, iterations=25, horizon=1), task)
    assert res.particles.tolist() == [3]
    assert np.allclose(res.displacements[0], [0.08, -0.05, 0.02], atol=0.01)
    assert res.cost < 2e-3
    assert np.all(np.diff(res.cost_history) <= 0)          # best so far never rises
    assert task.calls == 25
    assert res.seconds_per_iteration.shape == (25,)


def test_samples_respect_bound_and_none():
    cem = CEM(CEMConfig(population=200, horizon=3, init_std=1.0))
    bound = torch.tensor([0.1, 0.2, 0.05], dtype=torch.float64)
    cand = torch.tensor([4, 7])
    dist = cem.initial(2, bound)
    s = cem.sample(dist, cand, bound, torch.Generator().manual_seed(0))
    assert s.particles.shape == (200, 3) and s.displacements.shape == (200, 3, 3)
    assert torch.all(s.displacements.abs() <= bound)
    none = s.particles == NONE
    assert none.any() and torch.all(s.displacements[none] == 0)
    assert set(s.particles.unique().tolist()) == {NONE, 4, 7}


def test_refit_moves_towards_elites():
    cfg = CEMConfig(population=4, elites=2, horizon=1, smoothing=0.5, min_std=0.0)
    cem = CEM(cfg)
    bound = torch.full((3,), 0.1, dtype=torch.float64)
    dist = cem.initial(2, bound)                                   # 2 candidates + None
    choice = torch.tensor([[0], [0], [1], [2]])
    disp = torch.tensor([[[0.05, 0, 0]], [[0.07, 0, 0]], [[0.0, 0.1, 0]], [[0, 0, 0]]],
                        dtype=torch.float64)
    s = Samples(choice, choice, disp)
    new, elite = cem.refit(dist, s, torch.tensor([1.0, 2.0, 3.0, 4.0]), bound)
    assert elite.tolist() == [0, 1]
    assert torch.allclose(new.probs[0], torch.tensor([0.5 / 3 + 0.5, 0.5 / 3, 0.5 / 3],
                                                     dtype=torch.float64))
    assert torch.allclose(new.mean[0, 0], torch.tensor([0.03, 0, 0], dtype=torch.float64))
    assert torch.equal(new.mean[0, 1], dist.mean[0, 1])            # not an elite's choice
    assert isinstance(new, Distribution)


@pytest.mark.parametrize("n_candidates", [4, 144])
def test_prob_floor_is_a_fraction_of_uniform(n_candidates):
    """After every elite picked candidate 0 (no smoothing), the others keep prob_floor of the
    uniform probability: the same exploration for 4 keys and for 144 particles."""
    cem = CEM(CEMConfig(population=4, elites=4, horizon=1, smoothing=0.0, prob_floor=0.25))
    bound = torch.full((3,), 0.1, dtype=torch.float64)
    dist = cem.initial(n_candidates, bound)
    choice = torch.zeros((4, 1), dtype=torch.long)
    s = Samples(choice, choice, torch.zeros((4, 1, 3), dtype=torch.float64))
    new, _ = cem.refit(dist, s, torch.arange(4.0, dtype=torch.float64), bound)
    C1 = n_candidates + 1
    rest = new.probs[0, 1:]
    floor = 0.25 / C1
    assert torch.allclose(rest, torch.full_like(rest, floor / (1 + (C1 - 1) * floor)))
    assert new.probs[0, 0] > 0.5 and torch.isclose(new.probs.sum(), torch.tensor(1.0,
                                                                                 dtype=torch.float64))


@pytest.mark.parametrize("kwargs", [dict(elites=0), dict(elites=40), dict(iterations=0),
                                    dict(smoothing=1.0), dict(init_std=0.0),
                                    dict(min_std=2.0), dict(horizon=0), dict(prob_floor=1.0)])
def test_bad_config_raises(kwargs):
    with pytest.raises(ValueError):
        CEMConfig(**kwargs)


@pytest.mark.parametrize("cand, match", [([], "empty"), ([1, 1], "repeated"),
                                         ([-1, 2], ">= 0")])
def test_bad_candidates_raise(cand, match):
    with pytest.raises(ValueError, match=match):
        _plan(0, CEMConfig(population=2, elites=1, iterations=1), candidates=cand)


def test_cloth_iteration_is_reproducible():
    """One CEM iteration on a 6x6 cloth with a fixed generator: same seed, same costs."""
    from dopt.rollout import RolloutConfig, RolloutService
    from dopt.tasks.pick.cloth_scene import ClothSceneConfig, make_cloth
    from dopt.tasks.pick.scene import PickPlaceTask

    scene = make_cloth(ClothSceneConfig(n=6), )
    goal = scene.positions(scene.initial_state)[::-1].copy()
    task = PickPlaceTask(scene, goal, rollout=RolloutService(scene.scene, RolloutConfig(threads=2)))
    cfg = CEMConfig(population=4, elites=2, iterations=1, horizon=1)
    runs = [CEM(cfg).plan(task, [0, 5, 30, 35], torch.Generator().manual_seed(3))
            for _ in range(2)]
    assert runs[0].cost == runs[1].cost
    assert np.array_equal(runs[0].displacements, runs[1].displacements)
    # replaying the plan reaches the batched rollout's final state bit for bit; the cost's
    # reductions differ in order between the two paths (last-bit differences)
    final = task.execute(runs[0].particles, runs[0].displacements).state
    batched = task.rollout(runs[0].particles[None], runs[0].displacements[None])
    assert np.array_equal(batched.final_states[0], final)
    assert task.cost(final) == pytest.approx(runs[0].cost, rel=1e-12, abs=0)


@pytest.mark.parametrize("stop_after", [1, 4])
def test_a_plan_resumed_from_its_progress_is_the_uninterrupted_plan(stop_after):
    cfg = CEMConfig(population=12, elites=3, iterations=6, horizon=2)
    ref = _plan(7, cfg)
    saved = []

    class Stop(Exception):
        pass

    def keep(progress):
        # through its JSON form, as a checkpoint file holds it
        saved.append(CEMProgress.from_dict(json.loads(json.dumps(progress.to_dict()))))
        if len(saved) == stop_after:
            raise Stop

    with pytest.raises(Stop):
        CEM(cfg).plan(PointsTask(), list(range(10)), torch.Generator().manual_seed(7),
                      on_progress=keep)
    task = PointsTask()
    # a fresh generator with another seed: the progress carries the generator's state
    res = CEM(cfg).plan(task, list(range(10)), torch.Generator().manual_seed(99),
                        resume=saved[-1])
    assert task.calls == cfg.iterations - stop_after
    assert np.array_equal(res.particles, ref.particles)
    assert np.array_equal(res.displacements, ref.displacements)
    assert np.array_equal(res.cost_history, ref.cost_history)
    assert np.array_equal(res.elite_history, ref.elite_history)


def test_a_resume_of_another_plan_is_refused():
    cfg = CEMConfig(population=6, elites=2, iterations=3, horizon=2)
    saved = []
    CEM(cfg).plan(PointsTask(), list(range(10)), torch.Generator().manual_seed(0),
                  on_progress=saved.append)
    with pytest.raises(ValueError, match="probs"):          # other candidates
        CEM(cfg).plan(PointsTask(), list(range(5)), torch.Generator(), resume=saved[0])
    longer = CEMConfig(population=6, elites=2, iterations=3, horizon=3)
    with pytest.raises(ValueError, match="resume does not fit"):
        CEM(longer).plan(PointsTask(), list(range(10)), torch.Generator(), resume=saved[0])
    with pytest.raises(TypeError, match="CEMProgress"):
        CEM(cfg).plan(PointsTask(), list(range(10)), torch.Generator(),
                      resume=saved[0].to_dict())
    with pytest.raises(ValueError, match="not a CEM progress record"):
        CEMProgress.from_dict({"iteration": 1})


def _saved_progress() -> dict:
    """The JSON form of a real plan's progress after its second iteration."""
    cfg = CEMConfig(population=6, elites=2, iterations=3, horizon=2)
    saved = []
    CEM(cfg).plan(PointsTask(), list(range(10)), torch.Generator().manual_seed(0),
                  on_progress=lambda p: saved.append(json.loads(json.dumps(p.to_dict()))))
    return saved[1]


def _probs(d, f):
    d["dist"]["probs"][0] = f(d["dist"]["probs"][0])


@pytest.mark.parametrize("spoil, match", [
    (lambda d: _probs(d, lambda p: [float("nan")] + p[1:]), "not all finite and >= 0"),
    (lambda d: _probs(d, lambda p: [-p[0]] + p[1:-1] + [p[-1] + 2 * p[0]]),
     "not all finite and >= 0"),
    (lambda d: _probs(d, lambda p: [2 * v for v in p]), "do not sum to 1"),
    (lambda d: d["dist"]["std"][0][0].__setitem__(0, -0.1), "a std is negative"),
    (lambda d: d["dist"]["mean"].pop(), "its means have shape"),
    (lambda d: d.__setitem__("generator_state", d["generator_state"][:100]),
     "generator state has 100 bytes"),
    (lambda d: d["generator_state"].__setitem__(0, 300), "not a list of bytes"),
    (lambda d: d.__setitem__("iteration", 2.5), "are not integers"),
    (lambda d: d.__setitem__("iteration", 3), "histories are not 3 long"),
    (lambda d: d.__setitem__("best_cost", float("nan")), "hold NaN/inf"),
    (lambda d: d["best"][2].__setitem__(0, [float("inf"), 0.0, 0.0]), "a NaN/inf move"),
    (lambda d: d["best"][0].__setitem__(0, 99), "choices outside 0..C"),
])
def test_a_bad_progress_record_is_a_value_error_before_torch_sees_it(spoil, match):
    """NaN or negative probabilities once reached torch.multinomial ("invalid multinomial
    distribution") and a short generator state Generator.set_state ("Expected a
    CPUGeneratorImplState of size 5056"); from_dict now refuses them and says why."""
    good = _saved_progress()
    CEMProgress.from_dict(good)                                    # the real one is fine
    spoil(good)
    with pytest.raises(ValueError, match="not a CEM progress record") as exc:
        CEMProgress.from_dict(good)
    assert match in str(exc.value)
