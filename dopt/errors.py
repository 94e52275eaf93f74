"""Exceptions raised by the rollout service.

``RolloutError``: MuJoCo raised an error inside a batched call. ``UnstableRolloutError(rollout,
step, reason)``: a simulation went unstable (a MuJoCo warning, a state MuJoCo would reject or a
non-finite one), raised where a caller asked for it (``RolloutConfig(on_unstable="raise")``,
derivatives); the verdicts of the scene's own bounds are ``dopt.stability``'s. Bad arguments
raise ``ValueError`` / ``TypeError`` naming them (``dopt.validation``), and a closed service
``RuntimeError``.
"""

from __future__ import annotations


class RolloutError(RuntimeError):
    """MuJoCo raised an error inside a batched call (bad model data, out of memory, ...)."""


class UnstableRolloutError(RolloutError):
    """A simulation went unstable: MuJoCo warned during a step (bad qpos/qvel/qacc/ctrl,
    ...), or a step left a state MuJoCo would reject (a qpos or qvel entry NaN or beyond
    +-mjMAXVAL = 1e10) or a non-finite one. Every route and call reports the same step.

    Attributes:
        step: step t, the step that started from state row t with control t and produced the
            bad state (or warned). For a rollout from x_0 with controls u_0..u_{T-1}, the step
            that applied u_t to x_t; an invalid start state fails at step 0. For derivatives,
            the timestep t: the steps from ``states[t]`` (the nominal one and its nudges).
        rollout: index of the offending rollout in the batch; for derivatives, the perturbation
            row of timestep ``step``: 0 the nominal step, then the control, velocity and
            position nudges in ``RolloutService.derivatives``' order (the + block before the -
            block when centred).
        reason: MuJoCo's warning name (e.g. "mjWARN_BADQVEL"; "mjWARN_BADQPOS" or
            "mjWARN_BADQVEL" also for a step that left a state MuJoCo's next step would reject
            with that warning), or "non-finite state".
        what: which call ran it ("rollout", "rollout_feedback", "mpc agent", or
            "derivatives t=.. perturbation=..").
        capture: the folder of the blow-up capture written of it (``dopt.blowup``; an
            MPC agent given ``blowup_out``), else None.
    """

    capture: str | None = None

    def __init__(self, rollout: int, step: int, reason: str, what: str = "rollout"):
        self.rollout, self.step, self.reason, self.what = int(rollout), int(step), reason, what
        super().__init__(f"{what}: simulation {self.rollout} went unstable at step {self.step} "
                         f"({reason})")
