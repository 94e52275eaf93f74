"""The C-kernel route of RolloutService: derivatives and feedback rollouts in the C loops of
``dopt.kernels`` (``_rollout_kernels.c``), open-loop rollouts in ``mujoco.batch.Batch``.

Derivatives skip the stages a perturbation leaves unchanged, as ``mjd_transitionFD`` does;
feedback rollouts need no Python per step. Both give the numbers of the Batch route
(``dopt.rollout_batch``, tested). Open-loop rollouts are inherited from it unchanged:
``Batch.rollout`` already runs them without Python per step.
"""

from __future__ import annotations

import numpy as np

from dopt import kernels
from dopt.errors import UnstableRolloutError
from dopt.rollout_batch import BatchRoute
from dopt.stability import Stability


class CRoute(BatchRoute):
    """BatchRoute with ``feedback`` and ``derivatives`` in ``kernels.Kernels`` (``threads``
    MjData and a thread pool, made on first use). Needs ``kernels.load()`` to succeed."""

    def __init__(self, scene, threads: int):
        super().__init__(scene, threads)
        self._kernels: kernels.Kernels | None = None

    def close(self) -> None:
        """Shut the kernels' thread pool down and drop their MjData, then the Batch."""
        if self._kernels is not None:
            self._kernels.close()
            self._kernels = None
        super().close()

    def feedback(self, x0: np.ndarray, u: np.ndarray, ref: np.ndarray, K: np.ndarray,
                 C: np.ndarray) -> tuple[np.ndarray, np.ndarray, Stability]:
        """As ``BatchRoute.feedback``: x0 (ns,), u (P, T, nu), ref (T, ns), K (T, nu, 2|C|)
        -> (states (P, T+1, ns), applied controls (P, T, nu), the verdict)."""
        out, applied, stats, bad = self._kernel().feedback(x0, u, ref, K, C, self.lo, self.hi)
        mon = self.scene.monitor
        col = {name: i for i, name in enumerate(kernels.STATS)}
        step, reason = np.full(len(u), -1), [""] * len(u)
        for t, p, code, names in bad:
            step[p] = t
            bound = kernels.FAULT_BOUNDS.get(code)
            reason[p] = (mon.reason(bound, stats[p, col["value"]], int(stats[p, col["index"]]))
                         if bound else names[0])
            if code == kernels.FAULT_MUJOCO_ERROR:   # as the Batch route: held before the step
                out[p, t + 1:] = out[p, t]
            else:                                    # as the Batch route: stopped where it failed
                out[p, t + 2:] = out[p, t + 1]
            applied[p, t + 1:] = applied[p, t]
        verdict = Stability(step >= 0, step, tuple(reason), stats[:, col["speed"]].copy(),
                            stats[:, col["penetration"]].copy(), stats[:, col["strain"]].copy(),
                            stats[:, col["capped"]].astype(int), stats[:, col["energy"]].copy())
        return out, applied, verdict

    def derivatives(self, x: np.ndarray, C: np.ndarray, eps: float,
                    centered: bool) -> np.ndarray:
        """As ``BatchRoute.derivatives``: x (T, ns), C (|C|,) -> F (T, 2|C|, 2|C| + nu)."""
        F, bad = self._kernel().fd(x, C, eps, centered, self.lo, self.hi)
        if bad:
            t, k, names = bad[0]
            raise UnstableRolloutError(k, t, names[0], f"derivatives t={t} perturbation={k}")
        return F

    def _kernel(self) -> kernels.Kernels:
        if self._kernels is None:
            self._kernels = kernels.Kernels(self.model, self.scene.layout, self.threads,
                                            self.scene.monitor)
        return self._kernels
