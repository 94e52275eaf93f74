"""The sentence that sizes a multi-layer fold's last fold (``report_fig7.fold_reference``): the
flat sheet's and the previous fold's goal's cost to the final goal, from the goals' geometry."""

import numpy as np
import pytest

from planners.pick_place.experiments.report_fig7 import fold_reference
from planners.pick_place.scaling import fold_costs


@pytest.mark.parametrize("n, side", [(12, 0.3), (20, 0.3), (31, 0.5)])
def test_the_side_folds_flat_cost_is_the_rigid_mirrors_less_the_rounded_crease(n, side):
    """A rigid mirror of the far half about the middle moves a particle of row r by
    2 (r - (n - 1) / 2) h: the goal's rounded crease shortens the moves near it, so the
    goal's cost lies a few per cent below that and never above it."""
    flat, previous = fold_costs("side", n, side)
    h, rows = side / (n - 1), np.arange(n)
    mirror = np.where(rows >= n / 2, 2 * (rows - (n - 1) / 2) * h, 0.0).mean()
    assert previous is None
    assert 0.93 * mirror < flat <= 1.01 * mirror


def test_a_multi_layer_fold_names_both_costs_the_previous_below_the_flat():
    text = fold_reference({"task": "cloth", "goal": "reflective", "n": 20, "side": 0.3})
    flat, previous = fold_costs("reflective", 20, 0.3)
    assert 0 < previous < flat
    assert f"flat sheet lies {flat * 1e3:.1f} mm" in text
    assert f"previous fold's goal {previous * 1e3:.1f} mm" in text
    under_flat, under_previous = fold_costs("underneath", 20, 0.3)
    assert 0 < under_previous < under_flat


@pytest.mark.parametrize("settings", [
    {"task": "cloth", "goal": "side", "n": 20, "side": 0.3},            # one fold
    {"task": "cloth", "goal": "diagonal", "n": 20, "side": 0.3},
    {"task": "rope", "goal": "fold", "n": 40},                          # not a cloth
    {"task": "cloth", "goal": "reflective", "n": 20},                   # no side recorded
    {"task": "cloth", "goal": "reflective", "n": "x", "side": 0.3},
    {}])
def test_other_settings_get_no_sentence(settings):
    assert fold_reference(settings) == ""
