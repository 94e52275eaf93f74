"""``DragSettings``: the key-particle authors' action encoding as a planner option
(``PickPlaceSettings.drag``; the planners of ``planners.pick_place.drag``).

Every number says where it comes from: the authors' code (``shengyin-git/ac_softagent``:
``softgym/action_space/action_space.py``, ``cem/cem.py``, ``cem/parallel_worker.py``, the
cloth scripts ``cem_cloth_*_folding/run_cem_cloth_folding.py``) or ours.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

from dopt.validation import check_config

#: SoftGym's cloth particle spacing (m): the particle radius, ``cloth_env.py``
SOFTGYM_SPACING = 0.00625


@dataclass(frozen=True)
class DragSettings:
    """The drag encoding of a trial.

    Attributes:
        n_points: N, candidate pick points of CEM(Original): a sqrt(N) x sqrt(N) grid over
            the sheet, numbered row-major as the cloth's particles (ours: decoupled from the
            physics mesh, ``dopt.tasks.pick.drag.VirtualPoints``; a perfect square).
        horizon: T, decisions per plan (the authors' cloth scripts: ``env_kwargs_horizon`` 15).
        repeat: substeps per decision (the authors': ``env_kwargs_action_repeat`` 8).
        step: largest move per axis of one substep, m (the authors': 1 cm, the picker's
            action box +-0.1 * 0.1).
        substeps: MuJoCo steps per substep (ours, measured with
            ``planners.pick_place.drag.speed_check``, 16 plans of the authors' first CEM
            distribution on the 0.619 m sheet: at 1, the authors' 1 cm per 5 ms step (2 m/s),
            7 of 16 are flagged, 4 of them above 5 m/s, strain up to 0.60; at 2 (1 m/s) 2 of
            16, both 20-22 mm into the floor, as at 4, strain up to 0.43: the speed needs 2).
        best_over_trajectory: a sample's cost is the lowest Eq. 2 cost at the end of any of
            its decisions, and the executed plan stops at that decision (the authors':
            ``get_cost`` is -100 max_t reward, and the run script stops at the best step);
            False: Eq. 2 after the whole plan and the settle.
        population: CEM samples per iteration (the authors': 10000 // 30 = 333; ours,
            chosen: 32, the project's population).
        iterations: CEM iterations (the authors': 30; ours the same).
        elites_fraction: elites per population (the authors': population // 10).
    """

    n_points: int = 400
    horizon: int = 15
    repeat: int = 8
    step: float = 0.01
    substeps: int = 2
    best_over_trajectory: bool = True
    population: int = 32
    iterations: int = 30
    elites_fraction: float = 0.1

    def __post_init__(self):
        check_config(self, positive=("step", "elites_fraction"),
                     minimum={"n_points": 4, "horizon": 1, "repeat": 1, "substeps": 1,
                              "population": 1, "iterations": 1})
        side = round(self.n_points ** 0.5)
        if side * side != self.n_points:
            raise ValueError(f"DragSettings.n_points must be a perfect square (a grid), got "
                             f"{self.n_points}")
        if not self.elites_fraction <= 1:
            raise ValueError(f"DragSettings.elites_fraction must be <= 1, got "
                             f"{self.elites_fraction}")

    @property
    def elites(self) -> int:
        """E = max(1, floor(population * elites_fraction)) (the authors' population // 10)."""
        return max(1, int(self.population * self.elites_fraction))

    def to_dict(self) -> dict:
        return asdict(self)
