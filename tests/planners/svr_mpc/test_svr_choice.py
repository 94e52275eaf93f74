"""planners.svr_mpc.choice: how often each row's C held the goal object, from stored active
sets, against shares counted by hand on constructed episodes; the goal DoFs of an authors'
clutter scene against MuJoCo's own joint tables."""

import numpy as np
import pytest
from scipy import stats

from planners.svr_mpc.choice import choice_fields, goal_dofs, goal_held
from planners.svr_mpc.episode import dofs_mask
from tests.external import LAYOUTS

ROWS = {"baseline": ("baseline", 0, 1.0), "rand-t5": ("rand", 5, 1.0),
        "sum-t10-r1": ("svr-sum", 10, 1.0), "naive": ("naive", 0, 1.0)}


def mask(dofs) -> str:
    return dofs_mask(np.array(sorted(dofs), dtype=int))


def trial(row: str, seed: int, cost: float, sets: list, held: int = 0, lag: float = 10.0,
          landed=None):
    method, theta, rho = ROWS[row]
    result = {"mpc_cost": cost, "active_sets": [mask(s) for s in sets], "held_steps": held,
              "lag_steps_mean": lag, "goal_distance_end": 0.0}
    if landed is not None:                        # every optimisation lagging `lag` steps
        result.update(landed_at=landed, lag_steps=[int(lag)] * len(landed))
    return {"params": {"method": method, "theta": theta, "rho": rho, "seed": seed},
            "result": result}


def test_goal_held_counts_optimisations_after_the_first_holding_every_goal_dof():
    goal = np.array([7, 8])
    sets = [range(12), [0, 7, 8], [0, 7], [8, 9], [7, 8, 20]]
    assert goal_held([mask(s) for s in sets], goal) == [True, False, False, True]
    assert goal_held([mask(range(12))], goal) == []


def test_choice_fields_pool_shares_and_order_rows_by_kendall_tau():
    goal = np.array([3, 4])
    every = list(range(10))
    recs = []
    for seed in range(3):
        recs.append(trial("baseline", seed, 100.0, [every, every], held=50, lag=40))
        recs.append(trial("naive", seed, 70.0, [every, [0, 3, 4]], held=30, lag=20,
                          landed=[0, 20 + 4 * seed]))
        # rand holds the goal in one optimisation of three per episode
        recs.append(trial("rand-t5", seed, 80.0, [every, [0, 3, 4], [0, 1], [0, 4]],
                          held=20 + seed, lag=15))
        recs.append(trial("sum-t10-r1", seed, 90.0 + seed, [every, [0, 3], [3, 4, 5]],
                          held=40, lag=30))
    out = choice_fields(recs, goal_of=lambda params: goal)
    rows = out["rows"]
    assert rows["naive"]["goal_held_share"] == 1.0
    assert rows["rand-t5"]["goal_held_share"] == pytest.approx(1 / 3)
    assert rows["sum-t10-r1"]["goal_held_share"] == pytest.approx(0.5)
    assert rows["sum-t10-r1"]["cost_ratio_median"] == pytest.approx(0.91)
    assert rows["rand-t5"]["held_steps_mean"] == pytest.approx(21.0)
    others = ("naive", "rand-t5", "sum-t10-r1")
    # naive's landings after the first: 20, 24, 28 against a lag of 20
    assert rows["naive"]["landing_offset_mean"] == pytest.approx(4.0)
    assert rows["rand-t5"]["landing_offset_mean"] is None       # no landings stored
    assert out["tau"]["landing_offset_mean"] is None            # one row has them: no tau
    for field in ("goal_held_share", "held_steps_mean", "lag_steps_mean"):
        expected = stats.kendalltau([rows[r][field] for r in others],
                                    [rows[r]["cost_ratio_median"] for r in others])
        assert out["tau"][field]["tau"] == pytest.approx(expected.statistic)
    assert choice_fields([r for r in recs if r["params"]["method"] != "baseline"],
                         goal_of=lambda params: goal) == {}


def test_goal_dofs_of_an_authors_clutter_scene_are_its_goal_bodys_free_joint_x_and_y():
    if not LAYOUTS.is_dir():
        pytest.skip("the authors' layouts are not here (../shared/external)")
    layouts = LAYOUTS
    from planners.svr_mpc import PushScene, SVRMPCSettings

    s = SVRMPCSettings(task="clutter", scene=PushScene("authors", str(layouts)))
    task = s.build_task(0)
    (body,) = task.goal_bodies
    joint = task.model.body_jntadr[body]
    assert task.model.jnt_type[joint] == 0                             # mjJNT_FREE
    first = task.model.jnt_dofadr[joint]
    params = {"task": "clutter", "problem": "authors", "layouts": str(layouts), "seed": 0}
    assert goal_dofs(params).tolist() == [first, first + 1]
