"""Fig. 7 (a-b) rope straightening and folding by CEM: `python experiments/rope.py --goal
straighten`; --help says more (planners.pick_place.experiments.fig7)."""
import os

os.environ.setdefault("MUJOCO_GL", "egl")     # offscreen renders: read when MuJoCo loads

from planners.pick_place.experiments import fig7  # noqa: E402


def main(argv=None) -> int:
    return fig7.main(argv, task="rope")


if __name__ == "__main__":
    raise SystemExit(main())
