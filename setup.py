"""Only the optional C extension lives here; everything else is in pyproject.toml.

dopt/_rollout_kernels.c holds the C loops behind RolloutService (reduced FD, feedback
rollouts). It is optional: without a C compiler the install still succeeds and RolloutService
uses mujoco.batch.Batch (dopt/kernels.py says why in the log). The file declares the MuJoCo
functions it calls, so no MuJoCo headers or libraries are needed at build time.
"""

from setuptools import Extension, setup

setup(ext_modules=[Extension("dopt._rollout_kernels", ["dopt/_rollout_kernels.c"],
                             extra_compile_args=["-O2", "-std=c11"], optional=True)])
