"""The gain of key particles against the candidate count under the authors' drag encoding
(issue 89, item 2): the Fig. 7 cloth folds on one physics mesh with N candidate pick points
(``encoding_trials``) and their statistics (``encoding_summary``).

Every trial is the paper protocol's cloth settings of its goal at the physics mesh
``MESH`` x ``MESH`` on a sheet of ``side`` (default ``SIDE``: SoftGym's 100 x 100 sheet, so
N = 10,000 points lie at its 6.25 mm spacing), the picker's bound one decision's reach
(repeat x step), and ``PickPlaceSettings.drag`` with N = ``n_points``. CEM(Original) and
CEM(Random) run at every N (Random draws its points from the N-point grid); CEM(Simple)
plans over the key particles whatever N is, so it runs once per seed (at the smallest N) and
is paired with every N.

The trend test is ``planners.pick_place.scaling``'s (the paired difference, method minus
Simple, per seed, regressed on log N by OLS, Holm over Original and Random), fed the records
with the grid's side sqrt(N) as the size, so that its N is the candidate count.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import replace

from dopt.lab.sweep import Trial
from planners.pick_place.drag_settings import SOFTGYM_SPACING, DragSettings
from planners.pick_place.scaling import scaling_summary
from planners.pick_place.settings import PickPlaceSettings
from planners.pick_place.trial_names import trial_key

#: the physics mesh's particles per side (the Fig. 7 paper-protocol cloth, 20 x 20)
MESH = 20
#: the sheet's side (m): SoftGym's 100 x 100 sheet at its 6.25 mm spacing
SIDE = 99 * SOFTGYM_SPACING
#: the drag methods and the macro method each stands for in the statistics
BASE = {"simple-drag": "simple", "original-drag": "original", "random-drag": "random"}


def encoding_settings(goal: str, drag: DragSettings, side: float = SIDE,
                      threads: int = 0) -> PickPlaceSettings:
    """The paper protocol's cloth settings of ``goal`` on the ``MESH`` x ``MESH`` mesh of a
    sheet of ``side`` m, planned in the drag encoding ``drag``."""
    base = PickPlaceSettings.preset("cloth", goal, protocol="paper")
    return replace(base, n=MESH, side=float(side), bound=drag.repeat * drag.step,
                   drag=drag, threads=int(threads))


def encoding_trials(goal: str, points: Sequence[int], seeds: Iterable[int],
                    methods: Sequence[str], drag: DragSettings = DragSettings(),
                    side: float = SIDE, threads: int = 0) -> list[Trial]:
    """The ``dopt.lab.sweep`` trials: every (N, seed) of the methods but CEM(Simple), and one
    CEM(Simple) trial per seed at the smallest N (key ``trial_key``, params {"settings",
    "method", "seed"}, which ``run_trial`` runs)."""
    unknown = sorted(set(methods) - set(BASE))
    if unknown or not methods:
        raise ValueError(f"methods must be a non-empty subset of {list(BASE)}, got {unknown}")
    if not points:
        raise ValueError("points: at least one candidate count")
    seeds = [int(s) for s in seeds]
    out = []
    for n in sorted(set(int(p) for p in points)):
        settings = encoding_settings(goal, replace(drag, n_points=n), side, threads)
        for m in methods:
            if m == "simple-drag" and n != min(points):
                continue
            out += [Trial(trial_key(m, s, settings),
                          {"settings": settings.to_dict(), "method": m, "seed": s})
                    for s in seeds]
    return out


def encoding_summary(records: Iterable[dict], points: Sequence[int]) -> dict:
    """``scaling_summary`` of the sweep's records with the candidate count as the size:
    the per-N statistics under "per_size" (keys str(sqrt N)), "n_points" the counts, and the
    trend of Original - Simple and Random - Simple against log N with Holm."""
    records = list(records)
    recast = []
    for n in sorted(set(int(p) for p in points)):
        recast += [_as_size(r, round(n ** 0.5)) for r in records
                   if r["params"]["method"] == "simple-drag"
                   or r["params"]["settings"]["drag"]["n_points"] == n]
    out = scaling_summary(_unique(recast))
    out["n_points"] = out.pop("n_particles")
    return out


def _as_size(record: dict, side: int) -> dict:
    """A record with the grid's side as the settings' n and the macro method's name."""
    p = record["params"]
    settings = {**p["settings"], "n": side}
    return {"params": {**p, "settings": settings, "method": BASE[p["method"]]},
            "result": record["result"]}


def _unique(records: list[dict]) -> list[dict]:
    """Records without repeats of one (size, method, seed)."""
    seen, out = set(), []
    for r in records:
        p = r["params"]
        key = (p["settings"]["n"], p["method"], p["seed"])
        if key not in seen:
            seen.add(key)
            out.append(r)
    return out
