"""Every bad input of the SVR-MPC pipeline gets a clear error naming the argument: its
settings, run_svr_mpc's arguments and optimiser, the optimiser registry, a trial's params and
the derivative options (iLQR's and DoF selection's own: tests/planners/test_bad_inputs_svr.py)."""

import numpy as np
import pytest

from planners.svr_mpc import SVRMPCSettings, run_svr_mpc


@pytest.mark.parametrize("kwargs, error, match", [
    (dict(rho=-1.0), ValueError, "DofSelection.rho.*>= 0"),
    (dict(rho=np.nan), ValueError, "DofSelection.rho.*finite"),
    (dict(rho="1"), TypeError, "DofSelection.rho.*number"),
    (dict(theta=-1), ValueError, "DofSelection.theta.*>= 0"),
    (dict(theta=1.5), TypeError, "DofSelection.theta.*int"),
    (dict(theta=True), TypeError, "DofSelection.theta.*int"),
    (dict(control_noise=-0.1), ValueError, "Execution.control_noise.*>= 0"),
    (dict(control_noise=np.nan), ValueError, "Execution.control_noise.*finite"),
    (dict(control_noise="a"), TypeError, "Execution.control_noise.*number"),
    (dict(slowdown=0.0), ValueError, "Timing.slowdown.*> 0"),
    (dict(slowdown=np.nan), ValueError, "Timing.slowdown.*finite"),
    (dict(timeout=0), ValueError, "Execution.timeout.*>= 1"),
    (dict(timeout=1.5), TypeError, "Execution.timeout.*int"),
    (dict(feedback=1), TypeError, "Execution.feedback.*bool"),
    (dict(synchronous="yes"), TypeError, "Timing.synchronous.*bool"),
    (dict(threads=-1), ValueError, "SVRMPCSettings.threads.*>= 0"),
    (dict(threads=1.5), TypeError, "SVRMPCSettings.threads.*int"),
    (dict(task="Clutter"), ValueError, "unknown task 'Clutter'"),
    (dict(method=None), ValueError, "unknown method None"),
    (dict(islands="no"), TypeError, "PushScene.islands.*bool"),
    (dict(push_tail=0), TypeError, "PushStart.push_tail.*bool"),
    (dict(clocks="model"), TypeError, "SVRMPCSettings has no setting 'clocks'"),
])
def test_svr_mpc_settings_fields(kwargs, error, match):
    """Each bad setting, by its flat name (a trial's params), is refused by its group."""
    with pytest.raises(error, match=match):
        SVRMPCSettings.from_params(kwargs)
    with pytest.raises(error, match=match):
        SVRMPCSettings().with_params(**kwargs)


@pytest.mark.parametrize("kwargs, match", [
    (dict(timing={"clock": "model"}), "SVRMPCSettings.timing must be a Timing"),
    (dict(selection="svr-sum"), "SVRMPCSettings.selection must be a DofSelection"),
    (dict(derivatives=None), "SVRMPCSettings.derivatives must be a Derivatives"),
])
def test_svr_mpc_settings_groups_have_their_types(kwargs, match):
    with pytest.raises(TypeError, match=match):
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
    settings = SVRMPCSettings.from_params(dict(method="baseline", synchronous=True, timeout=1,
                                               threads=1))
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
