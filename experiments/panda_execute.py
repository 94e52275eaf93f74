"""Sec. IV-D, a Panda executes CEM(Simple)'s cloth plans:
`python experiments/panda_execute.py --trials 3`; --help says more
(planners.pick_place.experiments.panda_execute)."""
import os

os.environ.setdefault("MUJOCO_GL", "egl")     # offscreen renders: read when MuJoCo loads

from planners.pick_place.experiments.panda_execute import main  # noqa: E402

if __name__ == "__main__":
    raise SystemExit(main())
