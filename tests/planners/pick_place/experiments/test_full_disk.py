"""A full disk never cuts the pick experiments' curves.csv short (#92; it was left empty): a
rewrite with no room keeps the old file whole and the error names it (the lab's files:
tests/dopt/lab/test_full_disk.py)."""

from planners.pick_place.experiments.pictures import write_curves
from tests.dopt.lab.run_files import rewrite_on_a_full_disk


def curves(n_iterations: int) -> list[dict]:
    return [{"method": m, "seed": s, "cost_history": [0.1 / (i + 1) for i in range(n_iterations)],
             "stage_of_iteration": [0] * n_iterations} for m in ("pp", "rand") for s in range(3)]


def curves_csv(out, big: bool):
    write_curves(out / "curves.csv", curves(400 if big else 2))


def test_a_rewrite_on_a_full_disk_keeps_the_old_curves_and_names_them(tmp_path, monkeypatch):
    rewrite_on_a_full_disk(tmp_path, monkeypatch, curves_csv, "curves.csv")
