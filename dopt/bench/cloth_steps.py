"""Bench of a cloth step across resolutions: where MuJoCo spends it (its own timers), per
physics preset, and the warnings each size prints.

Per (preset, n): the scene is built and settled (``make_cloth``), then one pick-and-place
action (the corner particle 0 lifted and moved 10 cm toward the sheet's centre) is stepped
with ``mj_step``; MuJoCo's timers give ms per step for the step and its stages (position: of
which kinematics, inertia, collision, constraint making; velocity; actuation; constraint solve;
"other": the rest of the step, which holds the discrete integrator's implicit solve), and the
warnings are listed: MuJoCo's counters of the stepped MjData by name, and every message
MuJoCo's warning hook received while the scene was built, settled and stepped (e.g. "Flex
stiffness is too ill-conditioned ...") with its count.
"""

from __future__ import annotations

import contextlib
import re
import time
from collections import Counter

import mujoco
import numpy as np

from dopt.state import INTEGRATION

#: MuJoCo timer -> the name in the result (ms per step)
TIMERS = {"mjTIMER_STEP": "step", "mjTIMER_POSITION": "position",
          "mjTIMER_POS_KINEMATICS": "kinematics", "mjTIMER_POS_INERTIA": "inertia",
          "mjTIMER_POS_COLLISION": "collision", "mjTIMER_POS_MAKE": "make_constraint",
          "mjTIMER_VELOCITY": "velocity", "mjTIMER_ACTUATION": "actuation",
          "mjTIMER_CONSTRAINT": "constraint_solve"}


#: settings tried on top of a preset (``--variants``): name -> the ClothSceneConfig fields
#: changed. The flex solve of the discrete integrator (M + K with a per-vertex block
#: preconditioner) runs at most ``iterations`` iterations to ``tolerance``; these probe which
#: of the step, the mass, the stiffness and the solver budget decide whether it converges and
#: what a step costs (Newton: the solver MuJoCo 4.0's tuning guide recommends for cloth).
VARIANTS: dict[str, dict] = {
    "iterations 100": {"iterations": 100},
    "iterations 300": {"iterations": 300},
    "tolerance 1e-3": {"tolerance": 1e-3},
    "dt 5 ms": {"timestep": 0.005},
    "dt 1 ms": {"timestep": 0.001, "settle": 0.02},
    "mass x10": {"mass": 1.0},
    "mass x1000": {"mass": 100.0},
    "young / 10": {"young": 5e3},
    "no bending": {"bending": False},
    "Newton": {"solver": "Newton"},
    "iterations 15": {"iterations": 15},
    "tolerance 1e-5": {"tolerance": 1e-5},
    "dt 10 ms": {"timestep": 0.01},
}

#: the relative residual MuJoCo's warning gives when the flex solve ran out of iterations
_RESIDUAL = re.compile(r"relative residual of ([0-9.eE+-]+)")


def bench_cloth_steps(sizes: list[int], presets: list[str],
                      variants: list[str] = ()) -> list[dict]:
    """One row per (preset, size), then per (variant on the first preset, size): ms per step
    by stage, steps and ms per action, warnings, and the largest relative residual of the flex
    solve MuJoCo reported (None: it never ran out of iterations)."""
    from dopt.tasks.pick.cloth_scene import ClothSceneConfig, make_cloth
    from dopt.tasks.pick.picker import CONTROL_SPEC

    unknown = [v for v in variants if v not in VARIANTS]
    if unknown:
        raise ValueError(f"unknown cloth-steps variants {unknown}; choose from {list(VARIANTS)}")
    runs = [(p, None) for p in presets] + [(presets[0], v) for v in variants]
    rows = []
    for preset, variant in runs:
        for n in sizes:
            config = ClothSceneConfig.physics(preset, n=n, **VARIANTS.get(variant, {}))
            with mujoco_messages() as messages:
                t0 = time.perf_counter()
                scene = make_cloth(config)
                build = time.perf_counter() - t0
                row = _step_action(scene, CONTROL_SPEC)
            residuals = [float(x) for text in messages for x in _RESIDUAL.findall(text)]
            rows.append({"preset": preset, "variant": variant, "n": n, "particles": n * n,
                         "fields": {k: getattr(config, k) for k in
                                    ("young", "mass", "bending", "timestep", "solver",
                                     "iterations", "tolerance", "selfcollide")},
                         **row, "build_s": build, "messages": dict(messages),
                         "flex_solve_residual_max": max(residuals, default=None)})
    return rows


@contextlib.contextmanager
def mujoco_messages():
    """Collect every message MuJoCo's warning hook receives inside the block: yields a
    Counter {message: times}; the hook is restored to none on exit."""
    messages: Counter = Counter()
    mujoco.set_mju_user_warning(lambda text: messages.update([text.strip()]))
    try:
        yield messages
    finally:
        mujoco.set_mju_user_warning(None)


def action_rows(scene) -> np.ndarray:
    """The benched action's control rows, (steps_per_action, ncontrol) for CONTROL_SPEC:
    corner particle 0 moved 10 cm toward the sheet's centre and 5 cm up."""
    start = scene.positions(scene.initial_state)
    toward = -start[0, :2] / max(float(np.linalg.norm(start[0, :2])), 1e-9)
    return scene.picker.encode(np.array([[0]]), np.array([[[*(0.1 * toward), 0.05]]]))[0]


def _step_action(scene, control_spec, d: mujoco.MjData | None = None) -> dict:
    """ms per step by stage, steps and ms per action and warning counters of one action,
    stepped from the scene's initial state in ``d`` (a new MjData if None)."""
    m = scene.model
    d = mujoco.MjData(m) if d is None else d
    mujoco.mj_setState(m, d, scene.initial_state, INTEGRATION)
    mujoco.mj_forward(m, d)
    rows_u = action_rows(scene)
    for i in range(len(d.timer)):
        d.timer[i].duration, d.timer[i].number = 0.0, 0
    for u in rows_u:
        mujoco.mj_setState(m, d, u, control_spec)
        mujoco.mj_step(m, d)
    ms = {name: _ms(d, timer) for timer, name in TIMERS.items()}
    ms["other"] = ms["step"] - (ms["position"] + ms["velocity"] + ms["actuation"]
                                + ms["constraint_solve"])
    return {"ms_per_step": ms, "steps_per_action": len(rows_u),
            "ms_per_action": ms["step"] * len(rows_u),
            "warnings": {mujoco.mjtWarning(i).name: int(w.number)
                         for i, w in enumerate(d.warning) if w.number}}


def _ms(d: mujoco.MjData, timer: str) -> float:
    t = d.timer[getattr(mujoco.mjtTimer, timer)]
    return 1e3 * t.duration / max(t.number, 1)
