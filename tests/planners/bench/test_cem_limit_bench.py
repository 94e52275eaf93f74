"""python -m planners.bench cem-limit at a toy size: one CEM iteration of the paper protocol's
cloth diagonal fold, its row's arithmetic (the limit is steps x one mj_step / cores, the steps
are the preset's P x H x K, the breakdown's shares sum to one), the printed table and the
result file. Speed targets stay out of tests: nothing here judges a time."""
import contextlib
import io
import json

import pytest

from planners.bench.__main__ import main
from planners.bench.cem import SHARES, breakdown
from planners.pick_place.settings import PickPlaceSettings

N = 3


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """The bench run once through its command line: (the printed lines, the result file)."""
    out = tmp_path_factory.mktemp("cem-limit") / "cem-limit.json"
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        assert main(["cem-limit", "--sizes", str(N), "--iterations", "1", "--threads", "1",
                     "--step-samples", "200", "--record", str(out)]) == 0
    return printed.getvalue().splitlines(), json.loads(out.read_text())


def test_the_record_has_one_row_per_size_with_its_provenance(run):
    _, record = run
    assert record["experiment"] == "cem_limit"
    assert (record["task"], record["goal"], record["protocol"]) == ("cloth", "diagonal", "paper")
    assert record["candidates"] == "keys" and record["iterations"] == 1
    assert {"command", "git_commit", "versions"} <= set(record["provenance"])
    (row,) = record["rows"]
    assert row["n"] == N and row["particles"] == N * N
    assert len(row["iterations_s"]) == 1 and row["step_samples"] == 200
    assert set(row["shares"]) == set(row["seconds"]) == set(SHARES)


def test_the_steps_are_the_presets_population_horizon_and_action(run):
    _, record = run
    (row,) = record["rows"]
    settings = PickPlaceSettings.preset("cloth", "diagonal", protocol="paper")
    K = sum(settings.picker().steps(settings.scene_config().timestep))
    assert (row["P"], row["H"], row["K"]) == (settings.cem.population, settings.cem.horizon, K)
    assert sum(row["phases"].values()) == K
    assert row["steps"] == settings.cem.population * settings.cem.horizon * K


def test_the_limit_ratio_and_shares_add_up(run):
    _, record = run
    (row,) = record["rows"]
    assert row["threads"] == row["cores"] == 1
    assert row["limit_s"] == pytest.approx(row["steps"] * row["mj_step_ms"] / 1e3 / row["cores"],
                                           rel=1e-12)
    assert row["ratio"] == pytest.approx(row["iteration_s"] / row["limit_s"], rel=1e-12)
    assert row["iteration_s"] == pytest.approx(row["iterations_s"][0])
    assert row["cpu_ratio"] == pytest.approx(row["cpu_s"] / (row["limit_s"] * row["cores"]),
                                             rel=1e-12)
    assert sum(row["shares"].values()) == pytest.approx(1.0, abs=1e-9)
    assert all(share > -1e-3 for share in row["shares"].values())
    assert row["shares"]["simulate"] > 0 and row["seconds"]["simulate"] > 0
    # the profile's iteration and the CEM's own clock time the same stretch
    assert sum(row["seconds"].values()) == pytest.approx(row["iteration_s"], rel=0.05)
    assert row["simulate_ratio"] == pytest.approx(row["seconds"]["simulate"] / row["limit_s"])


def test_the_table_has_a_header_and_a_line_per_size(run):
    lines, record = run
    header, line = lines
    assert header.split()[:3] == ["n", "steps/it", "ms/step"] and header.split()[-7:] == \
        list(SHARES)
    cells = line.split()
    (row,) = record["rows"]
    assert cells[:2] == [str(N), str(row["steps"])]
    assert len(cells) == len(header.split())


def test_breakdown_counts_a_nested_call_once():
    """A piece's function called from another of the same piece counts once; the service's
    own time is its call less the simulation and the verdict, Python's the rest."""
    import mujoco.batch

    from dopt.rollout import RolloutService
    from dopt.stability import Scan
    from planners.bench.cem import _label
    from planners.cem import CEM

    it, svc, sim = (_label(f) for f in (CEM._iterate, RolloutService.rollout,
                                         mujoco.batch.Batch.rollout))
    upd, flag = _label(Scan.update), _label(Scan.flag)
    stats = {it: (1, 1, 0.1, 10.0, {}),
             svc: (1, 1, 0.5, 6.0, {it: (1, 1, 0.5, 6.0)}),
             sim: (1, 1, 1.5, 1.5, {svc: (1, 1, 1.5, 1.5)}),
             upd: (1, 1, 1.0, 3.0, {svc: (1, 1, 1.0, 3.0)}),
             flag: (2, 2, 2.0, 2.0, {upd: (1, 1, 1.0, 1.0), svc: (1, 1, 1.0, 1.0)})}
    parts = breakdown(stats)
    assert parts["iteration"] == 10.0
    assert parts["simulate"] == 1.5
    assert parts["stability"] == pytest.approx(4.0)       # update 3 (holding 1 of flag) + 1
    assert parts["service"] == pytest.approx(0.5)
    assert parts["python"] == pytest.approx(4.0)
    assert sum(parts[k] for k in SHARES) == pytest.approx(10.0)


@pytest.mark.parametrize("argv, message", [
    (["--sizes", "2"], "argument --sizes: particles per side must be finite and >= 3, got 2"),
    (["--sizes", "10,10"], "argument --sizes: 10 given twice"),
    (["--iterations", "0"], "argument --iterations: must be >= 1, got 0"),
    (["--threads", "-1"], "argument --threads: must be >= 0, got -1"),
    (["--candidates", "some"], "argument --candidates: invalid choice: 'some'"),
    (["--step-samples", "x"], "argument --step-samples: 'x' is not an integer"),
])
def test_a_bad_flag_is_one_usage_error_line(capsys, monkeypatch, argv, message):
    import planners.bench.cem as bench

    def stop(*args, **kwargs):
        raise AssertionError("the arguments were accepted")
    monkeypatch.setattr(bench, "bench_cem_limit", stop)
    with pytest.raises(SystemExit) as exc:
        main(["cem-limit", *argv])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    errors = [line for line in err.splitlines() if "error:" in line]
    assert len(errors) == 1 and "Traceback" not in err
    assert errors[0].startswith("python -m planners.bench cem-limit: error: ")
    assert message in errors[0]
