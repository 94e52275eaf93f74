"""experiments/key_particles.py --quick writes its outputs with the counts."""
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[4]


def test_quick_run_writes_summary_curves_and_plots(tmp_path):
    proc = subprocess.run([sys.executable, str(ROOT / "experiments" / "key_particles.py"),
                           "--task", "all", "--quick", "--out", str(tmp_path)], check=True,
                          cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert "goals reduced" in proc.stderr and "7/7" in proc.stderr         # the bar
    assert proc.stdout.strip().splitlines()[-1].startswith(
        f"pictures: {tmp_path / 'rope_straighten.png'} ")
    summary = json.loads((tmp_path / "summary.json").read_text())
    tasks = summary["tasks"]
    assert tasks["rope_straighten"]["n_keys"] == 2
    assert tasks["rope_fold"]["n_keys"] == 4 and tasks["rope_fold_unequal"]["n_keys"] == 4
    assert tasks["cloth_diagonal"]["n_keys"] == 4 and tasks["cloth_diagonal"]["n_elements"] == 4
    assert tasks["cloth_side"]["n_keys"] == 6 and tasks["cloth_side"]["n_elements"] == 6
    assert [g["goal"] for g in tasks["cloth_underneath"]["intermediate_goals"]] == [
        "cloth_side", "cloth_reflective"]
    for name, entry in tasks.items():
        assert len(entry["indices"]) == entry["n_keys"]
        assert entry["error"] < entry["threshold"] and entry["seconds"] > 0
        assert (tmp_path / f"{name}.png").stat().st_size > 10_000
        rows = (tmp_path / f"curve_{name}.csv").read_text().splitlines()
        assert rows[0] == "size,error,threshold,accepted" and len(rows) == len(entry["sizes"]) + 1


def test_help_explains_every_flag():
    out = subprocess.run([sys.executable, str(ROOT / "experiments" / "key_particles.py"),
                          "--help"], check=True, capture_output=True, text=True).stdout
    for flag in ["--task", "--out", "--seed", "--quick", "--n", "--noise-n",
                 "--noise-seeds", "--noise-panels"]:
        assert flag in out


def test_unknown_panel_mode_is_refused_by_name():
    run = subprocess.run([sys.executable, str(ROOT / "experiments" / "key_particles.py"),
                          "--out", "unused", "--noise-panels", "auto,maybe"],
                         capture_output=True, text=True, cwd=ROOT)
    assert run.returncode == 2 and "maybe" in run.stderr


def test_noise_sweep_journals_each_goal_and_a_rerun_resumes(tmp_path):
    from deformables import ClothConfig, RopeConfig
    from planners.pick_place.experiments import key_particles

    journal = tmp_path / "noise.jsonl"
    args = (RopeConfig(), ClothConfig(), [1e-3], [12], 1, ["auto", "off"])
    rows, failed = key_particles.noise_sweep(journal, *args)
    assert failed == {}
    assert len(rows) == 3 + 4 * 4 * 2        # rope tasks + folds x triangulations x modes
    lines = journal.read_text().splitlines()
    assert len(lines) == len(rows)
    journal.write_text("\n".join(lines[:-5]) + "\n")    # a sweep killed 5 goals before the end
    again, failed = key_particles.noise_sweep(journal, *args)
    assert failed == {}
    assert len(journal.read_text().splitlines()) == len(rows)
    assert sorted(map(str, again)) == sorted(map(str, rows))     # same seeds, same counts
    table = key_particles.noise_table(again)
    assert table["rope"]["1 mm"] == "3/3"                 # rope counts hold at 1 mm
    assert set(table) == {"rope", "cloth, panels auto", "cloth, panels off"}
