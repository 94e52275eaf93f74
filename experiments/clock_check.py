"""The virtual clock against the real one on the same trials:
`python experiments/clock_check.py --quick`; --help says more. The experiment is
planners.svr_mpc.experiments.clock_check."""
# compare: resummarize.py reads it through this script until it moves
from planners.svr_mpc.experiments.clock_check import compare, main  # noqa: F401

if __name__ == "__main__":
    raise SystemExit(main())
