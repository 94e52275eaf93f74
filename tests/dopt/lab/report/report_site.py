"""Synthetic result files and a results site (the ``site`` fixture) for the tests of the
report (``dopt.lab.report``, experiments/report.py)."""
import json
from pathlib import Path

import pytest

import planners.pick_place.experiments.report_stale as pick_stale
import planners.svr_mpc.experiments.report_stale as svr_stale
from dopt.lab.report import cli as report
from dopt.lab.report.base import BEGIN, END
from dopt.lab.report.map import HEADLINES_TITLE

ROOT = Path(__file__).resolve().parents[4]
SCRIPT = ROOT / "experiments" / "report.py"


@pytest.fixture
def site(tmp_path, monkeypatch):
    """The site of ``make_site``."""
    return make_site(tmp_path, monkeypatch)


def make_site(tmp_path, monkeypatch) -> dict:
    """A results folder, a README with the markers and the paths report.py writes; today's
    presets (what the stale check compares with) are ``site["presets"]``, none until
    ``snapshot`` sets them."""
    readme = tmp_path / "README.md"
    readme.write_text(f"# project\n\nintro\n\n{BEGIN}\nstale\n{END}\n\nmore\n")
    results = tmp_path / "docs" / "results"
    results.mkdir(parents=True)
    presets = {"pick": {}, "svr_mpc": {}}
    monkeypatch.setattr(pick_stale, "today", lambda: presets["pick"])
    monkeypatch.setattr(svr_stale, "svr_presets", lambda: presets["svr_mpc"])
    return {"results": results, "md": tmp_path / "docs" / "RESULTS.md", "readme": readme,
            "presets": presets}


def provenance(command: str) -> dict:
    return {"command": command, "git_commit": "0123456789abcdef0123456789abcdef01234567",
            "versions": {"python": "3.11.7"}, "date": "2026-11-20T10:00:00+00:00",
            "machine": {"platform": "Linux", "cpus": 2}}


def fig7(**override) -> dict:
    def method(mean, ci, costs, n_candidates, s_per_iteration):
        return {"final_cost_mean": mean, "final_cost_ci95": ci, "final_costs": costs,
                "n_candidates": n_candidates, "n_candidates_per_stage": [n_candidates],
                "s_per_iteration": s_per_iteration, "seeds": list(range(len(costs))),
                "n": len(costs)}

    data = {"experiment": "fig7", "task": "cloth", "goal": "diagonal",
            "settings": {"task": "cloth", "goal": "diagonal", "n": 12, "bound": 0.3,
                         "cem": {"population": 32, "elites": 6, "iterations": 15,
                                 "horizon": 2},
                         "selfcollide": False},
            "methods": {
                "simple": method(0.013649, 0.00051, [0.0137, 0.0138, 0.0134], 4, 2.1),
                "original": method(0.04016, 0.0031, [0.039, 0.041, 0.0405], 144, 2.3),
                "scripted": method(0.01575, None, [0.01575], 4, None)},
            "failed": {}, "wall_s": 301.4,
            "provenance": provenance("python experiments/cloth_fold.py --goal diagonal "
                                     "--record docs/results/fig7_cloth_diagonal.json")}
    data.update(override)
    return data


def mpc_row(mean, ci, ms, dofs, trials=20) -> dict:
    return {"mpc_cost_normalised_mean": mean, "mpc_cost_normalised_ci90": ci,
            "mpc_cost_normalised_median": mean, "opt_ms_mean": ms, "dofs_mean": dofs,
            "lag_steps_mean": 3.0, "success_rate": 0.85, "goal_distance_end_median": 0.0123,
            "outliers": 1, "trials": trials}


def table1() -> dict:
    return {"experiment": "table1", "task": "clutter", "rho": 1.0,
            "theta": {"baseline": 0, "svr-sum": 10}, "slowdown": 10.0,
            "methods": {"baseline": mpc_row(1.0, 0.0, 189.4, 55.0),
                        "svr-sum": mpc_row(0.8567, 0.1049, 93.2, 21.04)},
            "failed": {"svr-sum-seed7": "UnstableRolloutError: rollout 3 step 40"},
            "provenance": provenance("python experiments/mpc.py --task clutter")}


def write(folder: Path, name: str, data: dict) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_text(json.dumps(data, indent=2))
    return path


def run(site, *extra) -> int:
    return report.main(["--results-dir", str(site["results"]), "--results-md", str(site["md"]),
                        "--readme", str(site["readme"]), *extra])


def headlines(site) -> str:
    """RESULTS.md's headline of every result file (what README's block held before its map)."""
    text = site["md"].read_text()
    start = text.index(f"## {HEADLINES_TITLE}")
    return text[start:text.index("\n## ", start + 1)]


def block(readme: Path) -> str:
    text = readme.read_text()
    return text[text.index(BEGIN):text.index(END)]


def trial_record(method: str, seed: int, final_cost: float, wall_s: float, goal="side") -> dict:
    """A trial file as dopt.lab.sweep writes it for experiments/cloth_fold.py."""
    settings = {"task": "cloth", "goal": goal, "n": 20, "selfcollide": False,
                "physics": "default", "cem": {"population": 32, "elites": 6,
                                              "iterations": 30, "horizon": 3}}
    return {"key": f"{method}-seed{seed}-abc", "params": {"settings": settings,
                                                          "method": method, "seed": seed},
            "result": {"method": method, "seed": seed, "final_cost": final_cost,
                       "s_per_iteration": wall_s / 30, "wall_s": wall_s, "n_rollouts": 961,
                       "n_unstable_rollouts": seed % 2, "unstable": False},
            "code": {"version": "0", "commit": "abc"}}


# ------------------------------------------------------------- trials and stale presets
def _trial(folder: Path, key: str, params: dict, commit: str) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / f"{key}.json").write_text(json.dumps(
        {"key": key, "params": params, "result": {"mpc_cost": 1.0},
         "code": {"version": "0.2.0", "commit": commit}}))


def snapshot(site, at_commit=None) -> None:
    """Today's presets: cloth preset default at 5e5 Pa, 5 ms; protocol ours of the diagonal
    fold; the SVR paper protocol on clutter; ``at_commit``: what the presets meant at a
    result's commit ({commit: {"pick": ...}}, the results folder's presets/at-commit.json)."""
    scene = {"n": 16, "side": 0.3, "young": 5e5, "timestep": 0.005, "selfcollide": False}
    settings = fig7()["settings"]
    data = {"pick": {"physics": {"cloth": {"default": scene}},
                     "protocols": {"ours": {"cloth/diagonal": {**settings,
                                                               "physics": "default"}}},
                     "resolved": {"ours": {"cloth/diagonal": {
                         "scene": scene, "picker": {"speed": 0.5, "bound": [0.3] * 3},
                         "stability": {"max_energy_gain": 0.5}}}}},
            "svr_mpc": {"paper": {"clutter": {"cost": "paper", "clock": "virtual",
                                              "control_noise": 0.05}}}}
    site["presets"].update(data)
    if at_commit is not None:
        write(site["results"] / "presets", "at-commit.json", {"at_commit": at_commit})
