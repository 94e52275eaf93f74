"""Settle until at rest: a population of pick-and-place sequences simulated action by action,
each sample's settle cut short once its object is at rest.

A picker action (``dopt.tasks.pick.picker``) is K = snap + hold + move + settle steps, and a
plain rollout simulates every sample for all of them, at rest or not. ``rollout_until_rest``
runs the same control rows in stages: per action, every sample up to the end of its move plus
``RestTest.min_settle``; then the settle in chunks of ``RestTest.check_every``, where a sample
leaves the batch once its particles' root-mean-square speed (sqrt(2 E_kin / m) for particles
of equal mass) is below ``RestTest.speed`` (m/s), or the verdict has flagged it; at most the
picker's full settle. The next action starts from each sample's own state. With a speed no
sample gets below (0), the final states are bit-identical to the plain rollout's, since a
state row (mjSTATE_INTEGRATION) carries everything a step reads.

The verdict of the stages is merged: unstable if any stage was, the step counted from the
sequence's start, the largest speed, penetration, strain and energy gain, the capped steps
summed. The energy bound's free window restarts at each chunk (the gain is measured from the
chunk's start): a sheet that lost energy since its release is judged against the lower start.

Shapes: P population, H actions per sequence, K steps per action, N particles, ns state size.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dopt.rollout import RolloutResult, RolloutService
from dopt.stability import Stability
from dopt.tasks.pick.picker import CONTROL_SPEC
from dopt.validation import check_config


@dataclass(frozen=True)
class RestTest:
    """When a settle may stop.

    Attributes:
        speed: m/s; the object is at rest once its particles' root-mean-square speed is
            below it (0: never).
        check_every: seconds of settle between two tests (a chunk, whole steps of dt, >= 1).
        min_settle: seconds every sample settles before the first test.
    """

    speed: float = 0.005
    check_every: float = 0.025
    min_settle: float = 0.025

    def __post_init__(self):
        check_config(self, positive=("check_every",), minimum={"speed": 0.0, "min_settle": 0.0})


@dataclass(frozen=True)
class RestRollout:
    """What ``rollout_until_rest`` returns: ``result`` (final states (P, ns) and the merged
    verdict; no records), ``steps`` (P,) the steps each sample simulated, and ``full_steps``
    the H * K steps a plain rollout simulates for each."""

    result: RolloutResult
    steps: np.ndarray
    full_steps: int


def rollout_until_rest(service: RolloutService, picker, velocity_dofs: np.ndarray,
                       initial_state: np.ndarray, particles, displacements,
                       rest: RestTest) -> RestRollout:
    """Simulate (P, H) particles and (P, H, 3) displacements from ``initial_state`` (ns,),
    each action's settle ended once the object is at rest (module docstring).

    Args:
        service: the scene's rollout service; picker: its ``Picker``.
        velocity_dofs: (N, 3) qvel indices of the particles' linear velocities.
        rest: the rest test.
    """
    if not isinstance(rest, RestTest):
        raise TypeError(f"rest must be a RestTest, got {type(rest).__name__}")
    U = picker.encode(particles, displacements)                        # (P, H*K, nc)
    P, K, dt = U.shape[0], picker.steps_per_action, picker.dt
    H = U.shape[1] // K
    U = U.reshape(P, H, K, -1)
    qvel = service.scene.layout["qvel"]
    first = min(K, K - picker.settle_steps + int(round(rest.min_settle / dt)))
    chunk = max(1, int(round(rest.check_every / dt)))
    x = np.repeat(np.asarray(initial_state, dtype=float)[None], P, axis=0)
    merged = _Merged(P)
    steps = np.zeros(P, dtype=np.int64)
    for h in range(H):
        live = np.flatnonzero(~merged.unstable)
        t = 0
        while len(live) and t < K:
            n = first if t == 0 else min(chunk, K - t)
            res = service.rollout(x[live], U[live, h, t:t + n], control_spec=CONTROL_SPEC)
            x[live] = res.final_states
            merged.add(live, res.stability, offset=steps[live])
            steps[live] += n
            t += n
            v = res.final_states[:, qvel][:, velocity_dofs]                 # (p, N, 3)
            moving = np.sqrt((v ** 2).sum(axis=-1).mean(axis=-1)) >= rest.speed
            live = live[moving & ~res.stability.unstable]
    return RestRollout(RolloutResult(x, {}, merged.verdict()), steps, H * K)


class _Merged:
    """The verdict of P samples over the stages they ran (module docstring)."""

    def __init__(self, P: int):
        self.unstable = np.zeros(P, bool)
        self.step = np.full(P, -1, dtype=np.int64)
        self.reason = [""] * P
        self.maxima = {k: np.zeros(P) for k in ("max_speed", "max_penetration", "max_strain",
                                                 "max_energy_gain")}
        self.capped = np.zeros(P, dtype=np.int64)

    def add(self, rows: np.ndarray, st: Stability, offset: np.ndarray) -> None:
        for k, m in self.maxima.items():
            m[rows] = np.maximum(m[rows], getattr(st, k))
        self.capped[rows] += st.capped_steps
        for j in np.flatnonzero(st.unstable):
            i = rows[j]
            self.unstable[i] = True
            self.step[i] = offset[j] + st.step[j]
            self.reason[i] = st.reason[j]

    def verdict(self) -> Stability:
        return Stability(unstable=self.unstable.copy(), step=self.step.copy(),
                         reason=tuple(self.reason), capped_steps=self.capped.copy(),
                         **{k: m.copy() for k, m in self.maxima.items()})
