"""experiments/report.py on synthetic state-vector-reduction results: Table 1 beside the
paper, Fig. 4, clock checks, derivative variants, MPC sweeps in progress and the machine speed
behind the virtual clock."""
import json

import numpy as np
import pytest

from dopt.lab.report import base
from planners.svr_mpc.experiments import report_map as svr_map
from planners.svr_mpc.experiments import report_svr
from tests.dopt.lab.report.report_site import (
    _trial,
    block,
    headlines,
    make_site,
    mpc_row,
    provenance,
    run,
    snapshot,
    table1,
    write,
)


@pytest.fixture
def site(tmp_path, monkeypatch):
    """A results site (``report_site.make_site``)."""
    return make_site(tmp_path, monkeypatch)


def test_table1_renders_its_rows(site):
    write(site["results"], "table1_clutter.json", table1())
    assert run(site) == 0
    md = site["md"].read_text()
    assert "| baseline | 1.00 ± 0.00 | 1.00 | 189 | 55.0 | 3.0 | 0.85 | 0.012 | 1 | - | 20 |" in md
    assert "| svr-sum | 0.86 ± 0.10 | 0.86 | 93 | 21.0 | 3.0 | 0.85 | 0.012 | 1 | - | 20 |" in md
    assert "1 failed trial(s)" in md and "svr-sum-seed7" in md
    assert "svr-sum 0.86 ± 0.10 (93 ms, 21.0 DoFs)" in headlines(site)


def test_table1_says_whether_each_svr_row_beats_rand_and_baseline(site):
    from planners.svr_mpc import versus

    records = [{"params": {"method": m, "theta": t, "rho": 1.0, "seed": k},
                "result": {"mpc_cost": c * (1 + 0.01 * ((k * i) % 5)),
                           "goal_distance_end": 0.01}}
               for k in range(8) for i, (m, t, c) in enumerate(
                   (("baseline", 0, 100.0), ("rand", 5, 60.0), ("svr-sum", 10, 80.0)))]
    write(site["results"], "table1_clutter.json", {**table1(), "versus": versus(records)})
    assert run(site) == 0
    md = site["md"].read_text()
    assert "| sum-t10-r1 | baseline | 0.82 |" in md and "| cheaper |" in md
    assert "| sum-t10-r1 | rand-t5 | 1.34 |" in md and "| dearer |" in md
    assert ("against baseline, 1 of 1 SVR rows cheaper and 0 dearer, against rand-t5, 0 of 1 "
            "SVR rows cheaper and 1 dearer") in headlines(site)


# ------------------------------------------------------------- Table 1 beside the paper
@pytest.mark.parametrize("seed", range(20))
def test_kendall_tau_b_equals_scipys(seed):
    from scipy.stats import kendalltau

    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 12))
    x = rng.integers(0, 5, n).astype(float).tolist()      # ties in both lists
    y = rng.integers(0, 5, n).astype(float).tolist()
    want = kendalltau(x, y).statistic
    got = report_svr.kendall_tau_b(x, y)
    if np.isnan(want):
        assert got is None
    else:
        assert got == pytest.approx(want)


def test_orderings_name_reversed_pairs_and_those_with_separate_intervals():
    paper = {"a": (0.80, 0.02), "b": (0.90, 0.02), "c": (1.00, 0.02), "d": (0.85, None)}
    ours = {"a": (0.95, 0.01), "b": (0.70, 0.01), "c": (0.96, 0.10), "e": (0.1, 0.1)}
    o = report_svr.orderings(paper, ours)
    assert o["rows"] == ["a", "b", "c"]                    # d, e: in one column only
    assert o["paper_order"] == ["a", "b", "c"] and o["our_order"] == ["b", "a", "c"]
    assert o["reversed"] == [("a", "b")]
    assert o["reversed_separate"] == [("a", "b")]          # 0.1 > 0.04 and 0.25 > 0.02
    # Holm over each column's three pairs: a-b apart in both (z 5.8 on the paper's, 20 on ours)
    assert o["reversed_holm"] == [("a", "b")]
    assert o["holm"]["paper"]["a", "b"][2] and o["holm"]["ours"]["a", "b"][2]
    ours["b"] = (0.94, 0.01)                               # ours now within the intervals
    assert report_svr.orderings(paper, ours)["reversed_separate"] == []
    assert report_svr.orderings(paper, ours)["reversed_holm"] == []
    assert report_svr.orderings(paper, ours)["kendall_tau"] == pytest.approx(1 / 3)


def test_table1_of_the_paper_protocol_is_shown_beside_the_published_table(site):
    data = table1()
    data.update(preset="paper", methods={"baseline": mpc_row(1.0, 0.0, 130.0, 55.0),
                                         "sum-t10-r1": mpc_row(0.70, 0.02, 50.0, 17.0),
                                         "rand-t5": mpc_row(0.95, 0.02, 40.0, 12.0)},
                paired={"sum-t10-r1": {"ratio_geomean": 0.68, "ratio_ci90": [0.6, 0.75]}})
    write(site["results"], "table1-clutter.json", data)
    assert run(site) == 0
    assert "beside the paper" not in site["md"].read_text()     # no published table yet
    pub = {"clutter": {"baseline": {"mpc_cost": 1.0, "mpc_cost_ci90": 0.034, "opt_ms": 485.7,
                                    "n_dofs": 55.0},
                       "sum-t10-r1": {"mpc_cost": 0.86, "mpc_cost_ci90": 0.032, "opt_ms": 287.0,
                                      "n_dofs": 29.8},
                       "rand-t5": {"mpc_cost": 0.94, "mpc_cost_ci90": 0.033, "opt_ms": 148.9,
                                   "n_dofs": 12.0}}}
    write(site["results"], "paper-svr.json",
          {"experiment": "paper_svr", "tasks": {"clutter": {"rows": {
              "sum-t10-r1": {"n_runs": 100, "median_ratio": 0.87, "final_dist_mean": 0.2,
                             "avg_dofs": 29.8, "opt_ms": 287.0}}}},
           "published": pub, "provenance": provenance("python experiments/paper_reference.py")})
    assert run(site) == 0
    md = site["md"].read_text()
    assert ("| sum-t10-r1 | 0.86 ± 0.032 | 0.70 ± 0.02 | n/a | 0.68 [0.60, 0.75] | 0.87 | "
            "29.8 / 17.0 | 287 / 50 |") in md
    assert "Cheapest first, paper: sum-t10-r1, rand-t5, baseline; ours: sum-t10-r1, rand-t5, " \
           "baseline." in md
    assert "Kendall tau 1.00 over 3 rows; 0 of 3 pairs in the opposite order" in headlines(site)
    # the same run on the authors' problems, with its Holm verdicts, is the one shown beside
    # the paper and in the README's map; the run on our problems keeps its own map row
    versus = {"alpha": 0.05, "family_size": 2, "references": ["baseline", "rand-t5"],
              "pairs": {f"sum-t10-r1 vs {ref}": {
                  "row": "sum-t10-r1", "reference": ref, "ratio_geomean": g,
                  "ratio_ci_simultaneous": [g - 0.05, g + 0.05], "p": 1e-4, "p_holm": 2e-4,
                  "better": 9, "pairs": 10, "verdict": verdict}
                  for ref, g, verdict in (("baseline", 0.7, "cheaper"), ("rand-t5", 0.9,
                                                                         "cheaper"))}}
    write(site["results"], "table1-clutter-authors.json",
          {**data, "preset": "authors", "problem": "authors", "versus": versus})
    assert run(site) == 0
    assert "### clutter: `table1-clutter-authors.json` beside the paper" in site["md"].read_text()
    readme = block(site["readme"])
    assert ("SVR cheaper:dearer/n vs baseline, rand-t5 (Holm): clutter 1:0/1, 1:0/1; tau vs "
            "paper 1.00") in readme
    assert "Table 1 on dopt's own push tasks" in readme
    # the same rows lagging alike explain the order; they are not the Table 1 beside the paper
    write(site["results"], "table1-clutter-authors-ms150.json",
          {**data, "preset": "authors", "problem": "authors", "versus": versus, "clock": "model",
           "clock_ms": 150.0, "methods": {"baseline": mpc_row(1.0, 0.0, 150.0, 55.0),
                                          "sum-t10-r1": mpc_row(0.80, 0.02, 150.0, 30.0),
                                          "rand-t5": mpc_row(0.90, 0.02, 150.0, 12.0)}})
    assert run(site) == 0
    md = site["md"].read_text()
    assert "### clutter: `table1-clutter-authors.json` beside the paper" in md
    assert ("Every row lagging alike (`table1-clutter-authors-ms150.json`: every optimisation "
            "150 ms on the model clock, 20 scenes), cheapest first (mean cost / baseline): "
            "sum-t10-r1 0.80, rand-t5 0.90, baseline 1.00; Kendall tau against the paper's "
            "order 1.00; Holm's correction at 5 %: against baseline, 1 of 1 SVR rows cheaper") in md
    assert "(Holm): clutter 1:0/1, 1:0/1; tau vs paper" in block(site["readme"])


def test_clock_check_headline_gives_the_lag_ratios(site):
    row = {"real": {"n_trials": 10, "lag_steps_mean": 20.0}, "virtual": {"n_trials": 10},
           "lag_ratio": 0.64, "opt_ms_ratio": 0.64, "lag_within_10_percent": False,
           "cost_intervals_overlap": True}
    write(site["results"], "clock-check-clutter.json",
          {"experiment": "clock_check", "task": "clutter", "preset": "paper",
           "rows": {"rand-t5": row, "baseline": {**row, "cost_intervals_overlap": False}},
           "failed": {}, "provenance": provenance("python experiments/clock_check.py")})
    assert run(site) == 0
    assert ("clutter: lag virtual / real rand-t5 0.64, baseline 0.64; MPC cost intervals "
            "overlap on 1 of 2 rows (10 seeds each)") in headlines(site)


def test_a_derivative_variant_run_has_its_own_row_not_table1s(site):
    """A run with rows +skip5 (derivatives_effect) gets the key-timestep row of the README,
    its variant table in RESULTS.md, and is never taken for the task's Table 1."""
    data = table1()
    data.update(preset="paper", methods={"baseline": mpc_row(1.0, 0.0, 130.0, 55.0),
                                         "sum-t10-r1": mpc_row(0.80, 0.02, 53.0, 17.0),
                                         "sum-t10-r1 +skip5": mpc_row(0.78, 0.02, 30.0, 17.0)},
                derivatives_effect={"sum-t10-r1 +skip5": {
                    "versus": "sum-t10-r1", "ratio_geomean": 0.97, "ratio_ci90": [0.94, 1.01],
                    "better": 61, "pairs": 100, "lag_steps_mean": 7.5,
                    "versus_lag_steps_mean": 13.4, "opt_ms_mean": 30.2,
                    "versus_opt_ms_mean": 53.9}})
    write(site["results"], "keypoints-clutter.json", data)
    assert run(site) == 0
    readme = headlines(site)
    assert ("sum-t10-r1 +skip5 / sum-t10-r1: MPC cost 0.97 (0.94-1.01), lag 7.5 / 13.4 steps, "
            "opt. time 30 / 54 ms (100 seeds)") in readme
    row = next(line for line in readme.splitlines() if "keypoints-clutter.json" in line)
    assert "FD at every K-th timestep" in row
    table1_row = next(line for line in readme.splitlines() if "Table 1: clutter" in line)
    assert "not recorded yet" in table1_row
    assert "| sum-t10-r1 +skip5 | sum-t10-r1 | 0.97 | 0.94-1.01 | 61/100 | 7.5 / 13.4 | 30 / 54 |" \
        in site["md"].read_text()
    assert report_svr.paper_preset_table1(base.load_results(site["results"]), "clutter") is None


def test_a_run_of_other_optimisers_rows_is_never_taken_for_table1(site):
    """A record of baseline and an optimiser's row only (``--rows baseline,unoptimised``),
    newest by name, renders its own section but the README's Table 1 row stays on the run
    with the paper's rows."""
    data = table1()
    data.update(preset="authors", methods={"baseline": mpc_row(1.0, 0.0, 266.0, 55.0),
                                           "sum-t10-r1": mpc_row(0.93, 0.02, 170.0, 32.0)})
    write(site["results"], "table1-clutter-authors.json", data)
    other = table1()
    other.update(preset="authors", methods={"baseline": mpc_row(1.0, 0.0, 266.0, 55.0),
                                            "unoptimised": mpc_row(0.98, 0.02, 0.0, 0.0)})
    write(site["results"], "table1-clutter-authors_other.json", other)
    assert run(site) == 0
    chosen = report_svr.paper_preset_table1(base.load_results(site["results"]), "clutter")
    assert chosen.path.name == "table1-clutter-authors.json"
    assert "| unoptimised | 0.98 ± 0.02 |" in site["md"].read_text()


def test_a_table1_result_is_checked_on_its_trials_settings(site):
    """Table 1's protocol is in every trial's params: a trial run on another cost than the
    paper preset gives today is stale, unless the command set that cost itself."""
    snapshot(site)
    data = table1()
    data["preset"] = "paper"
    cmd = "python experiments/mpc.py --task clutter --preset paper --out docs/results/runs/t1"
    data["provenance"] = provenance(cmd)
    write(site["results"], "table1-clutter.json", data)
    _trial(site["results"] / "runs" / "t1" / "trials", "clutter-baseline-seed0",
           {"task": "clutter", "method": "baseline", "seed": 0, "cost": "paper-reach",
            "clock": "virtual", "control_noise": 0.05}, "c" * 40)
    assert run(site) == 0
    assert ("**stale**: protocol `paper` on clutter now sets cost \"paper-reach\" → \"paper\"" in
            headlines(site))
    data["provenance"] = provenance(cmd + " --cost paper-reach")
    write(site["results"], "table1-clutter.json", data)
    assert run(site) == 0
    assert "stale" not in headlines(site)


def test_fig4_rows_read_the_authors_sweep_with_the_most_scenes_and_ours_apart(site):
    """The authors' Fig. 4 row reads the authors' sweep with the most scenes per point (a
    5-scene sweep beside a 100-scene one), with its interval; dopt's own clutter has its row."""

    def fig4(problem, trials, cost, command):
        points = [dict(rho=r, theta=10, n_trials=trials, **mpc_row(c, 0.1, 50.0, 20.0, trials))
                  for r, c in [(1.0, 1.1), (100.0, cost)]]
        return {"experiment": "fig4", "task": "clutter", "method": "svr-sum",
                "problem": problem, "points": points, "failed": {},
                "provenance": provenance(command)}

    write(site["results"], "fig4-a-full.json",
          fig4("authors", 100, 0.9, "python experiments/rho_sweep.py --preset authors"))
    write(site["results"], "fig4-b.json",
          fig4("authors", 5, 0.7, "python experiments/rho_sweep.py --preset authors"))
    write(site["results"], "fig4-ours.json",
          fig4("ours", 20, 0.5, "python experiments/rho_sweep.py --preset paper"))
    assert run(site) == 0
    results = base.load_results(site["results"])
    assert svr_map.fig4_line(results, "authors") == (
        "clutter: lowest cost / baseline 0.90 ± 0.10 (90 % CI) at rho 100, theta 10; 2 rho "
        "from 1 to 100; 100 scenes per point")
    assert svr_map.fig4_line(results).startswith("clutter: lowest cost / baseline 0.50")
    # with every point against the baseline (one Holm family) the row counts the verdicts
    data = fig4("authors", 100, 0.9, "python experiments/rho_sweep.py --preset authors")
    data["versus"] = {"alpha": 0.05, "family_size": 2, "references": ["baseline"], "pairs": {
        f"sum-t10-r{r} vs baseline": {"row": f"sum-t10-r{r}", "reference": "baseline",
                                      "verdict": v} for r, v in [(1, "no difference shown"),
                                                                 (100, "cheaper")]}}
    write(site["results"], "fig4-a-full.json", data)
    assert svr_map.fig4_line(base.load_results(site["results"]), "authors").endswith(
        "; 100 scenes per point; Holm: 1/2 points cheaper, 0 dearer")
    readme = block(site["readme"])
    assert readme.index("| Fig. 4 on the authors' clutter: rho and theta |") < \
        readme.index("| Fig. 4 on dopt's own clutter (a second benchmark) |")
    # a sweep on the authors' executor (their regime) is read before the paper's Alg. 1, even
    # with fewer scenes per point
    on_theirs = fig4("authors", 20, 0.8, "python experiments/rho_sweep.py --preset authors")
    write(site["results"], "fig4-c-executor.json", {**on_theirs, "executor": "authors"})
    assert svr_map.fig4_line(base.load_results(site["results"]), "authors").startswith(
        "clutter: lowest cost / baseline 0.80")


def test_fig4_beside_the_authors_runs_ranks_both_sides_on_the_same_statistic(site):
    """A Fig. 4 summary beside the authors' runs of the same points: Kendall tau-b (scipy's) of
    the two sides' median cost ratios, and of each side's ratios against its mean |C|, over
    the common points only; nothing without the authors' file."""
    from scipy.stats import kendalltau

    rng = np.random.default_rng(5)
    grid = [(t, r) for t in (0, 10) for r in (1.0, 100.0, 500.0)]
    ours = {k: (float(rng.uniform(0.8, 1.1)), float(rng.uniform(8, 35))) for k in grid}
    theirs = {k: (float(rng.uniform(0.8, 1.1)), float(rng.uniform(8, 35))) for k in grid}
    theirs[(5, 1.0)] = (0.9, 20.0)                        # a point only they ran
    points = [dict(rho=r, theta=t, n_trials=5, mpc_cost_median_ratio=ours[t, r][0],
                   n_dofs_mean=ours[t, r][1], **mpc_row(1.0, 0.1, 50.0, ours[t, r][1], 5))
              for t, r in grid]
    write(site["results"], "fig4-x.json",
          {"experiment": "fig4", "task": "clutter", "method": "svr-sum", "problem": "authors",
           "points": points, "failed": {}, "provenance": provenance("python rho_sweep.py")})
    assert run(site) == 0
    assert "Fig. 4 beside the authors' runs" not in site["md"].read_text()
    write(site["results"], "paper-svr.json",
          {"experiment": "paper_svr", "tasks": {"clutter": {"rows": {}, "fig4": [
              {"theta": t, "rho": r, "median_ratio": c, "avg_dofs": n}
              for (t, r), (c, n) in theirs.items()]}},
           "provenance": provenance("python experiments/paper_reference.py")})
    assert run(site) == 0
    page = site["md"].read_text()

    def tau(x, y):
        return f"{kendalltau(x, y).statistic:.2f}"
    want = (f"`clutter`, 6 points in common: our points' order against theirs "
            f"{tau([theirs[k][0] for k in grid], [ours[k][0] for k in grid])}; cost against "
            f"mean |C| {tau([ours[k][1] for k in grid], [ours[k][0] for k in grid])} here, "
            f"{tau([theirs[k][1] for k in grid], [theirs[k][0] for k in grid])} in their runs.")
    assert want in page


def test_each_fig4_summary_shows_its_own_figure(site):
    """A Fig. 4 section embeds the figure named after its own summary (docs/images/<stem>.png),
    never another sweep's of the same task; a summary without one shows none."""
    def fig4(problem):
        return {"experiment": "fig4", "task": "clutter", "method": "svr-sum", "problem": problem,
                "points": [dict(rho=1.0, theta=10, n_trials=5, **mpc_row(1.1, 0.1, 50.0, 20.0, 5))],
                "failed": {}, "provenance": provenance("python experiments/rho_sweep.py")}

    write(site["results"], "fig4-mine.json", fig4("ours"))
    write(site["results"], "fig4-theirs.json", fig4("authors"))
    images = site["md"].parent / "images"
    images.mkdir(parents=True)
    (images / "fig4-mine.png").write_bytes(b"png")
    assert run(site) == 0
    page = site["md"].read_text()
    mine = page[page.index("`fig4-mine.json`"):]
    theirs = page[page.index("`fig4-theirs.json`"):]
    assert "(images/fig4-mine.png)" in mine.split("###")[0]
    assert "images/" not in theirs.split("###")[0]


def test_an_mpc_sweep_in_progress_is_counted_until_a_summary_names_it(site):
    """Committed MPC trials that no summary's --out names are counted per row and scene in
    "MPC sweeps in progress" (no costs); once a recorded summary names the folder they are
    its trials and the section is gone."""
    trials = site["results"] / "runs" / "fig4-x" / "trials"
    base = {"task": "clutter", "problem": "authors", "theta": 0}
    for seed in range(3):
        _trial(trials, f"b{seed}", {**base, "method": "baseline", "rho": 1.0, "seed": seed},
               "a" * 40)
        for rho in (1.0, 10.0):
            if (seed, rho) != (2, 10.0):
                _trial(trials, f"s{rho:g}-{seed}", {**base, "method": "svr-sum", "rho": rho,
                                                     "seed": seed}, "b" * 40)
    write(site["results"], "t1.json", table1())                  # a summary naming no folder
    assert run(site) == 0
    md = site["md"].read_text()
    assert "## MPC sweeps in progress" in md
    assert ("### `fig4-x`: clutter, the authors' problem\n\n8 trials over 3 rows (method, rho, "
            "theta: baseline 1, svr-sum 2), 2-3 scenes each (seeds 0-2); written at `bbbbbbbb` "
            "(5), `aaaaaaaa` (3); machine not recorded (times may mix machines).") in md
    data = table1()
    data["provenance"] = provenance("python experiments/rho_sweep.py --out "
                                    "docs/results/runs/fig4-x --record docs/results/x.json")
    write(site["results"], "x.json", data)
    assert run(site) == 0
    assert "## MPC sweeps in progress" not in site["md"].read_text()


def test_mpc_trials_that_all_keep_their_controls_are_named_replayable(site):
    """A folder whose every trial keeps its executed controls (--keep-controls: episodes
    committed for the viewer) says that dopt-view replays it; one trial without them and the
    folder reads as a plain sweep part-way."""
    trials = site["results"] / "runs" / "replays-x" / "trials"
    base = {"task": "clutter", "problem": "authors", "theta": 0, "rho": 1.0, "seed": 0}
    for method in ("baseline", "svr-sum"):
        _trial(trials, method, {**base, "method": method}, "c" * 40)
        path = trials / f"{method}.json"
        record = json.loads(path.read_text())
        record["result"].update(start_state=[0.0], controls=[[0.0]])    # CONTROLS_FIELDS
        path.write_text(json.dumps(record))
    write(site["results"], "t1.json", table1())
    assert run(site) == 0
    sentence = ("Every trial keeps its start state and executed controls: `dopt-view "
                "docs/results/runs/replays-x` replays them.")
    assert sentence in site["md"].read_text()
    _trial(trials, "naive", {**base, "method": "naive"}, "c" * 40)          # no controls
    assert run(site) == 0
    md = site["md"].read_text()
    assert "### `replays-x`" in md and sentence not in md


def test_machine_speed_behind_the_virtual_clock_compares_each_sweeps_own_baselines(site):
    """Per group of sweeps with the same baseline settings under the virtual clock: the one with
    the most baseline scenes is the reference; another sweep's own baseline trials (not copies
    of the reference's) give per scene the ratio of the mean optimisation times. Model-clock
    sweeps and groups of copies only are left out."""
    runs = site["results"] / "runs"
    base = {"task": "clutter", "problem": "authors", "method": "baseline", "rho": 1.0,
            "theta": 0, "clock": "virtual", "clock_ms": None}

    def baseline(sweep, seed, ms, params=base, cost=1.0):
        folder = runs / sweep / "trials"
        folder.mkdir(parents=True, exist_ok=True)
        (folder / f"b{seed}.json").write_text(json.dumps(
            {"key": f"b{seed}", "params": {**params, "seed": seed},
             "result": {"opt_ms_mean": ms, "mpc_cost": cost},
             "code": {"version": "0.2.0", "commit": "a" * 40}}))

    for seed in range(6):
        baseline("table1-ref", seed, 100.0 + seed)                      # the reference
        baseline("copies", seed, 100.0 + seed)                          # the same trials
        baseline("model", seed, 300.0, {**base, "clock": "model"})
    baseline("fig4-slow", 5, 105.0)                  # a copy of the reference's: not counted
    for seed, ms in [(0, 150.0), (1, 101.0), (2, 204.0), (3, 103.0), (7, 500.0)]:
        baseline("fig4-slow", seed, ms, cost=2.0)                       # seed 7: no reference
    for seed in range(2):
        baseline("ours", seed, 50.0, {**base, "problem": "ours"})       # a group of one
    write(site["results"], "t1.json", table1())
    assert run(site) == 0
    md = site["md"].read_text()
    section = md[md.index("## Machine speed behind the virtual clock"):]
    assert "| `table1-ref` (reference) | clutter, authors | 6 | - | 102 ms per optimisation " \
           "| - | - |" in section
    # ratios 1.5, 1.0, 2.0, 1.0 on seeds 0-3: median 1.25, deciles 1.00 and 1.85
    assert "| `fig4-slow` |  | 6 | 4 | 1.25 | 1.00-1.85 | 2 (seeds 0, 2) |" in section
    assert "`copies`" not in section and "`model`" not in section and "`ours`" not in section


def test_a_table1_file_with_flagged_episodes_says_so_and_the_map_reads_no_means_off_few(site):
    """The headline counts each row's episodes flagged unstable (they are left out of the
    means); the README map gives no mean of a task whose baseline is kept (neither outlier
    nor unstable) in under half its episodes, and no Kendall tau for it."""

    def soft(unstable_baseline):
        data = table1()
        base = {**mpc_row(1.0, 0.0, 1500.0, 115.0), "n_unstable_trials": unstable_baseline}
        data.update(task="soft", preset="paper",
                    methods={"baseline": base,
                             "sum-t10-r1": {**mpc_row(0.49, None, 1400.0, 107.0),
                                            "n_unstable_trials": 18},
                             "rand-t5": mpc_row(0.39, 0.37, 270.0, 12.0)})
        return data

    write(site["results"], "table1-soft.json", soft(18))
    assert run(site) == 0
    assert ("episodes flagged unstable (left out of the means): baseline 18/20, "
            "sum-t10-r1 18/20") in headlines(site)
    results = base.load_results(site["results"])
    assert svr_map.table1_line(results, "paper") == (
        "cheapest reduced row / baseline: soft n/a (baseline kept 1/20)")
    write(site["results"], "table1-soft.json", soft(9))     # kept 10 of 20: half, enough
    results = base.load_results(site["results"])
    assert svr_map.table1_line(results, "paper") == (
        "cheapest reduced row / baseline: soft rand-t5 0.39")
    # with verdicts against rand: those stand, the baseline's are n/a when it is kept too little
    pair = {"row": "sum-t10-r1", "reference": "rand-t5", "verdict": "dearer"}
    data = {**soft(18), "versus": {"alpha": 0.05, "family_size": 1, "references":
                                   ["baseline", "rand-t5"],
                                   "pairs": {"sum-t10-r1 vs rand-t5": pair}}}
    write(site["results"], "table1-soft.json", data)
    results = base.load_results(site["results"])
    assert svr_map.table1_line(results, "paper") == (
        "SVR cheaper:dearer/n vs baseline, rand-t5 (Holm): soft n/a (kept 1/20), 0:1/1")


def test_the_protocol_line_says_when_the_push_plan_ends_braking():
    from planners.svr_mpc.experiments.report_svr import protocol_line

    d = {"preset": "paper", "cost": "paper-reach", "warm_start": True, "clock": "real",
         "control_noise": 0.05, "fd": "forward", "slowdown": 3.0}
    assert "braking" not in protocol_line(d)
    assert "braking" not in protocol_line({**d, "push_tail": True})
    assert "push plan ending braking (`--push-tail off`)" in protocol_line(
        {**d, "push_tail": False})
