"""dopt: the runtime both planners stand on (scenes, state, batched rollouts, FD derivatives).

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

#: the version a result records (``dopt.provenance.code_version``); bump it for a
#: result-changing release. pyproject.toml reads it from here.
__version__ = "0.2.0"

#: public name -> the module that defines it; loaded on first use, so that the pure-Python
#: modules (dopt.validation, dopt.stats, dopt.provenance, dopt.cli) import without MuJoCo or torch
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
