"""Goal shapes of ropes and cloth and their simplification to key particles (no MuJoCo)."""
