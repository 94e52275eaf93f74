"""The gain of key particles against the particle count (Sec. V):
`python experiments/fig7_scaling.py --goal diagonal`; --help says more
(planners.pick_place.experiments.scaling)."""
from planners.pick_place.experiments.scaling import main

if __name__ == "__main__":
    raise SystemExit(main())
