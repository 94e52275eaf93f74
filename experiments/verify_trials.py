"""Rerun a sample of an MPC result's committed trials at today's code to the last bit:
`python experiments/verify_trials.py docs/results/NAME.json --sample 10`; --help says more
(``planners.svr_mpc.experiments.verify_trials``)."""

import sys

from planners.svr_mpc.experiments.verify_trials import main

if __name__ == "__main__":
    sys.exit(main())
