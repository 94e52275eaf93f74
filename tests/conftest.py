"""Session-wide test settings: MuJoCo renders offscreen with EGL (as ``make test`` sets), fixed
before any test imports mujoco, which picks its GL backend at import."""

import os

os.environ.setdefault("MUJOCO_GL", "egl")
