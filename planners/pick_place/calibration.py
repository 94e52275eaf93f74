"""What one simulated pick-and-place action costs on this machine now: the calibration step a
command line times before a run, to say how long the run will take
(``experiments/pick_place_cli.py``). Timed, not modelled: the cost of a step depends on the
cloth's size, the physics preset, the threads and what else the machine runs.

Shapes: P population, H actions per plan.
"""

from __future__ import annotations

import time

import numpy as np

from dopt.rollout import RolloutConfig, RolloutService
from dopt.tasks import PickPlaceTask
from planners.pick_place.problem import Problem
from planners.pick_place.settings import PickPlaceSettings

#: the calibration step times a batched rollout of this share of a CEM population (at least
#: ``CALIBRATION_MIN_PLANS`` random plans of the settings' horizon)
CALIBRATION_SHARE = 0.25
CALIBRATION_MIN_PLANS = 4
#: times the calibration rollout runs (the fastest counts)
CALIBRATION_REPEATS = 2


def seconds_per_action(problem: Problem, settings: PickPlaceSettings) -> tuple[float, int]:
    """The calibration step: wall seconds per simulated pick-and-place action on this machine
    now, timed on a batched rollout of random plans (``CALIBRATION_SHARE`` of the population,
    at least ``CALIBRATION_MIN_PLANS``; the settings' horizon, threads and planning physics)
    from the problem's start, the fastest of ``CALIBRATION_REPEATS``; and the plans timed."""
    scene = problem.planning_scene or problem.scene
    P, H = settings.cem.population, settings.cem.horizon
    plans = max(CALIBRATION_MIN_PLANS, int(P * CALIBRATION_SHARE))
    rng = np.random.default_rng(0)
    keys = problem.stages[0].keys
    particles = keys[rng.integers(0, len(keys), (plans, H))]
    displacements = rng.uniform(-0.5, 0.5, (plans, H, 3)) * scene.picker.bound
    service = RolloutService(scene.scene, RolloutConfig(threads=settings.threads))
    try:
        task = PickPlaceTask(scene, problem.final_goal, problem.start_state, service)
        seconds = []
        for _ in range(CALIBRATION_REPEATS):          # the fastest: a first call's set-up out
            t0 = time.perf_counter()
            task.rollout(particles, displacements)
            seconds.append(time.perf_counter() - t0)
        return min(seconds) / (plans * H), plans
    finally:
        service.close()
