"""python -m dopt.bench cloth-warp: bad inputs fail first (its command line's bad flags are in
test_bench_cli), and (where MuJoCo Warp is installed) its worlds reproduce MuJoCo's own CPU
step of the same action."""


import pytest

from dopt.bench.cloth_warp import bench_cloth_warp


@pytest.mark.parametrize("sizes, nworlds, preload", [([], [1], 0), ([1], [1], 0), ([6], [], 0),
                                                    ([6], [0], 0), ([6], [1], -1)])
def test_bad_sizes_world_counts_and_workers_raise_before_any_import(sizes, nworlds, preload):
    with pytest.raises(ValueError, match="sizes|nworlds|preload_workers"):
        bench_cloth_warp(sizes, nworlds, preload_workers=preload)


def test_warp_worlds_match_the_cpu_step():
    """MuJoCo Warp on warp's CPU device (float32) against mj_step (float64) on a 6 x 6 sheet:
    every world identical (same action, lockstep), finite, and within 1 mm of MuJoCo's
    particles after the 133-step action. Skipped without mujoco_warp (CI does not install it)."""
    pytest.importorskip("mujoco_warp")
    (row,) = bench_cloth_warp([6], [1, 2], device="cpu")
    assert row["cpu"]["steps_per_action"] == 133 and row["particles"] == 36
    one, two = row["warp"]
    for w in (one, two):
        assert "error" not in w and w["all_finite"] and w["steps_timed"] == 132
        assert w["gap_to_cpu_max_m"] < 1e-3
    assert one["gap_to_cpu_mean_m"] == pytest.approx(two["gap_to_cpu_mean_m"], rel=1e-6)


class _Capture:
    """warp.ScopedCapture's stand-in: records the steps issued inside it, fails on exit
    where told to (as CUDA refuses a capture that touches the legacy stream)."""

    def __init__(self, fail):
        self.fail, self.graph, self.steps = fail, "graph", 0

    def __call__(self, device):
        return self

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        if self.fail:
            raise RuntimeError("Warp CUDA error 906")
        return False


@pytest.mark.parametrize("fail", [False, True])
def test_a_step_that_cannot_be_captured_is_timed_launch_by_launch(fail):
    from types import SimpleNamespace

    from dopt.bench.cloth_warp import _captured_step

    capture = _Capture(fail)
    wp = SimpleNamespace(ScopedCapture=capture, synchronize_device=lambda dev: None)
    mjw = SimpleNamespace(step=lambda m, d: setattr(capture, "steps", capture.steps + 1))
    out = {}
    graph = _captured_step(wp, mjw, "cuda:0", None, None, out)
    assert capture.steps == 1
    assert (graph is None) == fail
    assert ("cuda_graph_error" in out) == fail
    if fail:
        assert "906" in out["cuda_graph_error"]
