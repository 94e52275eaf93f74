"""A full disk never cuts a result file short (#92): rerunning a finished folder with no room
left (a file-size limit of 4 kB here, RLIMIT_FSIZE, which fails a write as a full disk does)
leaves the old summary.json, curves.csv, table and figure copy whole, and the error names the
file. (Before, summary.json became 4,096 bytes of invalid JSON and curves.csv was left
empty, with only "OSError: [Errno 27] File too large".)"""

import errno
import json

import pytest

from dopt.lab import provenance
from dopt.lab.record import record_figure, write_summary
from planners.pick_place.experiments.pictures import write_curves
from planners.svr_mpc.experiments import outputs
from tests.dopt.lab.test_atomic_write import BIG, file_size_limit


@pytest.fixture(autouse=True)
def no_git(monkeypatch):
    """The summaries' provenance without git (git may write its index: not under the limit)."""
    monkeypatch.setattr(provenance, "provenance", lambda *a, **k: {"git_commit": "c0ffee"})


def curves(n_iterations: int) -> list[dict]:
    return [{"method": m, "seed": s, "cost_history": [0.1 / (i + 1) for i in range(n_iterations)],
             "stage_of_iteration": [0] * n_iterations} for m in ("pp", "rand") for s in range(3)]


def table_methods(n_rows: int) -> dict:
    row = {"mpc_cost_normalised_mean": 1.0, "mpc_cost_normalised_ci90": 0.1,
           "mpc_cost_normalised_median": 1.0, "mpc_cost_median_ratio": 1.0, "opt_ms_mean": 5.0,
           "n_dofs_mean": 3.0, "lag_steps_mean": 1.0, "success_rate": 0.5,
           "goal_distance_end_median": 0.01, "outliers": 0, "n_trials": 20}
    return {f"row-{i:04d}-with-a-long-name": row for i in range(n_rows)}


def summary(out, big: bool):
    write_summary(dict(BIG) if big else {"old": True}, out, None, "experiments/x.py", [])


def curves_csv(out, big: bool):
    write_curves(out / "curves.csv", curves(400 if big else 2))


def table_csv(out, big: bool):
    outputs.write_table(out, "push", table_methods(200 if big else 1))


def figure_copy(out, big: bool):
    """The figure a --record run copies beside its record (both sources written first, with
    room: only the copy runs under the limit)."""
    run = out / "run"
    if not run.exists():
        run.mkdir()
        (run / "small.png").write_bytes(bytes(range(256)))
        (run / "big.png").write_bytes(bytes(range(256)) * 100)
    record_figure(run / ("big.png" if big else "small.png"), out / "results" / "rec.json")


@pytest.mark.parametrize("write, name", [
    (summary, "summary.json"), (curves_csv, "curves.csv"), (table_csv, "table1.csv"),
    (figure_copy, "images/rec.png")])
def test_a_rewrite_on_a_full_disk_keeps_the_old_file_and_names_it(tmp_path, write, name):
    write(tmp_path, big=False)
    path = tmp_path / name
    old = path.read_bytes()
    if name.endswith(".json"):
        json.loads(old)
    with file_size_limit(4096), pytest.raises(OSError) as exc:
        write(tmp_path, big=True)
    print(exc.value)
    assert exc.value.errno == errno.EFBIG and str(path) in str(exc.value)
    assert path.read_bytes() == old                               # whole, as it was
    assert not [p for p in path.parent.iterdir() if p.name.startswith(".tmp-")]
    write(tmp_path, big=True)                                     # room again: rewritten
    assert path.read_bytes() != old and path.stat().st_size > 4096
