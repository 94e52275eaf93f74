"""Fig. 7 (c-f) cloth folds by CEM over key particles: `python experiments/cloth_fold.py --goal
diagonal`; --help says more (planners.pick_place.experiments.fig7)."""
import os

os.environ.setdefault("MUJOCO_GL", "egl")     # offscreen renders: read when MuJoCo loads

from planners.pick_place.experiments.fig7 import cloth as main  # noqa: E402

if __name__ == "__main__":
    raise SystemExit(main())
