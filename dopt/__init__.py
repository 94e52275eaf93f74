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

from dopt.errors import RolloutError, UnstableRolloutError
from dopt.rollout import (
                          Derivatives,
                          FDConfig,
                          RolloutConfig,
                          RolloutResult,
                          RolloutService,
                          Trajectory,
)
from dopt.scene import Scene
from dopt.state import INTEGRATION, StateLayout, get_state, set_state

__all__ = ["Derivatives", "FDConfig", "INTEGRATION", "RolloutConfig", "RolloutError",
           "RolloutResult", "RolloutService", "Scene", "StateLayout", "Trajectory",
           "UnstableRolloutError", "get_state", "set_state"]
