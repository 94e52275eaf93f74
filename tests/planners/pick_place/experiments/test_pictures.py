"""The pictures say what they show (the push picture's goal-object tilt: in
tests/planners/svr_mpc/experiments/test_outputs.py): the Panda strip's panel labels against the
executor's snapshot order (start, then grasp, carry, release per executed action), and the
scaling plot's x ticks at the sizes run."""

import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[4]


def test_strip_labels_follow_the_snapshots():
    from planners.pick_place.experiments import panda_execute

    assert panda_execute.strip_labels(1) == ["start"]
    labels = panda_execute.strip_labels(7)
    assert labels == ["start", "action 1: grasped", "action 1: carried", "action 1: released",
                      "action 2: grasped", "action 2: carried", "action 2: released"]


def test_scaling_plot_ticks_every_size(tmp_path):
    pytest.importorskip("matplotlib")
    import matplotlib.pyplot as plt

    from planners.pick_place.experiments import scaling as fig7_scaling

    record = ROOT / "docs" / "results" / "fig7-scaling-diagonal.json"
    if not record.is_file():
        pytest.skip("no committed scaling summary")
    stats = json.loads(record.read_text())
    seen = {}
    real = plt.close

    def keep(fig=None):
        seen["fig"] = fig
        real(fig)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(plt, "close", keep)
        assert fig7_scaling.plot(tmp_path / "s.png", stats, stats["goal"])
    sizes = sorted(int(k) ** 2 for k in stats["per_size"])
    for ax in seen["fig"].axes:
        assert sorted(ax.get_xticks()) == sizes
        assert [t.get_text() for t in ax.get_xticklabels()] == [str(n) for n in sizes]
        assert ax.get_xlabel() and ax.get_ylabel() and ax.get_legend() is not None
