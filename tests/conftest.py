"""Session-wide test settings: MuJoCo renders offscreen with EGL (as ``make test`` sets), fixed
before any test imports mujoco, which picks its GL backend at import; and the fixture that runs
a test on both routes of the rollout service."""

import os

import pytest

import dopt  # noqa: F401  before any test loads numpy: the pinned OpenBLAS kernels (dopt/blas.py)

os.environ.setdefault("MUJOCO_GL", "egl")


@pytest.fixture(params=[True, False], ids=["c-kernels", "batch"])
def c_kernels(request):
    """Both routes of RolloutService's derivatives and feedback rollouts: dopt.kernels' C loops
    (skipped, with the reason, where they were not built) and mujoco.batch.Batch."""
    if request.param:
        from dopt import kernels
        if kernels.load() is None:
            pytest.skip(f"C kernels not built: {kernels.load_error()}")
    return request.param
