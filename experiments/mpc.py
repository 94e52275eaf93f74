"""Table 1 of the state-vector-reduction paper, MPC with iLQR-SVR against its baselines:
`python experiments/mpc.py --quick` (also `dopt-mpc`); --help says more. The experiment is
planners.svr_mpc.experiments.table1."""
import os

os.environ.setdefault("MUJOCO_GL", "egl")   # offscreen renders; read when mujoco is imported

from planners.svr_mpc.experiments.table1 import main  # noqa: E402

if __name__ == "__main__":
    raise SystemExit(main())
