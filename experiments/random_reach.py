"""Why CEM(Random) wins or loses a fold (nothing simulated):
`python experiments/random_reach.py RUN_FOLDER --out OUT`; --help says more
(planners.pick_place.experiments.random_reach)."""
from planners.pick_place.experiments.random_reach import main

if __name__ == "__main__":
    raise SystemExit(main())
