"""Fig. 7 (a-b) rope straightening and folding by CEM: `python experiments/rope.py --goal
straighten`; --help says more (planners.pick_place.experiments.fig7)."""
import os

os.environ.setdefault("MUJOCO_GL", "egl")     # offscreen renders: read when MuJoCo loads

from planners.pick_place.experiments.fig7 import rope as main  # noqa: E402

if __name__ == "__main__":
    raise SystemExit(main())
