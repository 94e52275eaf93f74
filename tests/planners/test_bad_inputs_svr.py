"""Every bad input of the planners' state-vector-reduction side gets a clear error naming the
argument: iLQR and DoF selection (the SVR-MPC pipeline's: tests/planners/svr_mpc/test_bad_inputs.py;
the pick-and-place sizes: tests/planners/pick_place/test_bad_inputs.py)."""

import mujoco
import numpy as np
import pytest
import torch

from dopt import RolloutService, Scene
from dopt.costs import QuadraticCost
from planners.ilqr import ILQR, ILQRConfig, backward_pass
from planners.svr import (
    DofSelector,
    SelectionConfig,
    SVROptimiser,
    importance_sum,
    importance_svd,
)

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
    (dict(derivatives=None), TypeError, "ILQRConfig.derivatives must be a Derivatives"),
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
