"""python -m deformables.bench: the paper-scale timing and the paper-vs-default comparison run
and write what they measured (at a small size here; the timings themselves are not tested)."""
import json

import numpy as np
import pytest

from deformables import bench
from deformables.goals import TRIANGULATIONS, make_goal


def test_compare_runs_the_pipelines_on_the_same_goals():
    record = bench.compare(resolutions=(12,), noise=5e-4, triangulations=("anti",))
    assert len(record["goals"]) == 8                      # 4 folds x (exact, noisy)
    for row in record["goals"]:
        for name in bench.PIPELINES:
            result = row[name]
            assert result["seconds"] > 0 and result["n_keys"] >= 1
            assert result["reached_threshold"] == (result["error"] < result["threshold"])
        assert row["default"]["n_keys"] == row["reference_keys"]
        # 242 faces, fewer than shared_faces: the restarts start from the goal either way
        same = ("n_keys", "n_elements", "error")
        assert [row["separate-restarts"][k] for k in same] == [row["default"][k] for k in same]
    summary = record["summary"]
    assert set(summary) == {"default", "paper", "separate-restarts"}
    side = summary["default"]["noise_0"]["cloth_side"]
    assert side == {**side, "goals": 1, "keys_held": 1, "counts_as_first": 1,
                    "faces": {"6": 1}, "keys": {"6": 1}}
    assert all(fold["counts_as_first"] == 1
               for level in summary["separate-restarts"].values() for fold in level.values())


def test_paper_scale_times_the_four_folds_with_and_without_noise():
    record = bench.paper_scale(cloth_n=12, noise=5e-4)
    assert [(r["task"], r["noise_m"]) for r in record["goals"]] == [
        (task, sigma) for sigma in (0.0, 5e-4) for task in bench.CLOTH_TASKS]
    sticks = record["yardstick"]
    assert len(sticks) == 2 and all(s["faces"] == 242 and s["target_faces"] == 24
                                    and s["seconds"] > 0 for s in sticks)
    stick = (sticks[0]["seconds"] + sticks[1]["seconds"]) / 2
    for level in ("noise_0", "noise_0.0005"):
        summary = record["summary"][level]
        assert summary["keys_held"] == 4
        assert summary["paper_seconds"] == 0.73
        assert summary["yardstick_seconds"] == pytest.approx(stick, abs=1e-4)
        assert summary["ratio_to_yardstick"] == pytest.approx(
            summary["mean_seconds"] / stick, rel=1e-2)


def test_a_task_is_timed_against_the_paper_and_the_yardstick():
    row = bench.bench("cloth_side", repeats=1, cloth_n=12, stick=0.05)
    assert row["n_keys"] == 6 and row["paper_seconds"] == 0.73
    assert row["ratio_to_yardstick"] == pytest.approx(row["seconds"] / 0.05, rel=1e-3)
    assert "ratio_to_yardstick" not in bench.bench("rope_fold", repeats=1)


def test_the_yardstick_is_one_decimation_to_a_tenth_of_the_faces():
    """The yardstick decimates the diagonal fold's goal as the reduction would: to a tenth of
    its faces, and no lower than 2."""
    stick = bench.yardstick(cloth_n=6, repeats=1)
    assert stick == {**stick, "faces": 50, "target_faces": 5}
    assert stick["seconds"] > 0


def test_main_writes_the_record(tmp_path, capsys):
    out = tmp_path / "compare.json"
    bench.main(["paper-scale", "--cloth-n", "12", "--out", str(out)])
    record = json.loads(out.read_text())
    assert record["mode"] == "paper-scale" and record["cloth_n"] == 12
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 9 and "summary" in json.loads(lines[-1])


def test_authors_mode_reads_goals_in_the_authors_format(tmp_path, monkeypatch):
    """Our own 12 x 12 folds written as the authors' files (float32 ``n * n`` grids, their
    key indices): the mode reduces each in every triangulation and compares with them."""
    from deformables import authors

    layout = {"cloth_diagonal": ("diag", 12, 4), "cloth_side": ("side", 12, 6)}
    for task, (folder, n, _) in layout.items():
        goal = make_goal(task, n=n)
        (tmp_path / folder).mkdir()
        np.save(tmp_path / folder / "particle_pos_ini.npy", goal.rest_positions.astype(np.float32))
        np.save(tmp_path / folder / "particle_pos_final.npy", goal.positions.astype(np.float32))
        corners = [0, n - 1, n * (n - 1), n * n - 1]
        np.save(tmp_path / folder / "key_point_index.npy", np.array(corners, dtype=np.int64))
    monkeypatch.setattr(authors, "AUTHORS_CLOTH", layout)
    monkeypatch.setattr(bench, "AUTHORS_CLOTH", layout)
    out = tmp_path / "authors.json"
    bench.main(["authors", "--external", str(tmp_path), "--out", str(out)])
    record = json.loads(out.read_text())
    rows = record["goals"]
    assert [(r["task"], r["triangulation"]) for r in rows] == [
        (task, t) for task in sorted(layout) for t in TRIANGULATIONS]
    assert all(r["n_elements"] == r["paper_elements"] and r["n_keys"] == r["reference_keys"]
               for r in rows)
    # the diagonal's keys are the four corners; the side fold's six are not
    assert [r["keys_agree"] for r in rows] == [True] * 4 + [False] * 4
    assert record["summary"] == {**record["summary"], "goals": 8, "paper_elements_held": 8,
                                 "keys_held": 8, "keys_agree": 4, "paper_seconds": 0.73}
    assert [stick["faces"] for stick in record["yardstick"]] == [19602, 19602]
    assert record["summary"]["ratio_to_yardstick"] == pytest.approx(
        record["summary"]["mean_seconds"] / record["summary"]["yardstick_seconds"], rel=1e-2)


@pytest.mark.parametrize("argv", [["compare", "--resolutions", "1,2"], ["--noise", "-1"],
                                  ["--cloth-n", "0"], ["sweep"], ["--repeats", "0"],
                                  ["authors"], ["authors", "--external", "/no/such/folder"]])
def test_bad_flags_exit_2(argv):
    with pytest.raises(SystemExit) as exit_:
        bench.main(argv)
    assert exit_.value.code == 2
