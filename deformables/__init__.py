"""Goal shapes of ropes and cloth and their simplification to key particles (no MuJoCo).

Imports neither MuJoCo nor torch, and of dopt only its pure-Python dopt.validation,
dopt.lab.provenance, dopt.lab.cli and dopt.blas (first: it pins OpenBLAS's kernels). Modules:

    goals.py         rope and cloth goal shapes registered by name (GOALS, GOAL_SEQUENCES),
                     flexcomp-compatible numbering and triangulations
    reduction.py     Alg. 1: grow the model until its error is under the threshold -> KeyParticles
    rope.py          the rope's polyline (dynamic-programme breakpoints + a cvxpy QP);
                     segmentation.py its optimal segmentation in blocks
    cloth.py         the cloth's pipeline (ClothConfig; ClothConfig.paper(): the paper's), over
                     decimation.py (pymeshlab QECD with restarts), distance.py (exact symmetric
                     Hausdorff), mesh.py (canonical triangulation, geodesic dedupe),
                     layers.py (stacking axis and layer gap), panels.py (rigid panels of noisy
                     folds), frame.py (the goal's own frame), remesh.py (a rectangular
                     goal resampled on a grid of its rest sheet: keys free of triangulation)
    validation.py    goal checks and repairs
    authors.py       the paper authors' own cloth goals (their SoftGym / FleX files, read from
                     outside the project) and their key particles beside ours
    bench.py         python -m deformables.bench: timings, the paper's scale, paper vs default
"""
import dopt.blas  # noqa: F401  first: it pins OpenBLAS's kernels before numpy loads

from .cloth import ClothConfig, cloth_key_particles
from .goals import (
    GOAL_SEQUENCES,
    GOALS,
    ClothGoal,
    RopeGoal,
    cloth_diagonal,
    cloth_flat,
    cloth_reflective,
    cloth_side,
    cloth_underneath,
    goal_sequence,
    grid_faces,
    make_goal,
    rope_crossed_triangle,
    rope_crumpled,
    rope_straight,
)
from .reduction import KeyParticles
from .rope import RopeConfig, rope_key_particles

__all__ = [
    "ClothConfig", "ClothGoal", "GOALS", "GOAL_SEQUENCES", "KeyParticles", "RopeConfig",
    "RopeGoal", "cloth_diagonal", "cloth_flat", "cloth_key_particles", "cloth_reflective",
    "cloth_side", "cloth_underneath", "goal_sequence", "grid_faces", "make_goal",
    "rope_crossed_triangle", "rope_crumpled", "rope_key_particles", "rope_straight",
]
