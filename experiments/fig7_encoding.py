"""The gain against the candidate count in the authors' drag encoding:
`python experiments/fig7_encoding.py --goal diagonal`; --help says more
(planners.pick_place.experiments.encoding)."""
from planners.pick_place.experiments.encoding import main

if __name__ == "__main__":
    raise SystemExit(main())
