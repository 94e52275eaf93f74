"""Exceptions raised by the rollout service."""

from __future__ import annotations


class RolloutError(RuntimeError):
    """MuJoCo raised an error inside a batched call (bad model data, out of memory, ...)."""


class UnstableRolloutError(RolloutError):
    """A simulation went unstable: NaN/inf state or a MuJoCo warning (bad qpos/qvel/qacc, ...).

    Attributes:
        rollout: index of the offending rollout in the batch (for derivatives: the row of the
            perturbed batch, see ``what``).
        step: index of the step (0-based) during which it went unstable.
        reason: MuJoCo's warning name or "non-finite state".
        what: which call ran it ("rollout", or "derivatives t=.. perturbation=..").
    """

    def __init__(self, rollout: int, step: int, reason: str, what: str = "rollout"):
        self.rollout, self.step, self.reason, self.what = int(rollout), int(step), reason, what
        super().__init__(f"{what}: simulation {self.rollout} went unstable at step {self.step} "
                         f"({reason})")
