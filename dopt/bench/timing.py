"""Small timing helpers shared by the benches."""

from __future__ import annotations

import time
from collections.abc import Callable

import mujoco
import numpy as np

from dopt.state import INTEGRATION


def best_wall(fn: Callable[[], object], repeats: int) -> float:
    """Minimum wall time in seconds of ``fn()`` over ``repeats`` calls (after one warm-up)."""
    fn()
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return float(best)


def mj_step_seconds(model: mujoco.MjModel, state: np.ndarray, controls: np.ndarray,
                    repeats: int) -> float:
    """Seconds of one plain ``mj_step`` on one thread: the physical limit's unit.

    Steps a single MjData from ``state`` (ns,) through ``controls`` (T, nu), or through each of
    several control sequences (S, T, nu) in turn (the average over a sample of the workload);
    best of repeats.
    """
    data = mujoco.MjData(model)
    seqs = controls[None] if controls.ndim == 2 else controls

    def run():
        for seq in seqs:
            mujoco.mj_setState(model, data, state, INTEGRATION)
            for u in seq:
                data.ctrl[:] = u
                mujoco.mj_step(model, data)

    return best_wall(run, repeats) / (seqs.shape[0] * seqs.shape[1])
