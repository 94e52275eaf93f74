"""Key particles of the paper's goals (Fig. 4, Sec. IV-C.1):
`python experiments/key_particles.py --task all`; --help says more
(planners.pick_place.experiments.key_particles)."""
from planners.pick_place.experiments.key_particles import main

if __name__ == "__main__":
    raise SystemExit(main())
