"""dopt: the runtime both planners stand on (scenes, state, batched rollouts, FD derivatives).

Glossary of shape letters used in every docstring:
    P   population / number of rollouts in a batch
    T   horizon (number of control steps)
    N   particles (rope / cloth vertices)
    nq, nv, nu   MuJoCo position, velocity and control sizes
    ns  size of one mjSTATE_INTEGRATION state row
    C   active DoF set (indices into qvel); |C| its size, nx_C = 2|C| the reduced tangent state
"""
