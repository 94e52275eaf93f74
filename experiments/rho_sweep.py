"""Fig. 4 of the state-vector-reduction paper, MPC cost and mean |C| against rho per theta:
`python experiments/rho_sweep.py --quick --rhos 1,10 --thetas 0`; --help says more. The
experiment is planners.svr_mpc.experiments.fig4."""
from planners.svr_mpc.experiments.fig4 import main

if __name__ == "__main__":
    raise SystemExit(main())
