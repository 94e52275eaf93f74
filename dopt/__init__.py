"""dopt: the runtime both planners stand on (scenes, state, batched rollouts, FD derivatives).

It knows MuJoCo and no planner (docs/ARCHITECTURE.md has the map and the rule). Modules:

    state.py, scene.py      mjSTATE_INTEGRATION rows (StateLayout, Tangent); Scene: a compiled
                            model with named DoF groups and its stability bounds
    rollout.py              RolloutService: batched rollouts, feedback rollouts, reduced FD
                            derivatives; its routes rollout_batch.py (mujoco.batch) and
                            rollout_c.py over kernels.py (the C loops of _rollout_kernels.c)
    stability.py, errors.py the verdict every rollout gets; RolloutError, UnstableRolloutError
    blowup.py               blow-up captures: the last states of a flagged executed rollout,
                            written for dopt-view (which reads them; the runtime no viewer)
    costs.py, mpc.py        QuadraticCost + residual terms (Eq. 2-3); asynchronous MPC (Alg. 1)
                            with its real, virtual and model clocks, mpc_cost (Eq. 5)
    validation.py, atomic.py argument checks; the one atomic writer of files; the OpenBLAS
    blas.py                 kernels, pinned at import (the base modules every room, the lab's
                            included, may import)
    lab/                    the research machinery, apart from the runtime: sweeps, trial
                            files, provenance, statistics, command lines (dopt.lab)
    render.py               offscreen images of states (numpy arrays; no task knowledge)
    tasks/                  the two papers' tasks: registries in tasks/__init__.py, the wings
                            tasks/pick and tasks/push, the shared arm tasks/panda.py
    view/, bench/           dopt-view (the browser viewer); python -m dopt.bench

Glossary of shape letters used in every docstring:
    P   population / number of rollouts in a batch
    T   horizon (number of control steps)
    H   horizon in pick actions (CEM); K steps per action
    N   particles (rope / cloth vertices)
    nq, nv, nu   MuJoCo position, velocity and control sizes
    ns  size of one mjSTATE_INTEGRATION state row
    C   active DoF set (indices into qvel); |C| its size, 2|C| the reduced tangent state
"""

import importlib

from . import blas as _blas

_blas.pin()      # before anything loads numpy: the same BLAS bits on any machine (dopt/blas.py)

#: the version a result records (``dopt.lab.provenance.code_version``); bump it for a
#: result-changing release. pyproject.toml reads it from here.
__version__ = "0.2.0"

#: public name -> the module that defines it; loaded on first use, so that the pure-Python
#: modules (dopt.validation, dopt.atomic, dopt.lab) import without MuJoCo or torch
_EXPORTS = {
    "RolloutError": "dopt.errors", "UnstableRolloutError": "dopt.errors",
    "Derivatives": "dopt.rollout", "FDConfig": "dopt.rollout", "RolloutConfig": "dopt.rollout",
    "RolloutResult": "dopt.rollout", "RolloutService": "dopt.rollout",
    "Trajectory": "dopt.rollout", "Scene": "dopt.scene", "INTEGRATION": "dopt.state",
    "StateLayout": "dopt.state", "get_state": "dopt.state", "set_state": "dopt.state",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name in _EXPORTS:
        value = getattr(importlib.import_module(_EXPORTS[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'dopt' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_EXPORTS))
