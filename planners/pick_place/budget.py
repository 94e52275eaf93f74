"""What a pick-and-place setting will allocate, checked before anything is: the picker's
reach against its workspace, the steps of one action against ``MAX_STEPS_PER_ACTION``
(``dopt.tasks.pick.picker.PickerConfig``), and the memory of one CEM population's rollout
(its control rows, states and the simulated model) against this machine's
(``dopt.validation.memory_bytes``).

``budget_problem(settings)`` says which setting to change, so that a CLI can name its flag
(``experiments/pick_place_cli.py``): the one that grew most beyond the protocol's preset
when several make the size. ``check_budget`` raises it (``make_problem`` calls it).

Shapes: P population, H actions per plan, K steps per action, N particles.
"""

from __future__ import annotations

import os

from dopt.validation import check_memory
from planners.pick_place.tasks import PICK_TASKS

#: bytes one simulated particle takes in MuJoCo's model and in the data of each simulation
#: thread (a flex vertex body, its slide joints, contacts, the solver's rows; generously)
BYTES_PER_PARTICLE = 4096
#: columns of a control row beyond the grasp equalities (one per particle): the picker's six
#: actuators and a margin
CONTROL_COLUMNS = 16


class BudgetError(ValueError):
    """A setting implies more than the machine holds; ``field`` names it (``cem.population``
    for a nested field)."""

    def __init__(self, field: str, message: str):
        super().__init__(message)
        self.field = field


def sizes(settings) -> dict:
    """The sizes ``settings`` (a ``PickPlaceSettings``) imply: N particles, K steps per action
    (the largest over the scene's and the planning scene's timesteps), P, H and the bytes of
    one population's rollout ("controls": P H K control rows, "states": P (H + 1) states,
    "model": the scene's model and data per thread).

    Raises:
        BudgetError: a bound beyond the workspace, or more steps per action than the picker
            allows (field "bound" or "picker_speed").
    """
    try:
        picker = settings.picker()
    except ValueError as e:
        raise BudgetError("bound", str(e)) from None
    try:                           # the scene's own checks of its sizes (a rope's spacing)
        configs = [settings.scene_config(), settings.planning_scene_config()]
    except ValueError as e:
        raise BudgetError("n", str(e)) from None
    try:
        K = max(sum(picker.steps(c.timestep)) for c in configs if c is not None)
    except ValueError as e:
        field = "bound" if settings.picker_speed is None else "picker_speed"
        raise BudgetError(field, str(e)) from None
    N = PICK_TASKS[settings.task].n_particles(settings.n)
    P, H = settings.cem.population, settings.cem.horizon
    threads = settings.threads or os.cpu_count() or 1
    return {"N": N, "K": K, "P": P, "H": H,
            "controls": 8.0 * P * H * K * (CONTROL_COLUMNS + 2 * N),
            "states": 8.0 * P * (H + 1) * (6 * N + 64),
            "model": float(BYTES_PER_PARTICLE) * N * (threads + 1)}


def budget_problem(settings) -> BudgetError | None:
    """Why ``settings`` cannot run on this machine (a ``BudgetError`` naming the setting to
    change), or None."""
    try:
        s = sizes(settings)
        need = s["controls"] + s["states"] + s["model"]
        check_memory(need, f"one CEM population's rollout ({s['P']} plans x {s['H']} actions "
                           f"x {s['K']} steps per action on {s['N']} particles)")
    except BudgetError as e:
        return e
    except ValueError as e:
        return BudgetError(_blame(settings, s), str(e))
    return None


def check_budget(settings) -> None:
    """Raise ``budget_problem(settings)`` if there is one."""
    problem = budget_problem(settings)
    if problem is not None:
        raise problem


def _blame(settings, s: dict) -> str:
    """The field that grew most beyond the protocol's preset (at the default picker)."""
    base = sizes(type(settings).preset(settings.task, settings.goal))
    growth = {"n": s["N"] / base["N"], "cem.population": s["P"] / base["P"],
              "cem.horizon": s["H"] / base["H"],
              ("picker_speed" if settings.picker_speed is not None else "bound"):
              s["K"] / base["K"]}
    return max(growth, key=growth.get)
