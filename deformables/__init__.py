"""Goal shapes of ropes and cloth and their simplification to key particles (no MuJoCo)."""
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
