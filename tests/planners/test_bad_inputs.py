"""Every bad input of the planners gets a clear error naming the argument, and no failure
passes as a result: CEM's cost handling (non-finite populations, costs of the wrong shape),
candidates, bounds and configs; the scripted policy; iLQR; DoF selection; both pipelines'
settings."""
from types import SimpleNamespace

import mujoco
import numpy as np
import pytest
import torch

from dopt import RolloutService, Scene
from dopt.costs import QuadraticCost
from planners.cem import CEM, NONE, CEMConfig, Samples
from planners.ilqr import ILQR, ILQRConfig, backward_pass
from planners.pick_place import (
    CEMPlanner,
    PickPlaceSettings,
    ScriptedPlanner,
    make_planner,
    make_problem,
    run_problem,
    solve,
)
from planners.scripted import ScriptedConfig, scripted
from planners.svr import (
    DofSelector,
    SelectionConfig,
    SVROptimiser,
    importance_sum,
    importance_svd,
)
from planners.svr_mpc import SVRMPCSettings, run_svr_mpc


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


# ----------------------------------------------------------------------------- iLQR
SLIDES = """<mujoco><option timestep="0.02" gravity="0 0 0"/><worldbody>
  <body><joint name="x" type="slide" axis="1 0 0" damping=".3"/>
    <geom size=".05" mass="1" contype="0" conaffinity="0"/></body>
  <body pos="0 1 0"><joint name="y" type="slide" axis="0 1 0" damping=".1"/>
    <geom size=".05" mass="2" contype="0" conaffinity="0"/></body></worldbody>
  <actuator><motor joint="x"/><motor joint="y"/></actuator></mujoco>"""


@pytest.fixture(scope="module")
def lq():
    scene = Scene.from_xml(SLIDES)
    d = mujoco.MjData(scene.model)
    mujoco.mj_forward(scene.model, d)
    w = np.array([1.0, 1.0, 0.1, 0.1])
    cost = QuadraticCost(scene, np.array([0.3, -0.2]), w, 10 * w, np.full(2, 1e-2))
    with RolloutService(scene) as service:
        yield ILQR(service, cost), scene.state_of(d)


def test_ilqr_iterates_on_good_input(lq):
    ilqr, x0 = lq
    step = ilqr.iterate(x0, np.zeros((8, 2)))
    assert step.cost_after < step.cost_before


def _controls(kind):
    U = np.zeros((8, 2))
    return {"nan": np.where(np.arange(8)[:, None] == 2, np.nan, U), "inf": U + np.inf,
            "nu 3": np.zeros((8, 3)), "1-D": np.zeros(8), "3-D": U[None], "T 0": U[:0],
            "str": "abc", "bool": U.astype(bool)}[kind]


@pytest.mark.parametrize("kind, error, match", [
    ("nan", ValueError, r"controls.*NaN/inf.*\(2, 0\)"),
    ("inf", ValueError, r"controls.*NaN/inf"),
    ("nu 3", ValueError, r"controls.*shape.*\(8, 3\)"),
    ("1-D", ValueError, r"controls.*shape.*\(8,\)"),
    ("3-D", ValueError, r"controls.*shape.*\(1, 8, 2\)"),
    ("T 0", ValueError, "controls must have T >= 1 rows"),
    ("str", TypeError, r"controls.*float"),
    ("bool", TypeError, r"controls.*float.*bool"),
])
def test_ilqr_controls(lq, kind, error, match):
    ilqr, x0 = lq
    with pytest.raises(error, match=match):
        ilqr.iterate(x0, _controls(kind))
    with pytest.raises(error, match=match):
        ilqr.solve(x0, _controls(kind), max_iterations=2)


@pytest.mark.parametrize("kwargs, error, match", [
    (dict(x0="nan"), ValueError, r"initial_state.*NaN/inf"),
    (dict(x0="short"), ValueError, r"initial_state.*shape"),
    (dict(dofs=[0.5]), TypeError, r"dofs.*integer"),
    (dict(dofs=[True]), TypeError, r"dofs.*integer"),
    (dict(dofs=[7]), ValueError, r"dofs.*out of range"),
    (dict(dofs=[-1]), ValueError, r"dofs.*out of range"),
    (dict(dofs=[]), ValueError, r"dofs.*empty"),
    (dict(nominal=np.zeros((3, 3))), ValueError, r"nominal.*shape.*\(3, 3\)"),
    (dict(nominal="nan"), ValueError, r"nominal.*NaN/inf"),
])
def test_ilqr_state_dofs_and_nominal(lq, kwargs, error, match):
    ilqr, x0 = lq
    kwargs = dict(kwargs)
    if kwargs.get("x0") == "nan":
        kwargs["x0"] = np.where(np.arange(len(x0)) == 1, np.nan, x0)
    elif kwargs.get("x0") == "short":
        kwargs["x0"] = x0[:-1]
    if isinstance(kwargs.get("nominal"), str):
        kwargs["nominal"] = np.full((9, len(x0)), np.nan)
    args = dict(x0=x0, controls=np.zeros((8, 2)))
    args.update(kwargs)
    with pytest.raises(error, match=match):
        ilqr.iterate(**args)


@pytest.mark.parametrize("kwargs, error, match", [
    (dict(max_iterations=0), ValueError, "max_iterations.*>= 1"),
    (dict(max_iterations=1.5), TypeError, "max_iterations.*int"),
    (dict(max_iterations=True), TypeError, "max_iterations.*int"),
    (dict(rtol=np.nan), ValueError, "rtol.*finite"),
    (dict(rtol=-1e-6), ValueError, "rtol.*>= 0"),
])
def test_ilqr_solve_options(lq, kwargs, error, match):
    ilqr, x0 = lq
    with pytest.raises(error, match=match):
        ilqr.solve(x0, np.zeros((8, 2)), **kwargs)


@pytest.mark.parametrize("kwargs, error, match", [
    (dict(mu_init=np.nan), ValueError, "ILQRConfig.mu_init.*finite"),
    (dict(mu_init="a"), TypeError, "ILQRConfig.mu_init.*number"),
    (dict(mu_max=np.inf), ValueError, "ILQRConfig.mu_max.*finite"),
    (dict(mu_factor=np.nan), ValueError, "ILQRConfig.mu_factor.*finite"),
    (dict(mu_factor=1.0), ValueError, "mu_factor must be > 1"),
    (dict(alphas=(np.nan,)), ValueError, r"ILQRConfig.alphas\[0\].*finite"),
    (dict(alphas=()), ValueError, "alphas must be in"),
    (dict(alphas=0.5), TypeError, "ILQRConfig.alphas.*tuple"),
    (dict(fd=None), TypeError, "ILQRConfig.fd must be an FDConfig"),
])
def test_ilqr_config_fields(kwargs, error, match):
    with pytest.raises(error, match=match):
        ILQRConfig(**kwargs)


def test_ilqr_constructor_and_backward_pass(lq):
    ilqr, _ = lq
    with pytest.raises(TypeError, match="config must be an ILQRConfig"):
        ILQR(ilqr.service, ilqr.cost, {})
    with pytest.raises(TypeError, match="service must be a RolloutService"):
        ILQR(None, ilqr.cost)
    z = torch.zeros
    args = (z(2, 2, 3, dtype=torch.float64), z(3, 2, dtype=torch.float64),
            z(3, 2, 2, dtype=torch.float64), z(2, 1, dtype=torch.float64),
            z(2, 1, 1, dtype=torch.float64))
    with pytest.raises(ValueError, match="mu must be a finite number >= 0"):
        backward_pass(*args, np.nan)


# ------------------------------------------------------------------- DoF selection
K = torch.randn(5, 2, 6, dtype=torch.float64, generator=torch.Generator().manual_seed(0))


def _gains(kind):
    bad = K.clone()
    bad[0, 0, 0] = np.nan
    return {"nan": bad, "odd": K[..., :5], "2-D": K[0], "int": K.to(torch.int64),
            "T 0": K[:0], "c 0": K[..., :0], "str": "K"}[kind]


@pytest.mark.parametrize("importance", [importance_sum, importance_svd])
@pytest.mark.parametrize("kind, error, match", [
    ("nan", ValueError, "K contains NaN/inf"),
    ("odd", ValueError, r"K must have shape \(T, nu, 2c\) .*\(5, 2, 5\)"),
    ("2-D", ValueError, r"K must have shape \(T, nu, 2c\)"),
    ("T 0", ValueError, r"K must have shape \(T, nu, 2c\) with T, nu, c >= 1"),
    ("c 0", ValueError, r"K must have shape \(T, nu, 2c\) with T, nu, c >= 1"),
    ("int", TypeError, "K must be a float tensor"),
    ("str", TypeError, "K must be a float tensor"),
])
def test_importance_gains(importance, kind, error, match):
    """A NaN gain used to give the DoF a NaN importance and drop it silently (sum), or a raw
    LinAlgError (svd)."""
    with pytest.raises(error, match=match):
        importance(_gains(kind))


def test_importance_takes_numpy_and_checks_g():
    torch.testing.assert_close(importance_sum(K.numpy()), importance_sum(K))
    with pytest.raises(ValueError, match="g.*>= 1"):
        importance_svd(K, 0)
    with pytest.raises(TypeError, match="g.*int"):
        importance_svd(K, 1.5)


@pytest.mark.parametrize("args, error, match", [
    (dict(nv=0), ValueError, "nv.*>= 1"),
    (dict(nv=6.5), TypeError, "nv.*int"),
    (dict(robot=[9]), ValueError, r"robot.*out of range"),
    (dict(robot=[-1]), ValueError, r"robot.*out of range"),
    (dict(robot=[0.5]), TypeError, r"robot.*integer"),
    (dict(costed=[7]), ValueError, r"costed.*out of range"),
    (dict(costed=[1.5]), TypeError, r"costed.*integer"),
    (dict(config={}), TypeError, "config must be a SelectionConfig"),
    (dict(rng=0), TypeError, "rng must be a numpy.random.Generator"),
])
def test_dof_selector(args, error, match):
    kwargs = dict(nv=6, robot=[0, 1], costed=[2], config=SelectionConfig("naive"),
                  rng=np.random.default_rng(0))
    kwargs.update(args)
    with pytest.raises(error, match=match):
        DofSelector(**kwargs)


@pytest.mark.parametrize("gains, dofs, error, match", [
    (torch.ones(5, 2, 4, dtype=torch.float64), None, ValueError,
     r"K has 4 columns for 6 dofs; it must have 2 \|dofs\| = 12"),
    (torch.full((5, 2, 12), np.nan, dtype=torch.float64), None, ValueError, "K contains NaN"),
    (torch.ones(5, 2, 4, dtype=torch.float64), [0, 9], ValueError, r"dofs.*out of range"),
])
def test_dof_selector_after(gains, dofs, error, match):
    """A NaN gain used to drop its DoF silently; K of the wrong width raised a numpy
    broadcasting error."""
    selector = DofSelector(6, [0, 1], [], SelectionConfig(), np.random.default_rng(0))
    active = selector.before()
    with pytest.raises(error, match=match):
        selector.after(gains, active if dofs is None else dofs)


@pytest.mark.parametrize("kwargs, error, match", [
    (dict(method="svr"), ValueError, "unknown method"),
    (dict(rho=np.nan), ValueError, "SelectionConfig.rho.*finite"),
    (dict(rho=-1.0), ValueError, "SelectionConfig.rho.*>= 0"),
    (dict(rho="1"), TypeError, "SelectionConfig.rho.*number"),
    (dict(rho=True), TypeError, "SelectionConfig.rho.*number"),
    (dict(theta=1.5), TypeError, "SelectionConfig.theta.*int"),
    (dict(theta=True), TypeError, "SelectionConfig.theta.*int"),
    (dict(theta=-2), ValueError, "SelectionConfig.theta.*>= 0"),
    (dict(g=1.5), TypeError, "SelectionConfig.g.*int"),
    (dict(g=0), ValueError, "SelectionConfig.g.*>= 1"),
])
def test_selection_config_fields(kwargs, error, match):
    with pytest.raises(error, match=match):
        SelectionConfig(**kwargs)


def test_svr_optimiser_arguments(lq):
    selector = DofSelector(2, [0], [], SelectionConfig(), np.random.default_rng(0))
    with pytest.raises(TypeError, match="ilqr must be a planners.ilqr.ILQR"):
        SVROptimiser(None, selector)
    with pytest.raises(TypeError, match="selector must be a DofSelector"):
        SVROptimiser(lq[0], None)


# --------------------------------------------------------------- pick-and-place pipeline
CEM_SMALL = CEMConfig(population=4, elites=1, iterations=1, horizon=1)
ROPE = dict(task="rope", goal="fold", n=20, bound=0.1, cem=CEM_SMALL)


@pytest.mark.parametrize("kwargs, error, match", [
    (dict(task="Rope"), ValueError, "unknown task 'Rope'"),
    (dict(task=None), ValueError, "unknown task None"),
    (dict(goal="diagonal"), ValueError, "unknown rope goal 'diagonal'"),
    (dict(n=2), ValueError, "PickPlaceSettings.n.*>= 3"),
    (dict(n=20.0), TypeError, "PickPlaceSettings.n.*int"),
    (dict(n=True), TypeError, "PickPlaceSettings.n.*int"),
    (dict(n="20"), TypeError, "PickPlaceSettings.n.*int"),
    (dict(bound=np.nan), ValueError, "PickPlaceSettings.bound.*finite"),
    (dict(bound=np.inf), ValueError, "PickPlaceSettings.bound.*finite"),
    (dict(bound=0.0), ValueError, "PickPlaceSettings.bound.*> 0"),
    (dict(bound=-0.1), ValueError, "PickPlaceSettings.bound.*> 0"),
    (dict(bound="0.1"), TypeError, "PickPlaceSettings.bound.*number"),
    (dict(bound=None), TypeError, "PickPlaceSettings.bound.*number"),
    (dict(bound=True), TypeError, "PickPlaceSettings.bound.*number"),
    (dict(bound=[0.1]), TypeError, "PickPlaceSettings.bound.*number"),
    (dict(threads=-1), ValueError, "PickPlaceSettings.threads.*>= 0"),
    (dict(threads=1.5), TypeError, "PickPlaceSettings.threads.*int"),
    (dict(threads=None), TypeError, "PickPlaceSettings.threads.*int"),
    (dict(cem=None), TypeError, "PickPlaceSettings.cem must be a CEMConfig"),
    (dict(cem={}), TypeError, "PickPlaceSettings.cem must be a CEMConfig"),
    (dict(scripted=None), TypeError, "PickPlaceSettings.scripted must be a ScriptedConfig"),
    (dict(selfcollide=1), TypeError, "PickPlaceSettings.selfcollide.*bool"),
    (dict(side=np.nan), ValueError, "PickPlaceSettings.side.*finite"),
    (dict(side=-0.3), ValueError, "PickPlaceSettings.side.*> 0"),
    (dict(length=0.0), ValueError, "PickPlaceSettings.length.*> 0"),
    (dict(length="x"), TypeError, "PickPlaceSettings.length.*number"),
])
def test_pick_place_settings_fields(kwargs, error, match):
    with pytest.raises(error, match=match):
        PickPlaceSettings(**{**ROPE, **kwargs})


def test_pick_place_settings_normalise_numpy_scalars():
    s = PickPlaceSettings(**{**ROPE, "n": np.int64(20), "bound": np.float32(0.1)})
    assert type(s.n) is int and type(s.bound) is float
    assert PickPlaceSettings.from_dict(s.to_dict()) == s


@pytest.mark.parametrize("d, error, match", [
    ({"task": "rope"}, ValueError, r"settings does not match PickPlaceSettings: missing "
                                   r"\['bound', 'cem', 'goal', 'n'\]"),
    ("extra", ValueError, r"unknown \['foo'\]"),
    ("cem extra", ValueError, r"settings\['cem'\] does not match CEMConfig: unknown \['pop'\]"),
    ([1, 2], TypeError, "from_dict needs a dict"),
])
def test_pick_place_settings_from_dict(d, error, match):
    good = PickPlaceSettings(**ROPE).to_dict()
    if d == "extra":
        d = {**good, "foo": 1}
    elif d == "cem extra":
        d = {**good, "cem": {**good["cem"], "pop": 3}}
    with pytest.raises(error, match=match):
        PickPlaceSettings.from_dict(d)


@pytest.mark.parametrize("call, error, match", [
    (lambda s: PickPlaceSettings.preset("rope", "diagonal"), ValueError, "no preset"),
    (lambda s: PickPlaceSettings.preset("rope", "fold", quick="yes"), TypeError,
     "quick.*bool"),
    (lambda s: make_planner("Simple", s), ValueError, "unknown method 'Simple'"),
    (lambda s: make_planner(None, s), ValueError, "unknown method None"),
    (lambda s: make_planner("simple", None), TypeError, "settings must be PickPlaceSettings"),
    (lambda s: make_planner("simple", s, -1), ValueError, "seed.*>= 0"),
    (lambda s: make_planner("simple", s, 1.5), TypeError, "seed.*int"),
    (lambda s: make_planner("simple", s, "0"), TypeError, "seed.*int"),
    (lambda s: make_planner("simple", s, True), TypeError, "seed.*int"),
    (lambda s: make_planner("simple", s, 2 ** 70), ValueError, r"seed must be < 2\*\*63"),
    (lambda s: make_problem(s, -1), ValueError, "seed.*>= 0"),
    (lambda s: make_problem({"task": "rope"}), TypeError, "settings must be PickPlaceSettings"),
    (lambda s: solve({"task": "rope"}), TypeError, "settings must be PickPlaceSettings"),
    (lambda s: solve(s, "bogus"), ValueError, "unknown method 'bogus'"),
    (lambda s: solve(s, "simple", -3), ValueError, "seed.*>= 0"),
    (lambda s: solve(s, "simple", 0.5), TypeError, "seed.*int"),
    (lambda s: solve(s, "simple", 0, on_iteration=3), TypeError, "on_iteration must be"),
    (lambda s: solve(s, "simple", 0, blowup_out=3), TypeError, "blowup_out must be"),
    (lambda s: solve(s, "simple", 0, blowup_label=7), TypeError, "blowup_label must be"),
    (lambda s: run_problem(None, make_planner("simple", s)), TypeError,
     "problem must be a Problem"),
    (lambda s: CEMPlanner(s.cem, "every", 0), ValueError, "candidates must be one of"),
    (lambda s: CEMPlanner(None, "keys", 0), TypeError, "config must be a CEMConfig"),
    (lambda s: CEMPlanner(s.cem, "keys", -1), ValueError, "seed.*>= 0"),
    (lambda s: ScriptedPlanner(None), TypeError, "config must be a ScriptedConfig"),
])
def test_pick_place_calls(call, error, match):
    """Each raises before any scene is built (a float seed used to run a whole trial)."""
    with pytest.raises(error, match=match):
        call(PickPlaceSettings(**ROPE))


# --------------------------------------------------------------------- SVR-MPC pipeline
@pytest.mark.parametrize("kwargs, error, match", [
    (dict(rho=-1.0), ValueError, "SVRMPCSettings.rho.*>= 0"),
    (dict(rho=np.nan), ValueError, "SVRMPCSettings.rho.*finite"),
    (dict(rho="1"), TypeError, "SVRMPCSettings.rho.*number"),
    (dict(theta=-1), ValueError, "SVRMPCSettings.theta.*>= 0"),
    (dict(theta=1.5), TypeError, "SVRMPCSettings.theta.*int"),
    (dict(theta=True), TypeError, "SVRMPCSettings.theta.*int"),
    (dict(control_noise=-0.1), ValueError, "SVRMPCSettings.control_noise.*>= 0"),
    (dict(control_noise=np.nan), ValueError, "SVRMPCSettings.control_noise.*finite"),
    (dict(control_noise="a"), TypeError, "SVRMPCSettings.control_noise.*number"),
    (dict(slowdown=0.0), ValueError, "SVRMPCSettings.slowdown.*> 0"),
    (dict(slowdown=np.nan), ValueError, "SVRMPCSettings.slowdown.*finite"),
    (dict(timeout=0), ValueError, "SVRMPCSettings.timeout.*>= 1"),
    (dict(timeout=1.5), TypeError, "SVRMPCSettings.timeout.*int"),
    (dict(feedback=1), TypeError, "SVRMPCSettings.feedback.*bool"),
    (dict(synchronous="yes"), TypeError, "SVRMPCSettings.synchronous.*bool"),
    (dict(threads=-1), ValueError, "SVRMPCSettings.threads.*>= 0"),
    (dict(threads=1.5), TypeError, "SVRMPCSettings.threads.*int"),
    (dict(task="Clutter"), ValueError, "unknown task 'Clutter'"),
    (dict(method=None), ValueError, "unknown method None"),
])
def test_svr_mpc_settings_fields(kwargs, error, match):
    with pytest.raises(error, match=match):
        SVRMPCSettings(**kwargs)


@pytest.mark.parametrize("settings, seed, error, match", [
    ({"task": "clutter"}, 0, TypeError, "settings must be SVRMPCSettings"),
    (SVRMPCSettings(), -1, ValueError, "seed.*>= 0"),
    (SVRMPCSettings(), 0.5, TypeError, "seed.*int"),
])
def test_run_svr_mpc_arguments(settings, seed, error, match):
    with pytest.raises(error, match=match):
        run_svr_mpc(settings, seed)


@pytest.mark.parametrize("optimiser, error, match", [
    ("nope", ValueError, "unknown optimiser 'nope'; choose from .*'svr'"),
    (3, TypeError, "optimiser must be a name of OPTIMISERS or a factory.*got int"),
    (None, TypeError, "optimiser must be a name of OPTIMISERS or a factory.*got NoneType"),
    (lambda context: object(), TypeError, "'custom': its factory returned a 'object', which "
                                          r"has no optimise\(state, plan\)"),
])
def test_run_svr_mpc_optimiser(optimiser, error, match):
    settings = SVRMPCSettings(method="baseline", synchronous=True, timeout=1, threads=1)
    with pytest.raises(error, match=match):
        run_svr_mpc(settings, 0, optimiser=optimiser)


@pytest.mark.parametrize("name, factory, error, match", [
    ("Shooting", print, ValueError, "'Shooting' must be lower case letters"),
    ("random-shooting", print, ValueError, "must be lower case letters, digits and _"),
    ("svr", print, ValueError, "'svr' is taken"),
    ("baseline", print, ValueError, "'baseline' is taken"),
    (3, print, TypeError, "optimiser name must be a str, got int"),
    ("shooting", "not callable", TypeError, "optimiser factory must be callable.*got str"),
])
def test_register_optimiser_arguments(name, factory, error, match):
    from planners.svr_mpc import OPTIMISERS, register_optimiser

    with pytest.raises(error, match=match):
        register_optimiser(name, factory)
    assert "shooting" not in OPTIMISERS


def test_an_optimiser_is_registered_once_unless_replaced():
    from planners.svr_mpc import OPTIMISERS, register_optimiser, svr_optimiser

    register_optimiser("twice", svr_optimiser)
    try:
        with pytest.raises(ValueError, match="'twice' is registered already"):
            register_optimiser("twice", svr_optimiser)
        register_optimiser("twice", print, replace=True)
        assert OPTIMISERS["twice"] is print
    finally:
        del OPTIMISERS["twice"]


@pytest.mark.parametrize("optimiser, error, match", [
    ("nope", ValueError, "unknown optimiser 'nope'"),
    (print, TypeError, "optimiser must be a name of OPTIMISERS .*params are JSON"),
])
def test_trial_params_name_a_registered_optimiser(optimiser, error, match):
    from planners.svr_mpc import trial_params

    with pytest.raises(error, match=match):
        trial_params(SVRMPCSettings(), 0, optimiser)
    with pytest.raises(TypeError, match="settings must be SVRMPCSettings"):
        trial_params({"task": "clutter"}, 0)


@pytest.mark.parametrize("kwargs, error, match", [
    (dict(fd="centred"), ValueError, r"Derivatives.fd must be one of \['central', 'forward'\]"),
    (dict(keypoints="skip5"), ValueError, "Derivatives.keypoints must be one of"),
    (dict(keypoints="skip", fd_skip=0), ValueError, "Derivatives.fd_skip must be >= 1"),
    (dict(keypoints="skip", fd_skip=2.0), TypeError, "Derivatives.fd_skip must be an int"),
    (dict(fd_skip=5), ValueError, "fd_skip must be 1 with keypoints 'every'"),
    (dict(keypoints="adaptive", fd_skip=3), ValueError, "must be 1 with keypoints 'adaptive'"),
    (dict(box_qp=1), TypeError, "Derivatives.box_qp must be a bool"),
])
def test_derivatives_fields(kwargs, error, match):
    from planners.svr_mpc import Derivatives

    with pytest.raises(error, match=match):
        Derivatives(**kwargs)


def test_make_problem_checks_the_sizes_its_settings_imply_before_building_anything():
    """A cloth of 100000 x 100000 particles once ended in a MemoryError of numpy; the
    settings' sizes are checked first, naming the setting (``planners.pick_budget``)."""
    from dataclasses import replace

    from planners.pick_budget import BudgetError, budget_problem

    cloth = PickPlaceSettings.preset("cloth", "diagonal")
    with pytest.raises(BudgetError, match=r"on 10000000000 particles\) needs about .* more "
                                          r"than this machine's memory") as exc:
        make_problem(replace(cloth, n=100_000))
    assert exc.value.field == "n"
    rope = PickPlaceSettings.preset("rope", "fold")
    assert budget_problem(rope) is None
    assert budget_problem(replace(rope, bound=1e9)).field == "bound"
    assert budget_problem(replace(rope, picker_speed=1e-9)).field == "picker_speed"
    assert budget_problem(replace(rope, cem=replace(rope.cem, population=10**9))).field == \
        "cem.population"
